"""Primitive API of the end-effector setting's source: a Panda with its Franka Hand, addressed by name.

The paper's parallel-jaw table: picks, places and handle grasps take an object's *name*, and the
arm moves shared with the 2F-85 and the vacuum gripper (``end_effector_moves``) take positions,
axes and angles. ``primitives/franka_hand.yaml`` describes them for the ontology.
"""

from __future__ import annotations

from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.end_effector_moves import (
    check_pointing,
    move_gripper_to,
    move_parallel,
    move_to_position,
    rotate_gripper,
)
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext

__all__ = [
    "close_gripper",
    "grasp_handle",
    "move_gripper_to",
    "move_parallel",
    "move_to_position",
    "open_gripper",
    "pick",
    "place",
    "release_handle",
    "rotate_gripper",
]


def pick(env: RobotSession, task: TaskContext, obj_name: str, pointing_to: str = "down") -> control.Steps:
    """Grasp the object called ``obj_name`` from above and lift it; fails if another is held."""
    check_pointing(pointing_to)
    yield from control.grasp_at(env, task.get_object_position(obj_name), object_name=obj_name)


def place(env: RobotSession, task: TaskContext, obj_name: str, pointing_to: str = "down") -> control.Steps:
    """Lower the held object onto (or into) the object called ``obj_name`` until it rests, and let go."""
    check_pointing(pointing_to)
    yield from control.release_onto(env, task.get_object_position(obj_name))


def grasp_handle(env: RobotSession, task: TaskContext, handle_name: str) -> control.Steps:
    """Close the hand on the handle called ``handle_name`` from above and keep holding it (no lift)."""
    yield from control.grasp_handle_at(env, task.get_object_position(handle_name))


def release_handle(env: RobotSession, task: TaskContext) -> control.Steps:
    """Open the hand on the handle it holds and back off upwards."""
    yield from control.release_handle(env)


def open_gripper(env: RobotSession, task: TaskContext) -> control.Steps:
    """Open the Franka Hand fully."""
    yield from control.actuate_gripper(env, -1.0)


def close_gripper(env: RobotSession, task: TaskContext) -> control.Steps:
    """Close the Franka Hand."""
    yield from control.actuate_gripper(env, 1.0)
