"""Embodiments: a robosuite robot, its gripper, and the primitive API it exposes.

Adding an embodiment is data: a row here names the robosuite models, and
``primitives/<api>.yaml`` + ``primitives/<api>.py`` give its primitive API.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

_ASSETS = Path(__file__).parent / "grippers" / "assets"


# Where robosuite's table mount puts every arm's base on our 0.8 m table (tests check it against the sim).
ROBOT_BASE_XY = (-0.56, 0.0)


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
    )
}

SOURCE_EMBODIMENT = "Panda"


def arm_dof(name: str, default: int = 7) -> int:
    """How many of the observation's joint slots robot ``name`` fills (``default`` for one not listed here)."""
    embodiment = EMBODIMENTS.get(name)
    return embodiment.arm_dof if embodiment is not None else default


def get_embodiment(name: str) -> Embodiment:
    try:
        return EMBODIMENTS[name]
    except KeyError:
        raise KeyError(f"unknown embodiment {name!r}; known embodiments: {', '.join(EMBODIMENTS)}") from None
