"""Arm motions shared by the end-effector-variation APIs (Robotiq 2F-85 and suction on a Panda).

Both APIs expose these under the same names, as in the paper's Genesis tables; the ontology sees
them as one primitive per embodiment.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext

_DIRECTIONS = {"x": (1, 0, 0), "-x": (-1, 0, 0), "y": (0, 1, 0), "-y": (0, -1, 0), "z": (0, 0, 1), "-z": (0, 0, -1)}


def move_to_position(
    env: RobotSession, task: TaskContext, pos: Sequence[float], pointing_to: str = "down"
) -> control.Steps:
    """Move the end effector to ``pos`` along a straight line, pointing ``pointing_to`` (only 'down' is
    supported): a move that pushes something slides it along that line. It arrives once stopped
    within ``DRAG_TOL``, whatever stops it (a drawer pulled against its damping stalls 1-2 cm short);
    one still moving keeps going for ``POS_TOL``. An arm's own move does so only while it drives a
    mechanism (:func:`~.control.drives_mechanism`)."""
    check_pointing(pointing_to)
    yield from control.move_to(env, pos, tol=control.DRAG_TOL, settle=True, straight=True, plan=False)


def move_gripper_to(env: RobotSession, task: TaskContext, obj_name: str, pointing_to: str = "down") -> control.Steps:
    """Move the end effector above the object called ``obj_name``, and what it carries with it: a load
    off the grip site's axis (a cup seals where it touched the top face) is centred over the object,
    and one that hangs below the grip site is lifted by as much."""
    check_pointing(pointing_to)
    load = control.held_offset(env)
    load[2] = min(0.0, float(load[2]))
    above = np.array(task.get_object_position(obj_name)) + np.array([0.0, 0.0, control.APPROACH_HEIGHT]) - load
    yield from control.move_to(env, above)


def move_parallel(env: RobotSession, task: TaskContext, direction: str, offset: float) -> control.Steps:
    """Translate the end effector by ``offset`` metres along ``direction`` (x, -x, y, -y, z, -z)."""
    if direction not in _DIRECTIONS:
        raise control.PrimitiveFailure("unreachable", f"direction {direction!r} is not one of {sorted(_DIRECTIONS)}")
    yield from control.move_to(env, env.obs.eef_pos + float(offset) * np.array(_DIRECTIONS[direction]))


def rotate_gripper(env: RobotSession, task: TaskContext, angle: float, steps: int = 80) -> control.Steps:
    """Turn the end effector by ``angle`` radians about the vertical within ``steps`` control steps."""
    yield from control.rotate_about_z(env, float(angle), timeout_s=max(1, int(steps)) / control.CONTROL_FREQ)


def check_pointing(pointing_to: str) -> None:
    if pointing_to != "down":
        raise control.PrimitiveFailure("misaligned", f"pointing_to={pointing_to!r}: only 'down' is supported")
