"""Primitive API of the UFactory xArm 7: names of its own, thin over the shared controllers.

One module serves the xArm 7 with its own parallel gripper (robosuite's default) and with a Robotiq
2F-85; what differs between the two is in each embodiment's calibration.
"""

from __future__ import annotations

from collections.abc import Sequence

from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext


def xarm_pick(env: RobotSession, task: TaskContext, pick_at: Sequence[float], timeout: float = 10.0) -> control.Steps:
    """Pick up what lies at ``pick_at`` from above."""
    yield from control.grasp_at(env, pick_at, timeout_s=timeout)


def xarm_place(env: RobotSession, task: TaskContext, place_at: Sequence[float], timeout: float = 10.0) -> control.Steps:
    """Place the held object at ``place_at`` and open."""
    yield from control.release_at(env, place_at, timeout_s=timeout)


def xarm_move_tcp(env: RobotSession, task: TaskContext, tcp_at: Sequence[float], timeout: float = 6.0) -> control.Steps:
    """Move the tool centre point to ``tcp_at``."""
    yield from control.move_to(env, tcp_at, timeout_s=timeout, settle=True)


def xarm_push(
    env: RobotSession, task: TaskContext, push_from: Sequence[float], push_to: Sequence[float]
) -> control.Steps:
    """Push along the table with the closed gripper from ``push_from`` to ``push_to``."""
    yield from control.push_to(env, push_from, push_to)


def xarm_set_orientation(env: RobotSession, task: TaskContext, quat: Sequence[float]) -> control.Steps:
    """Turn the tool to the world-frame quaternion ``quat`` [x, y, z, w]."""
    yield from control.align_to(env, quat)


def xarm_gripper_open(env: RobotSession, task: TaskContext, opening: float = 1.0) -> control.Steps:
    """Open the gripper to ``opening`` of its stroke (1.0 = fully open)."""
    yield from control.set_opening(env, opening, velocity=0.2)


def xarm_gripper_close(env: RobotSession, task: TaskContext, opening: float = 0.0) -> control.Steps:
    """Close the gripper down to ``opening`` of its stroke (0.0 = fully closed)."""
    yield from control.set_opening(env, opening, velocity=0.2)
