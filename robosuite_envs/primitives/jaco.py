"""Primitive API of the Kinova Jaco (7-DoF): its own names and signatures, thin over the shared controllers.

One module serves the Jaco with its three-finger hand (robosuite's default) and with a Robotiq
2F-85: the controllers read what differs (the hand's closing time, its grasp point) from the
embodiment's calibration.
"""

from __future__ import annotations

from collections.abc import Sequence

from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext


def jaco_pick_up(
    env: RobotSession, task: TaskContext, obj_xyz: Sequence[float], timeout_s: float = 8.0
) -> control.Steps:
    """Take hold of what lies at ``obj_xyz`` from above and lift it."""
    yield from control.grasp_at(env, obj_xyz, timeout_s=timeout_s)


def jaco_put_down(
    env: RobotSession, task: TaskContext, put_xyz: Sequence[float], timeout_s: float = 8.0
) -> control.Steps:
    """Set the held object down at ``put_xyz`` and let go."""
    yield from control.release_at(env, put_xyz, timeout_s=timeout_s)


def jaco_goto(env: RobotSession, task: TaskContext, xyz: Sequence[float], timeout_s: float = 5.0) -> control.Steps:
    """Bring the hand to ``xyz``."""
    yield from control.move_to(env, xyz, timeout_s=timeout_s, settle=True)


def jaco_shove(
    env: RobotSession, task: TaskContext, begin_xyz: Sequence[float], end_xyz: Sequence[float]
) -> control.Steps:
    """Put the closed hand down at ``begin_xyz`` and slide it along the table to ``end_xyz``."""
    yield from control.push_to(env, begin_xyz, end_xyz)


def jaco_orient(env: RobotSession, task: TaskContext, quat_xyzw: Sequence[float]) -> control.Steps:
    """Turn the hand to the world-frame orientation ``quat_xyzw``."""
    yield from control.align_to(env, quat_xyzw)


def jaco_hand_open(env: RobotSession, task: TaskContext, fraction: float = 1.0) -> control.Steps:
    """Open the hand to ``fraction`` of its stroke (1.0 = fully open)."""
    yield from control.set_opening(env, fraction, velocity=0.2)


def jaco_hand_close(env: RobotSession, task: TaskContext, fraction: float = 0.0) -> control.Steps:
    """Close the hand to ``fraction`` of its stroke (0.0 = fully closed)."""
    yield from control.set_opening(env, fraction, velocity=0.2)
