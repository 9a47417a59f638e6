"""Paths that pass over what perception sees: the shared controllers' small planner.

A move's straight line may run the hand, or what it carries, through an object on the table (a
slab that landed mid-task, a bin's wall, a block beside the one to grasp). The planner sweeps the
hand's lowest parts (fingertips, or the held object's box) along the line against every perceived
box, and where one is in the way it lifts the path over it: up from the start, across above the
highest box crossed, down onto the goal. It plans from perception (boxes and the held object's
size, never the simulator's state) and the hand's own footprint, which calibration measures from
the gripper's model, so every embodiment, bundled or added by data, gets it through the controllers.

What the move acts on is no obstacle: the box the goal lies in (the cube a grasp descends into, the
button a press goes onto, the bin a release lowers into), and whatever the hand or its load already
lies against where the move starts (a block the rake drags, an object a tool pushes along: a cup put
down 5 mm behind the block it is to sweep).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from robosuite.utils.transform_utils import quat2mat

from lerobot_policy_recent.robosuite_envs.observation import POSITION_SIGMA, Observation

HAND_RADIUS = 0.07  # metres the open hand reaches sideways from the grip site (a Panda's touched a cube 7 cm off)
FINGER_DEPTH = 0.02  # metres the fingertips reach below the grip site
HAND_HEIGHT = 0.12  # metres of hand and wrist above the grip site that a box's underside could meet
CLEAR_MARGIN = 0.02  # metres the hand's lowest point passes above a box's top
GOAL_MARGIN = 0.01  # metres beyond a box within which a goal counts as the box's (perception's noise)
SLIDE_DEPTH = 0.01  # metres below a box's top the hand's lowest point may pass before the box is in the way
CLIMB_SPARE = 0.005  # metres a climb over a box that stopped the hand adds above the clearance
LOAD_CLEARANCE = 2.5 * POSITION_SIGMA  # metres a carried load's underside passes above a box's perceived top
# metres within which a point read from one frame is an object's own position: three sigmas of
# perception's noise on each axis (a point a skill computes off the position lies farther)
SAME_POINT = 0.02


@dataclass(frozen=True)
class Box:
    """An object's perceived axis-aligned box: its centre and half extents (metres, world)."""

    name: str
    centre: np.ndarray
    half: np.ndarray

    @property
    def top(self) -> float:
        return float(self.centre[2] + self.half[2])

    def contains(self, point: np.ndarray, margin: float = 0.0) -> bool:
        return bool(np.all(np.abs(np.asarray(point) - self.centre) <= self.half + margin))


@dataclass(frozen=True)
class Part:
    """A box that moves with the grip site: its centre's offset from it and its half extents (metres)."""

    offset: np.ndarray
    half: np.ndarray

    @property
    def bottom(self) -> float:
        """Its lowest point, relative to the grip site's height."""
        return float(self.offset[2] - self.half[2])


def hand(half_xy=(HAND_RADIUS, HAND_RADIUS)) -> Part:
    """The hand's box: ``half_xy`` across the table (world x, y), fingertips FINGER_DEPTH below the grip
    site, the hand and wrist HAND_HEIGHT above it."""
    return Part(
        offset=np.array([0.0, 0.0, (HAND_HEIGHT - FINGER_DEPTH) / 2]),
        half=np.array([*half_xy, (HAND_HEIGHT + FINGER_DEPTH) / 2]),
    )


HAND = hand()  # a hand of unknown size: as wide as a Panda's open hand reaches


def across_table(half_xy, eef_quat) -> tuple[float, float]:
    """A footprint measured along the grip site's x and y, as half extents along the world's x and y
    with the hand turned as ``eef_quat`` (xyzw) turns it (a box around the turned box)."""
    turn = np.abs(quat2mat(np.asarray(eef_quat, dtype=float))[:2, :2])
    return tuple(float(v) for v in turn @ np.asarray(half_xy, dtype=float))


@dataclass(frozen=True)
class Sweep:
    """What a moving hand occupies: its own box (first), and the held object's perceived box where it carries one."""

    parts: tuple[Part, ...] = (HAND,)

    @classmethod
    def of(cls, obs: Observation, hand_half_xy: tuple[float, float] | None = None) -> Sweep:
        """The hand as it is now, with the held object's box hanging from it as perception places it.
        ``hand_half_xy``: the gripper's calibrated footprint along the grip site's x and y (None: the
        nominal ``HAND``); a cup is narrower than a parallel jaw, whose open fingers and palm reach out
        along its closing axis."""
        own = HAND if hand_half_xy is None else hand(across_table(hand_half_xy, obs.eef_quat))
        held = obs.held()
        if held is None:
            return cls((own,))
        load = obs.objects[held]
        offset = np.asarray(load.pos, dtype=float) - np.asarray(obs.eef_pos, dtype=float)
        return cls((own, Part(offset, np.asarray(load.size, dtype=float) / 2)))

    def blocks(self, box: Box, start: np.ndarray, end: np.ndarray) -> bool:
        """The grip site's segment ``start`` → ``end`` sinks the hand into ``box`` by more than
        ``SLIDE_DEPTH`` (a hand sliding along at a marking's height is meant to be there), or carries
        its load over anything but a marking with less than ``LOAD_CLEARANCE`` to spare: both the
        load's underside and the box's top are perceived with noise, and a load that passes 2 mm
        above a block by the numbers may be resting on it and drag it along."""
        over_solid = 2 * box.half[2] > SLIDE_DEPTH  # taller than a marking
        for index, part in enumerate(self.parts):
            top = LOAD_CLEARANCE if index and over_solid else -SLIDE_DEPTH  # parts[0]: the hand
            low = box.centre - box.half - part.offset - part.half
            high = box.centre + box.half - part.offset + part.half + [0.0, 0.0, top]
            if segment_meets(start, end, low, high):
                return True
        return False

    def against(self, box: Box, point: np.ndarray) -> bool:
        """With the grip site at ``point``, the hand or its load is on or against ``box`` (within
        ``CLEAR_MARGIN`` of it): what may have stopped a move there, or what a move from there acts on."""
        point = np.asarray(point, dtype=float)
        return any(
            np.all(np.abs(point + part.offset - box.centre) <= box.half + part.half + CLEAR_MARGIN)
            for part in self.parts
        )

    def over(self, box: Box) -> float:
        """The grip site's height at which the hand's and its load's lowest points clear ``box``'s top."""
        return box.top + CLEAR_MARGIN - min(part.bottom for part in self.parts)


