"""Primitive API of a UR5e with its Robotiq 2F-85, driven the URScript way (``movel(p[x, y, z, rx, ry, rz])``).

Poses are in the robot's base frame (declared in ``urscript.yaml``) with an axis-angle rotation; the
driver turns them into the world-frame targets of the shared controllers, and turns the tool only
where the pose asks for another orientation than the one it holds.
"""

from __future__ import annotations

from collections.abc import Sequence

from lerobot_policy_recent.robosuite_envs.primitives import control, frames
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext

BASE = "base"


def _point(env: RobotSession, pose: Sequence[float]):
    """Turn the tool to the pose's rotation where it differs, then hand back the pose's world point."""
    base = env.frame(BASE)
    yield from control.align_if_turned(env, frames.world_rotation(pose, "pose", base))
    return frames.world_point(pose, "pose", "m", base)


def ur_pick(env: RobotSession, task: TaskContext, pose: Sequence[float], t: float = 5.0) -> control.Steps:
    """Move above ``pose``, descend, close the gripper on what is there and lift it."""
    point = yield from _point(env, pose)
    yield from control.grasp_at(env, point, timeout_s=t)


def ur_place(env: RobotSession, task: TaskContext, pose: Sequence[float], t: float = 5.0) -> control.Steps:
    """Lower the held object to ``pose`` and open the gripper."""
    point = yield from _point(env, pose)
    yield from control.release_at(env, point, timeout_s=t)


def movel(env: RobotSession, task: TaskContext, pose: Sequence[float], t: float = 3.0) -> control.Steps:
    """Move the tool linearly to ``pose`` ([x, y, z, rx, ry, rz], base frame)."""
    point = yield from _point(env, pose)
    yield from control.move_to(env, point, timeout_s=t, settle=True)


def ur_orient(env: RobotSession, task: TaskContext, rotvec: Sequence[float], t: float = 3.0) -> control.Steps:
    """Turn the tool to the base-frame rotation ``rotvec`` (axis-angle, rad), in place."""
    yield from control.align_to(env, frames.world_rotation(rotvec, "rotvec", env.frame(BASE)), timeout_s=t)


def rq_open(env: RobotSession, task: TaskContext) -> control.Steps:
    """Open the 2F-85 fully."""
    yield from control.actuate_gripper(env, -1.0)


def rq_close(env: RobotSession, task: TaskContext) -> control.Steps:
    """Close the 2F-85."""
    yield from control.actuate_gripper(env, 1.0)
