"""Primitive API of the Kinova Gen3 (robosuite ``Kinova3``, 7-DoF) with its Robotiq 2F-85: names of its own."""

from __future__ import annotations

from collections.abc import Sequence

from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext


def gen3_grasp(env: RobotSession, task: TaskContext, position: Sequence[float]) -> control.Steps:
    """Grasp what lies at ``position`` from above and lift it."""
    yield from control.grasp_at(env, position)


def gen3_release(env: RobotSession, task: TaskContext, position: Sequence[float]) -> control.Steps:
    """Lower the held object to ``position`` and open."""
    yield from control.release_at(env, position)


def gen3_reach(env: RobotSession, task: TaskContext, position: Sequence[float], duration: float = 6.0) -> control.Steps:
    """Reach ``position`` with the tool centre point within ``duration`` seconds."""
    yield from control.move_to(env, position, timeout_s=duration, settle=True)


def gen3_slide(env: RobotSession, task: TaskContext, start: Sequence[float], goal: Sequence[float]) -> control.Steps:
    """Slide the closed gripper along the table from ``start`` to ``goal``."""
    yield from control.push_to(env, start, goal)


def gen3_orient(env: RobotSession, task: TaskContext, orientation: Sequence[float]) -> control.Steps:
    """Orient the tool frame as ``orientation`` [x, y, z, w] (world frame)."""
    yield from control.align_to(env, orientation)


def gen3_gripper_open(env: RobotSession, task: TaskContext) -> control.Steps:
    """Open the 2F-85 fully."""
    yield from control.actuate_gripper(env, -1.0)


def gen3_gripper_close(env: RobotSession, task: TaskContext) -> control.Steps:
    """Close the 2F-85."""
    yield from control.actuate_gripper(env, 1.0)
