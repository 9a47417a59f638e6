"""Embodiments: a robosuite robot, its gripper, and the primitive API it exposes.

Adding an embodiment is data: a row here names the robosuite models, and
``primitives/<api>.yaml`` + ``primitives/<api>.py`` give its primitive API. A robot that lives
outside this package is a directory on ``RECENT_ROBOTS`` (``os.pathsep``-separated): each
``<api>.yaml`` there whose ``robot:`` block names the robosuite models is a row, and the module its
``module:`` names is imported from that directory (docs/add_a_robot.md).
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path

_ASSETS = Path(__file__).parent / "grippers" / "assets"
_BUNDLED_APIS = Path(__file__).parent / "primitives"
ROBOTS_ENV = "RECENT_ROBOTS"  # directories of robots added from files (a YAML with a `robot:` block + its module)


@dataclass(frozen=True)
class Embodiment:
    name: str
    robot: str  # robosuite robot class
    gripper: str  # robosuite gripper class
    api: str  # primitive API: robosuite_envs/primitives/<api>.{py,yaml}
    robot_mjcf: str  # MJCF files read by the ontology builder: relative paths are inside robosuite's package
    gripper_mjcf: str
    description: str
    arm_dof: int = 7  # arm joints (the observation's joint slots it fills; the rest stay 0)
    spec_dir: str = ""  # where <api>.yaml lives: empty for the bundled robosuite_envs/primitives/


EMBODIMENTS: dict[str, Embodiment] = {
    e.name: e
    for e in (
        Embodiment(
            name="Panda",
            robot="Panda",
            gripper="PandaGripper",
            api="panda",
            robot_mjcf="models/assets/robots/panda/robot.xml",
            gripper_mjcf="models/assets/grippers/panda_gripper.xml",
            description="Franka Panda, 7-DoF, parallel-jaw Franka Hand (source robot)",
        ),
        Embodiment(
            name="UR5e",
            robot="UR5e",
            gripper="LinkedRobotiq85Gripper",
            api="ur5e",
            robot_mjcf="models/assets/robots/ur5e/robot.xml",
            gripper_mjcf="models/assets/grippers/robotiq_gripper_85.xml",
            description="Universal Robots UR5e, 6-DoF, Robotiq 2F-85",
            arm_dof=6,
        ),
        Embodiment(
            name="Sawyer",
            robot="Sawyer",
            gripper="RethinkGripper",
            api="sawyer",
            robot_mjcf="models/assets/robots/sawyer/robot.xml",
            gripper_mjcf="models/assets/grippers/rethink_gripper.xml",
            description="Rethink Sawyer, 7-DoF, Rethink parallel gripper",
        ),
        Embodiment(
            name="Robotiq85",
            robot="Panda",
            gripper="LinkedRobotiq85Gripper",
            api="robotiq85",
            robot_mjcf="models/assets/robots/panda/robot.xml",
            gripper_mjcf="models/assets/grippers/robotiq_gripper_85.xml",
            description="Franka Panda with a Robotiq 2F-85 (end-effector variation)",
        ),
        Embodiment(
            name="Suction",
            robot="Panda",
            gripper="SuctionGripper",
            api="suction",
            robot_mjcf="models/assets/robots/panda/robot.xml",
            gripper_mjcf=str(_ASSETS / "suction_gripper.xml"),
            description="Franka Panda with a vacuum gripper (end-effector variation)",
        ),
        Embodiment(
            name="FrankaHand",
            robot="Panda",
            gripper="PandaGripper",
            api="franka_hand",
            robot_mjcf="models/assets/robots/panda/robot.xml",
            gripper_mjcf="models/assets/grippers/panda_gripper.xml",
            description="Franka Panda + Franka Hand, name-based API (end-effector setting's source robot)",
        ),
        # Arms added by the data path alone (a row, a YAML, a module of thin wrappers), each with
        # robosuite's own gripper for it and with a Robotiq 2F-85 (docs/add_a_robot.md).
        Embodiment(
            name="Jaco",
            robot="Jaco",
            gripper="JacoThreeFingerGripper",
            api="jaco",
            robot_mjcf="models/assets/robots/jaco/robot.xml",
            gripper_mjcf="models/assets/grippers/jaco_three_finger_gripper.xml",
            description="Kinova Jaco, 7-DoF, Kinova three-finger hand",
        ),
        Embodiment(
            name="JacoRobotiq85",
            robot="Jaco",
            gripper="LinkedRobotiq85Gripper",
            api="jaco_robotiq85",
            robot_mjcf="models/assets/robots/jaco/robot.xml",
            gripper_mjcf="models/assets/grippers/robotiq_gripper_85.xml",
            description="Kinova Jaco, 7-DoF, Robotiq 2F-85",
        ),
        Embodiment(
            name="Kinova3",
            robot="Kinova3",
            gripper="LinkedRobotiq85Gripper",  # robosuite's default for it is the 2F-85 (unlinked: it stalls)
            api="gen3",
            robot_mjcf="models/assets/robots/kinova3/robot.xml",
            gripper_mjcf="models/assets/grippers/robotiq_gripper_85.xml",
            description="Kinova Gen3, 7-DoF, Robotiq 2F-85",
        ),
        Embodiment(
            name="XArm7",
            robot="XArm7",
            gripper="XArm7PadGripper",  # robosuite's XArm7Gripper with its finger pads named right
            api="xarm",
            robot_mjcf="models/assets/robots/xarm7/robot.xml",
            gripper_mjcf="models/assets/grippers/xarm7_gripper.xml",
            description="UFactory xArm 7, 7-DoF, xArm parallel gripper",
        ),
        Embodiment(
            name="XArm7Robotiq85",
            robot="XArm7",
            gripper="LinkedRobotiq85Gripper",
            api="xarm_robotiq85",
            robot_mjcf="models/assets/robots/xarm7/robot.xml",
            gripper_mjcf="models/assets/grippers/robotiq_gripper_85.xml",
            description="UFactory xArm 7, 7-DoF, Robotiq 2F-85",
        ),
        Embodiment(
            name="IIWA",
            robot="IIWA",
            gripper="Robotiq140Gripper",
            api="iiwa",
            robot_mjcf="models/assets/robots/iiwa/robot.xml",
            gripper_mjcf="models/assets/grippers/robotiq_gripper_140.xml",
            description="KUKA LBR iiwa 14, 7-DoF, Robotiq 2F-140",
        ),
        # Two controllers that take other units and frames (issue 28): the ontology renders the conversions.
        Embodiment(
            name="UR5eScript",
            robot="UR5e",
            gripper="LinkedRobotiq85Gripper",
            api="urscript",
            robot_mjcf="models/assets/robots/ur5e/robot.xml",
            gripper_mjcf="models/assets/grippers/robotiq_gripper_85.xml",
            description="UR5e + Robotiq 2F-85, URScript-style: base-frame poses [x, y, z, rx, ry, rz], axis-angle",
            arm_dof=6,
        ),
        Embodiment(
            name="IIWAKRL",
            robot="IIWA",
            gripper="LinkedRobotiq85Gripper",
            api="krl",
            robot_mjcf="models/assets/robots/iiwa/robot.xml",
            gripper_mjcf="models/assets/grippers/robotiq_gripper_85.xml",
            description="KUKA LBR iiwa 14 + Robotiq 2F-85, KRL-style: millimetres, Euler angles A, B, C (deg)",
        ),
    )
}


class RobotFileError(ValueError):
    """A robot file (``RECENT_ROBOTS``) that cannot be a row: names the file and the field."""

    def __init__(self, path: Path, field: str, message: str):
        super().__init__(f"{path}: {field}: {message}")


ROBOT_FIELDS = {"robosuite": str, "gripper": str, "robot_mjcf": str, "gripper_mjcf": str, "description": str}


def robot_dirs() -> list[Path]:
    """The directories on ``RECENT_ROBOTS``, in order."""
    return [Path(p).expanduser() for p in os.environ.get(ROBOTS_ENV, "").split(os.pathsep) if p.strip()]


def load_robot_file(path: Path) -> Embodiment:
    """The row a robot file describes (its ``embodiment:`` name and ``robot:`` block); its directory
    becomes importable, for the module its ``module:`` names."""
    import yaml

    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as error:
        raise RobotFileError(path, "yaml", f"not valid YAML ({error})") from None
    if not isinstance(data, dict) or not isinstance(data.get("embodiment"), str):
        raise RobotFileError(path, "embodiment", "missing: the robot's name")
    block = data.get("robot")
    if not isinstance(block, dict):
        raise RobotFileError(path, "robot", "must be a mapping of " + ", ".join(ROBOT_FIELDS))
    for field, kind in ROBOT_FIELDS.items():
        if not isinstance(block.get(field), kind):
            raise RobotFileError(path, f"robot.{field}", f"missing or not a {kind.__name__}")
    arm_dof = block.get("arm_dof", 7)
    if not isinstance(arm_dof, int) or not 1 <= arm_dof <= 7:
        raise RobotFileError(path, "robot.arm_dof", f"must be an integer from 1 to 7, got {arm_dof!r}")
    if str(path.parent) not in sys.path:
        sys.path.append(str(path.parent))
    return Embodiment(
        name=data["embodiment"],
        robot=block["robosuite"],
        gripper=block["gripper"],
        api=path.stem,
        robot_mjcf=block["robot_mjcf"],
        gripper_mjcf=block["gripper_mjcf"],
        description=block["description"],
        arm_dof=arm_dof,
        spec_dir=str(path.parent),
    )


def _robots_from_files() -> dict[str, Embodiment]:
    found: dict[str, Embodiment] = {}
    for folder in robot_dirs():
        if not folder.is_dir():
            raise RobotFileError(folder, ROBOTS_ENV, "is not a directory")
        for path in sorted(folder.glob("*.yaml")):
            if "robot" not in (_top_keys(path)):
                continue  # a primitive API without a row of its own (a second gripper of a robot above)
            embodiment = load_robot_file(path)
            if embodiment.name in EMBODIMENTS or embodiment.name in found:
                raise RobotFileError(path, "embodiment", f"{embodiment.name!r} is already an embodiment")
            if (_BUNDLED_APIS / path.name).exists():
                raise RobotFileError(
                    path, "file name", f"a bundled primitive API is named {path.stem!r}: rename the file"
                )
            found[embodiment.name] = embodiment
    return found


def _top_keys(path: Path) -> set[str]:
    import yaml

    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError:
        return {"robot"}  # let load_robot_file say what is wrong with it
    return set(data) if isinstance(data, dict) else set()


EMBODIMENTS.update(_robots_from_files())

SOURCE_EMBODIMENT = "Panda"  # the kinematic setting's source: the reference arm the arm checks compare with
# Where the bundled skills are written and validated: the paper's two settings, each with its own source
# API on the same Panda (positions for the kinematic setting, object names for the end-effector one).
SOURCE_EMBODIMENTS = (SOURCE_EMBODIMENT, "FrankaHand")


def arm_dof(name: str, default: int = 7) -> int:
    """How many of the observation's joint slots robot ``name`` fills (``default`` for one not listed here)."""
    embodiment = EMBODIMENTS.get(name)
    return embodiment.arm_dof if embodiment is not None else default


def resolve_model_file(path: str) -> Path:
    """An embodiment's MJCF: a path relative to robosuite's package (``models/assets/...``), or a file path."""
    import importlib.util

    candidate = Path(path)
    if candidate.is_file():
        return candidate
    spec = importlib.util.find_spec("robosuite")  # locate without importing robosuite (slow)
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError(
            f"{path}: not a file, and robosuite (where model paths are relative to) is not installed"
        )
    return Path(spec.submodule_search_locations[0]) / path


def get_embodiment(name: str) -> Embodiment:
    try:
        return EMBODIMENTS[name]
    except KeyError:
        raise KeyError(f"unknown embodiment {name!r}; known embodiments: {', '.join(EMBODIMENTS)}") from None
