"""Primitive API of a Panda with a vacuum gripper: attach and detach instead of grasp and release."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.end_effector_moves import (
    check_pointing,
    move_gripper_to,
    move_parallel,
    rotate_gripper,
)
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext

__all__ = [
    "activate_vacuum",
    "attach_vacuum_handle",
    "deactivate_vacuum",
    "detach_vacuum_handle",
    "move_gripper_to",
    "move_parallel",
    "move_to_position",
    "rotate_gripper",
]


def move_to_position(
    env: RobotSession, task: TaskContext, pos: Sequence[float], pointing_to: str = "down"
) -> control.Steps:
    """Move the cup to ``pos`` over what is in the way (the shared planner).

    Free, each leg follows a straight line, as the other end-effector APIs' moves do: a move that
    pushes something slides it along that line (bent, a sweep's cup sideswiped the block and left it
    behind). Carrying a load that hangs free (:func:`~.control.load_hangs`), the same, and the
    load's centre goes over ``pos`` in x and y, as a load centred in a hand's grip would: a cup seals
    where it touched the top face, 2 cm off the centre at times (a block lowered into a drawer behind
    another then landed on its edge), and a carry that closed each axis on its own bent 4 cm off its
    line and pushed a block out of its slot. Dragging something (sealed on a load that rests or
    slides on something, or pressed on a knob it pulls by friction), each axis closes its own error,
    so the cup keeps pressing where the line would ease off. Lowered onto a surface, it stops where
    the cup, or its load, rests on it (it cannot reach a point inside what it would seal on, e.g. a
    knob's centre). A drag that stalls within ``DRAG_TOL`` has arrived, as for the other
    end-effector moves."""
    check_pointing(pointing_to)
    goal = control.as_position(pos, "target position")
    hangs = control.load_hangs(env)
    if hangs:  # the load over pos, wherever on its top the cup sealed
        goal = goal - np.array([*control.held_offset(env)[:2], 0.0])
    # sealed on a load that rests or slides on something, or pressed on a knob
    drag = (env.obs.object_detected or env.obs.eef_contact) and not hangs
    yield from control.move_to(env, goal, tol=control.DRAG_TOL, settle=True, stop_on_contact=True, straight=not drag)


def attach_vacuum_handle(env: RobotSession, task: TaskContext, handle_name: str) -> control.Steps:
    """Seal the cup on the flat top face of the object called ``handle_name``, switch suction on and lift."""
    yield from control.suction_grasp_at(env, task.get_object_position(handle_name))


def detach_vacuum_handle(env: RobotSession, task: TaskContext) -> control.Steps:
    """Lower the attached object straight down until it rests on what is below, switch suction off
    and back away: the object goes where the cup is (bring the cup over the receptacle first)."""
    yield from control.release_below(env)


def activate_vacuum(env: RobotSession, task: TaskContext) -> control.Steps:
    """Switch suction on (holds only what the cup already touches)."""
    yield from control.actuate_gripper(env, 1.0, duration_s=0.3, max_duration_s=0.5)


def deactivate_vacuum(env: RobotSession, task: TaskContext) -> control.Steps:
    """Switch suction off."""
    yield from control.actuate_gripper(env, -1.0, duration_s=0.3, max_duration_s=0.5)
