"""Primitive API of the source robot: Franka Panda with its parallel-jaw hand.

Each primitive is a generator of actions (see :mod:`lerobot_policy_recent.robosuite_envs.primitives.control`);
``primitives/panda.yaml`` describes them for the ontology.
"""

from __future__ import annotations

from collections.abc import Sequence

from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext


def pick(env: RobotSession, task: TaskContext, target_pos: Sequence[float], approach_axis: str = "z") -> control.Steps:
    """Grasp the object at ``target_pos`` approaching along ``approach_axis`` and lift it."""
    _check_axis(approach_axis)
    yield from control.grasp_at(env, target_pos)


def place(env: RobotSession, task: TaskContext, target_pos: Sequence[float], approach_axis: str = "z") -> control.Steps:
    """Lower the held object to ``target_pos`` along ``approach_axis`` and let go of it."""
    _check_axis(approach_axis)
    yield from control.release_at(env, target_pos)


def move(env: RobotSession, task: TaskContext, target_pos: Sequence[float], timeout: float = 6.0) -> control.Steps:
    """Move the hand to ``target_pos`` keeping its orientation."""
    yield from control.move_to(env, target_pos, timeout_s=timeout, settle=True)


def push(
    env: RobotSession,
    task: TaskContext,
    start_pos: Sequence[float],
    target_pos: Sequence[float],
    approach_axis: str = "z",
) -> control.Steps:
    """Lower the closed hand at ``start_pos`` and slide it to ``target_pos``, pushing what is in the way."""
    _check_axis(approach_axis)
    yield from control.push_to(env, start_pos, target_pos)


def align_to_quaternion(
    env: RobotSession, task: TaskContext, quaternion: Sequence[float], timeout: float = 4.0
) -> control.Steps:
    """Turn the hand to the world-frame orientation ``quaternion`` [x, y, z, w]."""
    yield from control.align_to(env, quaternion, timeout_s=timeout)


def align_two_axes(env: RobotSession, task: TaskContext, yaw: float = 0.0) -> control.Steps:
    """Keep the hand pointing down and turn it by ``yaw`` radians about the vertical."""
    yield from control.rotate_about_z(env, float(yaw))


def open_gripper(env: RobotSession, task: TaskContext) -> control.Steps:
    """Open the Franka hand fully."""
    yield from control.actuate_gripper(env, -1.0)


def close_gripper(env: RobotSession, task: TaskContext) -> control.Steps:
    """Close the Franka hand."""
    yield from control.actuate_gripper(env, 1.0)


def _check_axis(axis: str) -> None:
    if axis != "z":
        raise control.PrimitiveFailure(
            "misaligned", f"approach_axis={axis!r}: only top-down ('z') approaches are supported"
        )
