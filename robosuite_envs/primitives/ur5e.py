"""Primitive API of the UR5e with its Robotiq 2F-85: other names, other signatures than the Panda's."""

from __future__ import annotations

from collections.abc import Sequence

from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext


def ur5_grasp_at(
    env: RobotSession, task: TaskContext, grasp_pos: Sequence[float], timeout_s: float = 5.0
) -> control.Steps:
    """Grasp whatever lies at ``grasp_pos`` from above and lift it; give up after ``timeout_s`` per motion."""
    yield from control.grasp_at(env, grasp_pos, timeout_s=timeout_s)


def ur5_release_at(
    env: RobotSession, task: TaskContext, place_pos: Sequence[float], timeout_s: float = 5.0
) -> control.Steps:
    """Lower the held object to ``place_pos`` and open the gripper."""
    yield from control.release_at(env, place_pos, timeout_s=timeout_s)


def ur5_move_to(
    env: RobotSession, task: TaskContext, target_pos: Sequence[float], timeout_s: float = 3.0
) -> control.Steps:
    """Move the tool centre point to ``target_pos``."""
    yield from control.move_to(env, target_pos, timeout_s=timeout_s, settle=True)


def ur5_push_to(
    env: RobotSession,
    task: TaskContext,
    contact_pos: Sequence[float],
    goal_pos: Sequence[float],
    timeout_s: float = 6.0,
) -> control.Steps:
    """Touch down at ``contact_pos`` with the closed gripper and slide to ``goal_pos``."""
    yield from control.push_to(env, contact_pos, goal_pos, timeout_s=timeout_s)


def ur5_align_gripper(
    env: RobotSession, task: TaskContext, reference_quat: Sequence[float], timeout_s: float = 3.0
) -> control.Steps:
    """Align the tool frame with ``reference_quat`` [x, y, z, w] (world frame)."""
    yield from control.align_to(env, reference_quat, timeout_s=timeout_s)


def open_ur5_ee(
    env: RobotSession, task: TaskContext, gripper_open: float = 1.0, velocity: float = 0.2
) -> control.Steps:
    """Open the end effector to fraction ``gripper_open`` (1.0 = fully open)."""
    yield from control.set_opening(env, gripper_open, velocity)


def close_ur5_ee(
    env: RobotSession, task: TaskContext, gripper_close: float = 0.0, velocity: float = 0.2
) -> control.Steps:
    """Close the end effector to fraction ``gripper_close`` of its opening (0.0 = fully closed)."""
    yield from control.set_opening(env, gripper_close, velocity)
