"""Primitive API of a KUKA LBR iiwa 14 with a Robotiq 2F-85, driven the KRL way: millimetres and
Euler angles A, B, C in degrees (``krl.yaml``), linear moves and gripper switches, no pick or place.
The driver turns them into the world-frame metres and quaternions of the shared controllers."""

from __future__ import annotations

from collections.abc import Sequence

from lerobot_policy_recent.robosuite_envs.primitives import control, frames
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext


def _metres(xyz_mm: Sequence[float]) -> list[float]:
    return frames.scale(xyz_mm, "mm", "m")


def krl_lin(env: RobotSession, task: TaskContext, xyz_mm: Sequence[float], timeout_s: float = 6.0) -> control.Steps:
    """Linear move of the tool centre point to ``xyz_mm``."""
    yield from control.move_to(env, _metres(xyz_mm), timeout_s=timeout_s, settle=True)


def krl_slide(env: RobotSession, task: TaskContext, from_mm: Sequence[float], to_mm: Sequence[float]) -> control.Steps:
    """Slide the closed gripper along the table from ``from_mm`` to ``to_mm``."""
    yield from control.push_to(env, _metres(from_mm), _metres(to_mm))


def krl_orient(env: RobotSession, task: TaskContext, abc_deg: Sequence[float]) -> control.Steps:
    """Turn the tool to the world-frame Euler angles ``abc_deg`` (A about Z, B about Y, C about X; degrees)."""
    yield from control.align_to(env, frames.euler_to_quat(abc_deg, "ZYX", degrees=True))


def krl_open(env: RobotSession, task: TaskContext) -> control.Steps:
    """Open the 2F-85 fully."""
    yield from control.actuate_gripper(env, -1.0)


def krl_close(env: RobotSession, task: TaskContext) -> control.Steps:
    """Close the 2F-85."""
    yield from control.actuate_gripper(env, 1.0)
