"""Gripper models added to robosuite's registry (importing this package registers them)."""

from lerobot_policy_recent.robosuite_envs import runtime  # noqa: F401  (headless GL before robosuite loads)

# isort: split
from lerobot_policy_recent.robosuite_envs.grippers.robotiq85 import LinkedRobotiq85Gripper
from lerobot_policy_recent.robosuite_envs.grippers.suction import SuctionGripper
from lerobot_policy_recent.robosuite_envs.grippers.xarm7 import XArm7PadGripper

__all__ = ["LinkedRobotiq85Gripper", "SuctionGripper", "XArm7PadGripper"]
