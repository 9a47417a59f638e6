"""Gripper models added to robosuite's registry (importing this package registers them)."""

from robosuite_envs.grippers.robotiq85 import LinkedRobotiq85Gripper

__all__ = ["LinkedRobotiq85Gripper"]
