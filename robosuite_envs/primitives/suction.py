"""Primitive API of a Panda with a vacuum gripper: attach and detach instead of grasp and release."""

from __future__ import annotations

from collections.abc import Sequence

from robosuite_envs.primitives import control
from robosuite_envs.primitives.end_effector_moves import (
    move_gripper_to,
    move_parallel,
    move_to_position,
    rotate_gripper,
)
from robosuite_envs.primitives.session import RobotSession, TaskContext

__all__ = [
    "activate_vacuum",
    "attach_vacuum_handle",
    "deactivate_vacuum",
    "detach_vacuum_handle",
    "move_gripper_to",
    "move_parallel",
    "move_to_position",
    "rotate_gripper",
]


def attach_vacuum_handle(env: RobotSession, task: TaskContext, handle_pos: Sequence[float]) -> control.Steps:
    """Seal the cup on the flat top face at ``handle_pos``, switch suction on and lift."""
    yield from control.suction_grasp_at(env, handle_pos)


def detach_vacuum_handle(env: RobotSession, task: TaskContext, release_pos: Sequence[float]) -> control.Steps:
    """Carry the attached object to ``release_pos``, switch suction off and back away."""
    yield from control.release_at(env, release_pos)


def activate_vacuum(env: RobotSession, task: TaskContext) -> control.Steps:
    """Switch suction on (holds only what the cup already touches)."""
    yield from control.actuate_gripper(env, 1.0, duration_s=0.3, max_duration_s=0.5)


def deactivate_vacuum(env: RobotSession, task: TaskContext) -> control.Steps:
    """Switch suction off."""
    yield from control.actuate_gripper(env, -1.0, duration_s=0.3, max_duration_s=0.5)
