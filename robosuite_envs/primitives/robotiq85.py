"""Primitive API of a Panda with a Robotiq 2F-85 (end-effector variation)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.end_effector_moves import (
    move_gripper_to,
    move_parallel,
    move_to_position,
    rotate_gripper,
)
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext

__all__ = [
    "close_robotiq85",
    "grasp_handle_robotiq85",
    "move_gripper_to",
    "move_parallel",
    "move_to_position",
    "open_robotiq85",
    "pick_robotiq85",
    "place_robotiq85",
    "release_handle_robotiq85",
    "rotate_gripper",
]


def pick_robotiq85(
    env: RobotSession, task: TaskContext, target_pos: Sequence[float], pointing_to: str = "down"
) -> control.Steps:
    """Grasp the object at ``target_pos`` with the 2F-85 and lift it."""
    yield from move_to_position(
        env, task, np.asarray(target_pos, dtype=float) + [0.0, 0.0, control.APPROACH_HEIGHT], pointing_to
    )
    yield from control.grasp_at(env, target_pos)


def place_robotiq85(
    env: RobotSession, task: TaskContext, target_pos: Sequence[float], pointing_to: str = "down"
) -> control.Steps:
    """Lower the held object to ``target_pos`` and open the 2F-85."""
    yield from move_to_position(
        env, task, np.asarray(target_pos, dtype=float) + [0.0, 0.0, control.APPROACH_HEIGHT / 2], pointing_to
    )
    yield from control.release_at(env, target_pos)


def grasp_handle_robotiq85(env: RobotSession, task: TaskContext, handle_pos: Sequence[float]) -> control.Steps:
    """Close the 2F-85 on a handle at ``handle_pos`` and keep holding it (no lift)."""
    target = control.as_position(handle_pos, "handle position")
    yield from control.actuate_gripper(env, -1.0)
    yield from control.move_to(env, target + [0.0, 0.0, control.APPROACH_HEIGHT])
    yield from control.move_to(env, target)
    yield from control.actuate_gripper(env, 1.0)


def release_handle_robotiq85(env: RobotSession, task: TaskContext) -> control.Steps:
    """Open the 2F-85 and back off upwards."""
    yield from control.actuate_gripper(env, -1.0)
    yield from control.move_to(env, env.obs.eef_pos + [0.0, 0.0, control.APPROACH_HEIGHT / 2], tol=0.02)


def open_robotiq85(env: RobotSession, task: TaskContext) -> control.Steps:
    """Open the 2F-85 fully."""
    yield from control.actuate_gripper(env, -1.0)


def close_robotiq85(env: RobotSession, task: TaskContext) -> control.Steps:
    """Close the 2F-85."""
    yield from control.actuate_gripper(env, 1.0)
