"""A parallel jaw closes square to the faces of a long object it grasps.

Closed at a slant to a box's faces, the pads turn the box until its faces lie flat on them. A
block turns as they close; a tool, whose ends rest on the table, turns later, while carried, and
moves its working end: a rake taken at a slant turns in the grip, and its crossbar pushes what it
drags sideways. The grasp and
the check that predicts where the fingers come down both turn the jaw by the same turn, from
perception (the box's orientation and extents), never the simulator's state.
"""

from __future__ import annotations

import math

import numpy as np
from robosuite.utils.transform_utils import quat2mat

from lerobot_policy_recent.robosuite_envs.observation import ObjectState, Observation

LONG_OBJECT = 0.15  # metres across the table above which a grasp squares the jaw first (the rake: 0.27)


def yaw_of(quat_xyzw) -> float:
    """Radians about the vertical of a frame's x axis, or of its y axis where x stands steeper than
    60 degrees (a box on its side). Always x for a hand pointing down, whose x and y both lie flat: a
    choice by which lies flatter can flip between two reads of one hand, a quarter turn apart."""
    turn = quat2mat(np.asarray(quat_xyzw, dtype=float))
    x, y = turn[:, 0], turn[:, 1]
    axis = x if np.linalg.norm(x[:2]) > 0.5 else y
    return math.atan2(float(axis[1]), float(axis[0]))


def square_turn(hand_quat, box_quat) -> float:
    """The least turn about the vertical (radians, within a quarter turn's half either way) that lays
    the hand's horizontal axes on the box's: 0 where the box has no orientation."""
    if not np.any(np.asarray(box_quat, dtype=float)):
        return 0.0
    slant = yaw_of(box_quat) - yaw_of(hand_quat)
    return (slant + math.pi / 4) % (math.pi / 2) - math.pi / 4


def grasp_turn(hand_quat, state: ObjectState) -> float:
    """The turn a grasp takes before it descends onto ``state``'s object: square to it where the object
    is longer than ``LONG_OBJECT`` across the table, else none. A block under the pads turns flat
    against them as they close, before the lift, and so ends square to the hand and the world, as a
    drawer or a bin wants it; squared to its own yaw instead, it is carried turned. A tool's ends rest
    on the table and resist, so it turns later, while it is carried."""
    if float(np.max(np.asarray(state.size, dtype=float)[:2])) <= LONG_OBJECT:
        return 0.0
    return square_turn(hand_quat, state.quat)


def grasped(obs: Observation, point) -> str | None:
    """The object a grasp at ``point`` closes on, by perception: the one (not held) whose box holds the
    point, the nearest centre where several do (a cube in a bin); None where none does."""
    point = np.asarray(point, dtype=float)
    held = obs.held()
    inside = [
        (float(np.linalg.norm(np.asarray(state.pos, dtype=float) - point)), name)
        for name, state in obs.objects.items()
        if name != held
        and np.any(state.size)
        and np.all(np.abs(np.asarray(state.pos, dtype=float) - point) <= np.asarray(state.size, dtype=float) / 2)
    ]
    return min(inside)[1] if inside else None
