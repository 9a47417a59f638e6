"""Primitive API of the KUKA LBR iiwa 14 (robosuite ``IIWA``, 7-DoF) with its Robotiq 2F-140: names of its own."""

from __future__ import annotations

from collections.abc import Sequence

from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext


def lbr_take(
    env: RobotSession, task: TaskContext, frame_xyz: Sequence[float], timeout_s: float = 10.0
) -> control.Steps:
    """Take what lies at ``frame_xyz`` from above and lift it."""
    yield from control.grasp_at(env, frame_xyz, timeout_s=timeout_s)


def lbr_set_down(
    env: RobotSession, task: TaskContext, frame_xyz: Sequence[float], timeout_s: float = 10.0
) -> control.Steps:
    """Set the held object down at ``frame_xyz`` and open."""
    yield from control.release_at(env, frame_xyz, timeout_s=timeout_s)


def lbr_lin(env: RobotSession, task: TaskContext, frame_xyz: Sequence[float], timeout_s: float = 6.0) -> control.Steps:
    """Linear move of the tool centre point to ``frame_xyz``."""
    yield from control.move_to(env, frame_xyz, timeout_s=timeout_s, settle=True)


def lbr_slide(
    env: RobotSession, task: TaskContext, from_xyz: Sequence[float], to_xyz: Sequence[float]
) -> control.Steps:
    """Slide the closed gripper along the table from ``from_xyz`` to ``to_xyz``."""
    yield from control.push_to(env, from_xyz, to_xyz)


def lbr_orient(env: RobotSession, task: TaskContext, quat_xyzw: Sequence[float]) -> control.Steps:
    """Turn the tool to the world-frame quaternion ``quat_xyzw``."""
    yield from control.align_to(env, quat_xyzw)


def lbr_release(env: RobotSession, task: TaskContext) -> control.Steps:
    """Open the 2F-140 fully."""
    yield from control.actuate_gripper(env, -1.0)


def lbr_clamp(env: RobotSession, task: TaskContext) -> control.Steps:
    """Close the 2F-140."""
    yield from control.actuate_gripper(env, 1.0)