def boxes(obs: Observation) -> list[Box]:
    """Every object perception reports, as its box (the held one excluded: it moves with the hand)."""
    held = obs.held()
    return [
        Box(name, np.asarray(state.pos, dtype=float), np.asarray(state.size, dtype=float) / 2)
        for name, state in sorted(obs.objects.items())
        if name != held and np.any(np.asarray(state.size) > 0)
    ]


def object_at(perceived: list[Box], point, margin: float = SAME_POINT) -> Box | None:
    """The box of ``perceived`` whose object's own position ``point`` is, within ``margin`` (the
    noise of what the centres are: one frame's read, or a track's; the nearest where several are):
    a point that stands for the object itself, as a place by name's receptacle does
    (``task.get_object_position(box)``), not a point computed for the grip site (a corner of the
    bin's floor, a drop point above the plate). None where it is no object's."""
    point = np.asarray(point, dtype=float)
    near = [box for box in perceived if float(np.linalg.norm(box.centre - point)) <= margin]
    return min(near, key=lambda box: float(np.linalg.norm(box.centre - point)), default=None)


def path_over(start, goal, obstacles: list[Box], sweep: Sweep) -> list[np.ndarray]:
    """Waypoints from ``start`` to ``goal`` (the last is ``goal``) that keep the swept hand out of
    every box in ``obstacles``: the straight line where it is clear; else up, across above the
    boxes in the way, and down. Boxes the goal lies in, or that the hand or its load is against at
    the start (within ``CLEAR_MARGIN``, closer than the planner ever brings it to an obstacle), are
    what the move acts on and are passed through. Where going over does not help either (the
    descent itself meets a box beside the goal) the straight line is kept: nothing is made worse."""
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    in_the_way = [
        box
        for box in obstacles
        if not box.contains(goal, GOAL_MARGIN) and not sweep.against(box, start) and sweep.blocks(box, start, goal)
    ]
    if not in_the_way:
        return [goal]
    height = max(start[2], goal[2])
    for _ in range(len(obstacles) + 1):  # each pass may only raise the crossing: it settles
        crossed = [b for b in obstacles if sweep.blocks(b, np.r_[start[:2], height], np.r_[goal[:2], height])]
        needed = max((sweep.over(b) for b in crossed), default=height)
        if needed <= height:
            break
        height = needed
    rise, across = np.r_[start[:2], height], np.r_[goal[:2], height]
    legs = ((start, rise), (across, goal))
    if any(sweep.blocks(b, a, z) for b in in_the_way for a, z in legs if not b.contains(goal, GOAL_MARGIN)):
        return [goal]  # the climb or the descent itself meets the box: going over does not avoid it
    return [p for p in (rise, across) if np.linalg.norm(p - start) > 1e-4 and np.linalg.norm(p - goal) > 1e-4] + [goal]


def pushed(start, goal, obstacles: list[Box], sweep: Sweep) -> list[Box]:
    """The boxes a move from ``start`` pushes along: the move slides along the table, the grip site
    starts behind the box (its centre farther along the move than the box reaches back), the hand
    or its load is against it, and the line runs into it (a fist set down behind a block to sweep
    it), the goal's own box aside. :func:`path_over` passes through them; the move is to keep to
    its line. A hand at what it holds or presses on (a drawer's knob, on which the drawer's
    perceived box is centred) and a move up or away push nothing."""
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    along = goal - start
    length = float(np.linalg.norm(along[:2]))
    if length <= abs(float(along[2])):
        return []  # mostly up or down: no slide
    ahead = along[:2] / length
    return [
        box
        for box in obstacles
        if float(ahead @ (box.centre[:2] - start[:2])) > float(np.abs(ahead) @ box.half[:2])
        and not box.contains(goal, GOAL_MARGIN)
        and sweep.against(box, start)
        and sweep.blocks(box, start, goal)
    ]


def segment_meets(start: np.ndarray, end: np.ndarray, low: np.ndarray, high: np.ndarray) -> bool:
    """Whether the segment touches the axis-aligned box [low, high] (slab test), in space or on a plane."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    direction = end - start
    enter, leave = 0.0, 1.0
    for axis in range(len(start)):
        if abs(direction[axis]) < 1e-12:
            if not low[axis] <= start[axis] <= high[axis]:
                return False
            continue
        a, b = (low[axis] - start[axis]) / direction[axis], (high[axis] - start[axis]) / direction[axis]
        enter, leave = max(enter, min(a, b)), min(leave, max(a, b))
        if enter > leave:
            return False
    return True
