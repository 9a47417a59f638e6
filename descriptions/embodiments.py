"""Embodiments: a robosuite robot, its gripper, and the primitive API it exposes, read from robot files.

A robot file is ``<api>.yaml``: its ``embodiment:`` name and ``robot:`` block (the robosuite robot
and gripper classes, their MJCF files) make the row; the rest is its primitive API (``apis.py``).
The bundled robots are ``descriptions/robots/*.yaml``; a robot that lives outside this package is
a directory on ``RECENT_ROBOTS`` (``os.pathsep``-separated) of files in the same format, and the
module a file's ``module:`` names is imported from that directory (docs/add_a_robot.md).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

BUNDLED_DIR = Path(__file__).parent / "robots"
# The bundled robot files in listing order: the paper's two settings first (sources, then targets),
# then the arms added by data, then the controllers with other units and frames.
BUNDLED = (
    "panda", "ur5e", "sawyer", "robotiq85", "suction", "franka_hand", "jaco", "jaco_robotiq85",
    "gen3", "xarm", "xarm_robotiq85", "iiwa", "urscript", "krl",
)  # fmt: skip
ROBOTS_ENV = "RECENT_ROBOTS"  # directories of robots added from files (a YAML with a `robot:` block + its module)


@dataclass(frozen=True)
class Embodiment:
    name: str
    robot: str  # robosuite robot class
    gripper: str  # robosuite gripper class
    api: str  # primitive API: the robot file's stem (<api>.yaml)
    robot_mjcf: str  # MJCF files the ontology reads: a file path, else relative to robosuite's package
    gripper_mjcf: str
    description: str
    arm_dof: int = 7  # arm joints (the observation's joint slots it fills; the rest stay 0)
    spec_dir: str = ""  # the directory of <api>.yaml


class RobotFileError(ValueError):
    """A robot file (``RECENT_ROBOTS``) that cannot be a row: names the file and the field."""

    def __init__(self, path: Path, field: str, message: str):
        super().__init__(f"{path}: {field}: {message}")


ROBOT_FIELDS = {"robosuite": str, "gripper": str, "robot_mjcf": str, "gripper_mjcf": str, "description": str}


def robot_dirs() -> list[Path]:
    """The directories on ``RECENT_ROBOTS``, in order."""
    return [Path(p).expanduser() for p in os.environ.get(ROBOTS_ENV, "").split(os.pathsep) if p.strip()]


def read_yaml(path: Path) -> object:
    """A robot file's data (libyaml where it is installed: every CLI start reads the bundled files)."""
    import yaml

    return yaml.load(path.read_text(), Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))


def load_robot_file(path: Path, data: object = None) -> Embodiment:
    """The row a robot file describes (its ``embodiment:`` name and ``robot:`` block); ``data``: the
    file already read. Reading it changes nothing: the module its ``module:`` names is imported
    from beside it when its primitives are bound (``robosuite_envs/primitives``)."""
    import yaml

    if data is None:
        try:
            data = read_yaml(path)
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
    return Embodiment(
        name=data["embodiment"],
        robot=block["robosuite"],
        gripper=block["gripper"],
        api=path.stem,
        robot_mjcf=_beside(path, block["robot_mjcf"]),
        gripper_mjcf=_beside(path, block["gripper_mjcf"]),
        description=block["description"],
        arm_dof=arm_dof,
        spec_dir=str(path.parent),
    )


def _beside(robot_file: Path, mjcf: str) -> str:
    """An MJCF path relative to the robot file's directory, made absolute; others stay as written."""
    candidate = robot_file.parent / mjcf
    return str(candidate) if not Path(mjcf).is_absolute() and candidate.is_file() else mjcf


def _bundled_robots() -> dict[str, Embodiment]:
    rows = [load_robot_file(BUNDLED_DIR / f"{api}.yaml") for api in BUNDLED]
    return {row.name: row for row in rows}


def _robots_from_files() -> dict[str, Embodiment]:
    import yaml

    found: dict[str, Embodiment] = {}
    for folder in robot_dirs():
        if not folder.is_dir():
            raise RobotFileError(folder, ROBOTS_ENV, "is not a directory")
        for path in sorted(folder.glob("*.yaml")):
            try:
                data = read_yaml(path)
            except yaml.YAMLError as error:
                raise RobotFileError(path, "yaml", f"not valid YAML ({error})") from None
            if not isinstance(data, dict) or "robot" not in data:
                continue  # a primitive API without a row of its own (a second gripper of a robot above)
            embodiment = load_robot_file(path, data)
            if embodiment.name in EMBODIMENTS or embodiment.name in found:
                raise RobotFileError(path, "embodiment", f"{embodiment.name!r} is already an embodiment")
            if (BUNDLED_DIR / path.name).exists():
                raise RobotFileError(
                    path, "file name", f"a bundled primitive API is named {path.stem!r}: rename the file"
                )
            found[embodiment.name] = embodiment
    return found


EMBODIMENTS: dict[str, Embodiment] = _bundled_robots()
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
    """An embodiment's MJCF: a file path, or a path relative to robosuite's package (``models/assets/...``)."""
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
