"""Primitive API of the Rethink Sawyer with its parallel gripper (names and signatures of its own)."""

from __future__ import annotations

from collections.abc import Sequence

from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext


def sawyer_pick(env: RobotSession, task: TaskContext, target_object: str, target_pos: Sequence[float]) -> control.Steps:
    """Pick ``target_object``, expected at ``target_pos``; fails if that object is not what gets held."""
    task.get_object_position(target_object)  # object_not_found for names that are not in the scene
    yield from control.grasp_at(env, target_pos, object_name=target_object)


def sawyer_place(env: RobotSession, task: TaskContext, place_pos: Sequence[float]) -> control.Steps:
    """Put the held object down at ``place_pos`` and open."""
    yield from control.release_at(env, place_pos)


def sawyer_move_to(env: RobotSession, task: TaskContext, target_pos: Sequence[float]) -> control.Steps:
    """Move the gripper to ``target_pos``."""
    yield from control.move_to(env, target_pos, settle=True)


def sawyer_push(
    env: RobotSession, task: TaskContext, from_pos: Sequence[float], to_pos: Sequence[float]
) -> control.Steps:
    """Slide the closed gripper along the table from ``from_pos`` to ``to_pos``."""
    yield from control.push_to(env, from_pos, to_pos)


def sawyer_align_gripper(env: RobotSession, task: TaskContext, reference_quat: Sequence[float]) -> control.Steps:
    """Align the gripper with ``reference_quat`` [x, y, z, w]."""
    yield from control.align_to(env, reference_quat)


def sawyer_open_gripper(
    env: RobotSession, task: TaskContext, amount: float = 1.0, velocity: float = 0.2
) -> control.Steps:
    """Open by ``amount`` of the stroke (1.0 = fully open)."""
    yield from control.set_opening(env, amount, velocity)


def sawyer_close_gripper(
    env: RobotSession, task: TaskContext, amount: float = 0.0, velocity: float = 0.2
) -> control.Steps:
    """Close to ``amount`` of the stroke (0.0 = fully closed)."""
    yield from control.set_opening(env, amount, velocity)
