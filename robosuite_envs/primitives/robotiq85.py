"""Primitive API of a Panda with a Robotiq 2F-85 (end-effector variation): the paper's table, by name.

Its picks, places and handle grasps move as the Franka Hand's do (``franka_hand``); its calibration
(stroke, grasp point) is the 2F-85's."""

from __future__ import annotations

import numpy as np

from lerobot_policy_recent.robosuite_envs.primitives import control, franka_hand
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


def pick_robotiq85(env: RobotSession, task: TaskContext, obj_name: str, pointing_to: str = "down") -> control.Steps:
    """Grasp the object called ``obj_name`` with the 2F-85 from above and lift it."""
    above = np.asarray(task.get_object_position(obj_name), dtype=float) + [0.0, 0.0, control.APPROACH_HEIGHT]
    yield from move_to_position(env, task, above, pointing_to)
    yield from franka_hand.pick(env, task, obj_name, pointing_to)


def place_robotiq85(env: RobotSession, task: TaskContext, obj_name: str, pointing_to: str = "down") -> control.Steps:
    """Lower the held object onto (or into) the object called ``obj_name`` until it rests, and open the 2F-85."""
    yield from franka_hand.place(env, task, obj_name, pointing_to)


def grasp_handle_robotiq85(env: RobotSession, task: TaskContext, handle_name: str) -> control.Steps:
    """Close the 2F-85 on the handle called ``handle_name`` and keep holding it (no lift)."""
    yield from franka_hand.grasp_handle(env, task, handle_name)


def release_handle_robotiq85(env: RobotSession, task: TaskContext) -> control.Steps:
    """Open the 2F-85 and back off upwards."""
    yield from franka_hand.release_handle(env, task)


def open_robotiq85(env: RobotSession, task: TaskContext) -> control.Steps:
    """Open the 2F-85 fully."""
    yield from control.actuate_gripper(env, -1.0)


def close_robotiq85(env: RobotSession, task: TaskContext) -> control.Steps:
    """Close the 2F-85."""
    yield from control.actuate_gripper(env, 1.0)
