"""Run-time unit tests instantiated from the diagnosis' undetermined warnings.

Each check reads the latest observation and the values the guarded call receives, and either
passes or returns a :class:`Violation`: what was observed (rendered into the in-situ hints) and
the statements that would make the upcoming code valid again, written with the target robot's own
primitives. The rule backend applies those statements as they are; an LM is shown them as the cue
and writes the patch itself.

Preconditions are checked before the guarded statement starts; effects (``phase: after``) once it
has completed, and a violated effect asks for the statement to be done again from the current
scene (``rerun``), inserted right after it — what already ran is never repeated in place.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from robosuite.utils.transform_utils import quat2mat

from lerobot_policy_recent.ontology.specs import PATH_ROLE, WORLD_FRAME, ApiSpec, ParameterSpec, Waypoint
from lerobot_policy_recent.robosuite_envs.observation import POSITION_SIGMA, ObjectState, Observation
from lerobot_policy_recent.robosuite_envs.primitives import squaring
from lerobot_policy_recent.robosuite_envs.primitives.clearance import (
    FINGER_DEPTH,
    Box,
    across_table,
    boxes,
    object_at,
    segment_meets,
)
from lerobot_policy_recent.robosuite_envs.primitives.frames import WORLD_AT_ORIGIN, Frame, argument_for, world_point
from lerobot_policy_recent.skills.repository import Placement, StateEffect

FALSE_MOVES = 0.006  # the share of checks on a still object that may call it moved (each a needless patch)


def drift_threshold(sigma: float, false_rate: float = FALSE_MOVES) -> float:
    """Metres two reads of a still object differ by in only ``false_rate`` of checks.

    Each read errs by ``sigma`` per axis, so their difference has ``sigma * sqrt(2)`` per axis and
    its length follows a chi distribution with 3 degrees of freedom: the threshold is that
    distribution's ``1 - false_rate`` quantile, from the perception's stated accuracy alone.
    """

    def tail(r: float) -> float:  # P(chi_3 > r)
        return math.erfc(r / math.sqrt(2)) + math.sqrt(2 / math.pi) * r * math.exp(-r * r / 2)

    low, high = 0.0, 20.0
    for _ in range(60):
        mid = (low + high) / 2
        low, high = (mid, high) if tail(mid) > false_rate else (low, mid)
    return high * sigma * math.sqrt(2)


# metres an object may drift from where the skill read it before it counts as moved: beyond what the
# perception's noise explains (about 2 cm at 4 mm), and within what a grasp or a place on a 5 cm block tolerates
MOVED = drift_threshold(POSITION_SIGMA)
OFF_TABLE = 0.05  # metres an object's perceived top lies below the table top once it has left the table
CLEARANCE = 0.03  # metres around a release target that must be free
SLIDE_SHORT = 0.025  # metres a swept obstacle may stop short of where the hand leaves it
TABLE_LIMIT = 0.35  # |x|, |y| a swept obstacle may end at: 5 cm in from the 0.8 m table's edges
FINGER = 0.01  # metres from the hand's centre to the face that pushes
PUSH_TOLERANCE = 0.03  # metres a pushed object may end from where the push should leave it
PLACE_TOLERANCE = 0.04  # metres a released object may settle from the point it was released over
SETTLED_ABOVE = 0.02  # metres above that point it may rest: a place ends once its load rests, up to 2 cm high
FINGERTIPS = 0.015  # metres: half the closed fingertips' footprint, what comes down first on an empty sweep
START_MARGIN = 0.005  # metres a sweep's start is moved beyond what it would come down on
FINGER_SPAN = 0.055  # metres from a grasp's centre an open jaw reaches: half a 2F-85's 8.5 cm stroke, and a pad
# metres across its closing axis a finger reaches from the grasp's centre: half a pad (1.2 cm), perception's
# 3 sigma on where the obstacle lies, and a little for the hand's yaw turning on the way down
FINGER_ACROSS = 0.012 + 3 * POSITION_SIGMA + 0.003
# how far above a box's top an object's underside may be read and still lie on it (a tilted die, perception)
RESTING_GAP = 3 * POSITION_SIGMA + 0.003
MARKING = 0.005  # metres: what stands no higher off the table is a marking on it (a zone), no wall
FLAT_DEG = 10.0  # degrees a box set on top of another may lean and still lie flat on it (its faces, any of them)
JAW_STROKE = 0.075  # metres across an object the open jaw takes in with room to spare (a Franka Hand's 8 cm, less 5 mm)


@dataclass(frozen=True)
class SceneFacts:
    """What checks know besides the observation, from the workcell's model: which objects are loose (on
    a free joint, so they can end up somewhere unexpected) and every object's nominal extents. Never
    what kind an object is: a check decides from geometry and sensing."""

    loose: frozenset[str]
    sizes: dict[str, tuple[float, float, float]]  # every object of the scene (perception may report others)
    task_objects: frozenset[str] = frozenset()  # what the task's instruction names: never clutter to sweep away
    base_xy: tuple[float, float] = (0.0, 0.0)  # the robot's base on the table plane
    reach: float = float("inf")  # metres: the arm's reach (the ontology's upper bound)
    push_path: tuple[Waypoint, ...] = ()  # a push as its hand's path, for robots without one (the ontology's)
    table_reach: float = float("inf")  # metres from the base (table plane) the hand gets down to the table (calibrated)
    inner_reach: float = 0.0  # metres from the base (table plane) within which the hand, pointing down, stops short
    # (height above the table, metres from the base) beyond which the hand sent there pointing down stops
    # farther short than a move settles (calibrated at a few heights; see reach_in_the_air)
    reach_limits: tuple[tuple[float, float], ...] = ()
    table_top: float = float("-inf")  # world height of the table top (the workcell's, as calibration measured it)
    closing_axis: tuple[float, float, float] | None = None  # grip-site frame, one pad to the other (calibrated)
    hand_half_xy: tuple[float, float] | None = None  # metres, the open hand's half footprint along the grip site's x, y


@dataclass(frozen=True)
class Derivation:
    """An earlier statement the guarded call's values come from (``start`` computed from ``obj_pos``)."""

    source: str
    reads: frozenset[str]
    writes: frozenset[str]


@dataclass(frozen=True)
class CheckInput:
    obs: Observation
    arguments: dict[str, object]  # keyword values the guarded call will receive (evaluated now)
    # the guarded call's parameters (their units and frames), each with the role the warning reads it
    # in (a traced move's point is the original pick's grasp target)
    params: tuple[ParameterSpec, ...]
    named: frozenset[str]  # objects the skill's arguments name
    stale_reads: dict[str, tuple[str, list[float]]]  # variable -> (object, position read earlier)
    scene: SceneFacts
    api: ApiSpec
    derived: tuple[Derivation, ...] = ()  # the statements between those reads and the call, in order
    frames: dict[str, Frame] | None = None  # the robot's, where its API takes other frames than the world
    before: Observation | None = None  # for an effect: what the robot sensed when the statement started


@dataclass(frozen=True)
class Violation:
    check: str
    observation: str  # what was seen, for the hints and the log
    statements: tuple[str, ...] = ()  # to run before the segment; empty: nothing a patch can do
    instruction: str = ""  # the edit in words, as the LM's cue ("read obj_pos again")
    rerun: bool = False  # an effect that did not happen: do the statement again from the current scene
    cue: str = ""  # the observation as the LM's hint shows it; empty: ``observation`` itself
    follow: tuple[str, ...] = ()  # the skill's own statements, copied in after the patch (what derives from it)
    regrasp: bool = False  # with ``rerun``: the object is no longer in hand, so its grasp is done again first
    refuse: bool = False  # nothing can do it (a target beyond the arm's reach): the skill fails here, named
    # the robot's own statements that undo the patch once the guarded statement has run (a hand turned for
    # a grasp is turned back), copied in right after it where the patch is the one suggested
    after: tuple[str, ...] = ()


Check = Callable[[CheckInput], Violation | None]


def _by_role(inp: CheckInput, *roles: str) -> np.ndarray | None:
    """The world point (metres) the guarded call's argument of one of ``roles`` names, whatever the
    units and frame its API takes it in, or the observed position of the object it names by name;
    None where it names none."""
    for param in inp.params:
        if param.role in roles and param.name in inp.arguments:
            if param.type == "object_name":
                state = inp.obs.objects.get(str(inp.arguments[param.name]))
                return None if state is None else np.asarray(state.pos, dtype=float)
            if param.type not in ("position", "pose"):
                return None
            try:
                return world_point(inp.arguments[param.name], param.type, param.unit, _frame(inp, param))
            except (TypeError, ValueError):
                return None
    return None


def _named(inp: CheckInput, role: str) -> str | None:
    """The object name the guarded call's argument of ``role`` gives, if it takes one."""
    return next(
        (str(inp.arguments[p.name]) for p in inp.params if p.role == role and p.name in inp.arguments),
        None,
    )


def _frame(inp: CheckInput, param: ParameterSpec) -> Frame:
    return (inp.frames or {}).get(param.frame or WORLD_FRAME, WORLD_AT_ORIGIN)


def _argument(inp: CheckInput, param: ParameterSpec, point: np.ndarray) -> str:
    """A world point (metres) written as ``param`` takes it: its units, its frame, a pose's rotation the tool's."""
    value = argument_for(point, param.type, param.unit, _frame(inp, param), inp.obs.eef_quat)
    return "[" + ", ".join(f"{float(x):.{3 if param.unit in (None, 'm') else 1}f}" for x in value) + "]"


def _fmt(v) -> str:
    return "[" + ", ".join(f"{float(x):.3f}" for x in v) + "]"


def moved_reads(
    stale_reads: dict[str, tuple[str, list[float]]], obs: Observation
) -> list[tuple[str, str, float, np.ndarray]]:
    """(variable, object, drift, position now) for each read whose object moved more than ``MOVED``
    since — not one that is out of sight, nor one the hand holds (it moved it)."""
    out = []
    for variable, (name, then) in sorted(stale_reads.items()):
        state = obs.objects.get(name)
        if state is None or name == obs.held():
            continue
        drift = float(np.linalg.norm(np.asarray(state.pos) - np.asarray(then)))
        if drift > MOVED:
            out.append((variable, name, drift, state.pos))
    return out


def object_unmoved(inp: CheckInput) -> Violation | None:
    """Positions the call uses, itself or through values computed from them, were read before the
    object moved: re-read those that drifted (the patch), then recompute what was derived from
    them (the skill's own statements, copied: the LM writes only the edit)."""
    statements, seen, dirty = [], [], set()
    for variable, name, drift, now in moved_reads(inp.stale_reads, inp.obs):
        gone = off_table(inp.obs, inp.scene, name, now)
        if gone:  # fell off: nothing this robot does brings it back
            return Violation("object_unmoved", gone, refuse=True)
        seen.append(f"{name} moved {100 * drift:.1f} cm since {variable} was read (now at {_fmt(now)})")
        statements.append(f"{variable} = task.get_object_position({name!r})")
        dirty.add(variable)
    if not statements:
        return None
    instruction = f"read {', '.join(sorted(dirty))} again"
    follow = []
    for step in inp.derived:
        if step.reads & dirty:
            follow.append(step.source)
            dirty |= step.writes
    return Violation("object_unmoved", "; ".join(seen), tuple(statements), instruction, follow=tuple(follow))


def off_table(obs: Observation, scene: SceneFacts, name: str, now) -> str | None:
    """Where perception sees an object whose top lies below the table top (it left the table), or None."""
    top = float(now[2]) + seen_extents(obs, scene, name)[2] / 2
    if top >= scene.table_top - OFF_TABLE:
        return None
    return f"{name} lies at {_fmt(now)}, {scene.table_top - top:.2f} m below the table top: it left the table"


def object_present(inp: CheckInput) -> Violation | None:
    missing = sorted(n for n in inp.named if n in inp.scene.sizes and n not in inp.obs.objects)
    return Violation("object_present", f"not observed: {', '.join(missing)}") if missing else None


def target_clear(inp: CheckInput) -> Violation | None:
    """Something the skill does not name lies on the release target: sweep it off first."""
    held = _held(inp)
    carried = max((extents(inp, n)[2] / 2 for n in held), default=0.0)
    target = _by_role(inp, "release_target")
    if target is None and (receptacle := _named(inp, "release_receptacle")) is not None:
        # a place by name lowers the load onto the receptacle's top, over its middle
        state = inp.obs.objects.get(receptacle)
        if state is not None:
            target = np.asarray(state.pos, dtype=float) + [0.0, 0.0, extents(inp, receptacle)[2] / 2 + carried]
    if target is None:
        return None
    for name, state in _strangers(inp, held):
        size = extents(inp, name)
        half = max(size[:2]) / 2
        # in the way only if its top reaches where the held object's underside will be (not at a bin's bottom)
        reaches_up = state.pos[2] + size[2] / 2 > target[2] - carried - 0.01
        if np.linalg.norm(state.pos[:2] - target[:2]) < half + CLEARANCE and reaches_up:
            statements = sweep_statements(inp, name, held)
            what = f"{name} ({_described(size)}) lies"
            return Violation(
                "target_clear",
                f"{what} at {_fmt(state.pos)} on the release target {_fmt(target)}",
                statements,
                "push it off first: " + "; then ".join(statements),
                # the sweep's own coordinates are the only ones the LM sees: shown the slab's and the
                # target's too, the 1.5B sometimes copied those into the push (into the slab, which timed out)
                cue=f"{what} on the release target",
            )
    return None


class Jaw(NamedTuple):
    """Where the open fingers come down around a grasp's centre, on the table plane: a rectangle."""

    along: np.ndarray  # unit: the closing axis
    across: np.ndarray  # unit
    reach: float  # metres, half extent along
    width: float  # metres, half extent across

    def turned(self) -> Jaw:
        """The jaw after a quarter turn of the hand."""
        return Jaw(self.across, -self.along, self.reach, self.width)


def fingers_clear(inp: CheckInput) -> Violation | None:
    """An obstacle lies where an open finger comes down beside the object (a slab the push shoved
    along ahead of the cube, the wall of a box the object lies against): turn the hand a quarter turn
    where that clears the fingers of it, or sweep a loose one off first; else the hand stops on it,
    short of the grasp.

    The fingers come down along the jaw's closing axis, as the hand is turned now (the grasp keeps its
    yaw), so a block beside the object across that axis is clear of them. Judged in every direction, a
    block across the jaw was swept; a block along it was swept too where a turn cleared it, and the
    sweep ran the hand into the cabinet. Without a calibrated axis the jaw may reach out anywhere.
    The task's own objects are in the way as much as clutter is, but only a turn keeps the fingers
    off them: they are never swept.
    """
    target = _by_role(inp, "grasp_target")
    if target is None:
        return None
    held = _held(inp)
    jaw = _jaw(inp, target)
    loose = [name for name, _ in _strangers(inp, held)]
    neighbours = _neighbours(inp, held, target)
    blocking = [name for name in [*loose, *_fixed(inp), *neighbours] if _in_jaw(jaw, inp, name, target)]
    if not blocking:
        return None
    turn = _quarter_turn(inp, jaw, target, held)
    if turn and set(blocking) <= set(neighbours) and _palm_meets_wall(inp, jaw.turned(), target):
        return None  # turned for the task's own block, the palm would come down on a wall: left as it was
    name = blocking[0] if turn else next((n for n in blocking if n in loose), None)
    if name is None:
        return None  # only what is fixed to the table, and no turn clears it: nothing sweeps it
    state, size = inp.obs.objects[name], np.asarray(extents(inp, name), dtype=float)
    gap = float(np.max(np.abs(np.asarray(state.pos[:2]) - target[:2]) - size[:2] / 2))  # to its nearest face
    what = f"{name} ({_described(size)}) lies"
    observation = f"{what} at {_fmt(state.pos)}, {100 * max(gap, 0.0):.1f} cm from the grasp {_fmt(target)}: "
    if turn:
        return Violation(
            "fingers_clear",
            observation + "along the open fingers' closing axis",
            turn[:1],
            "turn the hand a quarter turn first: " + turn[0],
            cue=f"{what} where the open fingers come down, and not across them",
            # later skills were written for the hand as it was: turned, the hand met the box's open lid
            after=turn[1:],
        )
    statements = sweep_statements(inp, name, held)
    return Violation(
        "fingers_clear",
        observation + "within the open fingers' reach",
        statements,
        "push it away first: " + "; then ".join(statements),
        cue=f"{what} where the open fingers come down",
    )


def _palm_meets_wall(inp: CheckInput, jaw: Jaw, target: np.ndarray) -> bool:
    """The hand's calibrated footprint, its long side along ``jaw``'s closing axis (a parallel jaw's palm
    and fingers lie along it), centred over ``target``, meets a wall of the workcell that stands above
    the grasp (True where no footprint is known): a hand turned a quarter for a block beside the one it
    grasps can bring its long palm down on a box's wall, where the grasp as written was clear."""
    if inp.scene.hand_half_xy is None:
        return True
    long, short = max(inp.scene.hand_half_xy), min(inp.scene.hand_half_xy)
    half = np.abs(jaw.along) * long + np.abs(jaw.across) * short
    walls = [
        Box(name, np.asarray(inp.obs.objects[name].pos, dtype=float), np.asarray(extents(inp, name), dtype=float) / 2)
        for name in _fixed(inp)
    ]
    return any(box.top > target[2] and _footprint_meets(box, target, half) for box in walls)


def _neighbours(inp: CheckInput, held: set[str], target: np.ndarray) -> list[str]:
    """Loose objects the task or the skill names, other than the one grasped at ``target`` and what the
    hand holds: never swept (they are the task's), but a quarter turn may keep the fingers off them. A
    finger that comes down on a neighbouring block slides the hand off the one it grasps, which is
    then held off centre and set down off its spot."""
    return [
        name
        for name in sorted((inp.named | inp.scene.task_objects) - held)
        if name in inp.scene.loose and name in inp.obs.objects and not _under(inp, name, target)
    ]


def _under(inp: CheckInput, name: str, target: np.ndarray) -> bool:
    """``target`` lies over ``name``'s footprint: it is the object a grasp there closes on."""
    return bool(np.all(np.abs(inp.obs.objects[name].pos[:2] - target[:2]) <= np.asarray(extents(inp, name)[:2]) / 2))


def _fixed(inp: CheckInput) -> list[str]:
    """What perception sees that the workcell fixes to the table and stands up from it (a cabinet, a
    box; a zone marked on the table is no wall): never swept."""
    return sorted(
        n for n in inp.obs.objects if n in inp.scene.sizes and n not in inp.scene.loose and extents(inp, n)[2] > MARKING
    )


def _in_jaw(jaw: Jaw, inp: CheckInput, name: str, target: np.ndarray) -> bool:
    """The object's perceived box meets the open fingers' footprint and reaches up to where they come down."""
    return _reaches_fingers(inp, name, target) and _gap(jaw, inp, name, target) <= 0.0


def _reaches_fingers(inp: CheckInput, name: str, target: np.ndarray) -> bool:
    return inp.obs.objects[name].pos[2] + extents(inp, name)[2] / 2 > target[2] - FINGER_DEPTH


def _gap(jaw: Jaw, inp: CheckInput, name: str, target: np.ndarray) -> float:
    offset = np.asarray(inp.obs.objects[name].pos[:2], dtype=float) - target[:2]
    return _separation(jaw, offset, np.asarray(extents(inp, name)[:2], dtype=float) / 2)


def _quarter_turn(inp: CheckInput, jaw: Jaw, target: np.ndarray, held: set[str]) -> tuple[str, ...]:
    """The robot's yaw turn by a quarter and back, where it has one, the jaw's axis is known, the
    object fits across the turned jaw, and the turned jaw is clear of everything loose and farther
    from everything else than the jaw is now; else nothing. (Beside a box's wall, perception's noise
    leaves the turned fingers' few millimetres of room uncertain, where the wall in the jaw as it is
    is certain: farther is the test, not clear.)"""
    if inp.scene.closing_axis is None or jaw.reach == jaw.width or not (turn := _turn_calls(inp)):
        return ()
    turned = jaw.turned()
    if any(
        _in_jaw(turned, inp, name, target)
        for name in [*(n for n, _ in _strangers(inp, held)), *_neighbours(inp, held, target)]
    ):
        return ()
    if _clearance(turned, inp, target, held) <= _clearance(jaw, inp, target, held):
        return ()
    grasped = [n for n in _moved_objects(inp) if _under(inp, n, target)]
    if any(float(np.asarray(extents(inp, n)[:2]) @ np.abs(jaw.across)) > JAW_STROKE for n in grasped):
        return ()
    return turn


def _turn_calls(inp: CheckInput) -> tuple[str, ...]:
    """The robot's own calls that turn the hand a quarter turn about the vertical and back; none
    where its API has no yaw turn."""
    turn = inp.api.providing("rotate_end_effector")
    angle = None if turn is None else turn.by_role("yaw_angle")
    if angle is None:
        return ()
    return tuple(f"{turn.name}(env, task, {angle.name}={sign * math.pi / 2:.4f})" for sign in (1, -1))


def push_start_clear(inp: CheckInput) -> Violation | None:
    """A push's hand, come down at its start, would stand on or against what the push does not act
    on (the wall of a bin behind the cube: a hand long along the push reaches 10 cm back), and stop
    above its start: turn it a quarter turn first where that clears it, and back once the push is
    done. What the push acts on lies on its line, from the start to the goal. The hand's footprint
    is the calibrated one, as it is turned now, and it meets the workcell's walls (what is fixed to
    the table and stands up above the grip site there); what lies lower (a plate, a zone) meets
    only the fingertips, which come down on the line. A loose object's box is not its shape: a
    rake's covers the table between its crossbar and its handle, and the hand, turned for it, came
    down where nothing lay. Where no footprint is known, or no turn clears it, the push runs as
    written (and a stop is repaired as ever)."""
    start, goal = _by_role(inp, "push_start"), _by_role(inp, "push_goal")
    if start is None or goal is None or inp.scene.hand_half_xy is None or not (turn := _turn_calls(inp)):
        return None
    half = np.asarray(across_table(inp.scene.hand_half_xy, inp.obs.eef_quat), dtype=float)
    fixed = [
        Box(name, np.asarray(inp.obs.objects[name].pos, dtype=float), np.asarray(extents(inp, name), dtype=float) / 2)
        for name in _fixed(inp)
    ]
    walls = [box for box in fixed if box.top > start[2] and not _on_line(box, start, goal)]
    met = [box for box in walls if _footprint_meets(box, start, half)]
    if not met or any(_footprint_meets(box, start, half[::-1]) for box in walls):
        return None
    names = ", ".join(box.name for box in met)
    return Violation(
        "push_start_clear",
        f"{names} stands where the hand, {100 * 2 * half[0]:.0f} x {100 * 2 * half[1]:.0f} cm across the table as it "
        f"is turned now, comes down at the push's start {_fmt(start)}; turned a quarter, it is clear",
        turn[:1],
        "turn the hand a quarter turn first: " + turn[0],
        cue=f"{names} where the hand comes down to push, and not once it is turned",
        after=turn[1:],
    )


def _on_line(box: Box, start: np.ndarray, goal: np.ndarray) -> bool:
    """The push's line, on the table plane, passes over the box's footprint: what it pushes."""
    low, high = box.centre[:2] - box.half[:2], box.centre[:2] + box.half[:2]
    return segment_meets(start[:2], goal[:2], low, high)


def _footprint_meets(box: Box, point: np.ndarray, half: np.ndarray) -> bool:
    """The hand's footprint (``half`` across the table) centred at ``point`` overlaps the box's."""
    return bool(np.all(np.abs(box.centre[:2] - point[:2]) < box.half[:2] + half))


def _clearance(jaw: Jaw, inp: CheckInput, target: np.ndarray, held: set[str]) -> float:
    """Metres from the jaw to the nearest obstacle, loose or fixed, that reaches up to where the fingers
    come down (negative: one lies in it)."""
    obstacles = [*(n for n, _ in _strangers(inp, held)), *_fixed(inp), *_neighbours(inp, held, target)]
    return min((_gap(jaw, inp, n, target) for n in obstacles if _reaches_fingers(inp, n, target)), default=math.inf)


def _jaw(inp: CheckInput, target: np.ndarray) -> Jaw:
    """The open fingers' rectangle around a grasp at ``target``, along the closing axis as the hand is
    turned now and then squared to what it grasps, as the grasp squares it (a square without an axis)."""
    axis = inp.scene.closing_axis
    if axis is not None:
        along = (quat2mat(np.asarray(inp.obs.eef_quat, dtype=float)) @ np.asarray(axis, dtype=float))[:2]
        if np.linalg.norm(along) > 0.5:  # pointing down: the closing axis lies near the table plane
            grasped = squaring.grasped(inp.obs, target)
            if grasped is not None:
                turn = squaring.grasp_turn(inp.obs.eef_quat, inp.obs.objects[grasped])
                along = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]]) @ along
            along = along / np.linalg.norm(along)
            return Jaw(along, np.array([-along[1], along[0]]), FINGER_SPAN, FINGER_ACROSS)
    return Jaw(np.array([1.0, 0.0]), np.array([0.0, 1.0]), FINGER_SPAN, FINGER_SPAN)


def _separation(jaw: Jaw, offset: np.ndarray, half: np.ndarray) -> float:
    """Metres between the jaw's rectangle and an axis-aligned box ``offset`` from its centre (negative:
    they overlap), the largest gap over the four axes that could separate them."""
    gaps = []
    for axis in (jaw.along, jaw.across, np.array([1.0, 0.0]), np.array([0.0, 1.0])):
        jaw_radius = jaw.reach * abs(float(jaw.along @ axis)) + jaw.width * abs(float(jaw.across @ axis))
        gaps.append(abs(float(offset @ axis)) - jaw_radius - float(half @ np.abs(axis)))
    return max(gaps)


def _held(inp: CheckInput) -> set[str]:
    """What the grip holds, as the robot infers it from its gripper's sensors and perception."""
    held = inp.obs.held()
    return set() if held is None else {held}


def _strangers(inp: CheckInput, held: set[str]) -> list[tuple[str, object]]:
    """Loose objects neither the skill nor the task names, and the hand does not hold (``held``): clutter
    that may be in the way. Perception may report an object the workcell's model does not list: it is loose too."""
    return [
        (name, state)
        for name, state in sorted(inp.obs.objects.items())
        if name not in inp.named | inp.scene.task_objects | held
        and (name in inp.scene.loose or name not in inp.scene.sizes)
    ]


def extents(inp: CheckInput, name: str) -> tuple[float, float, float]:
    """An object's bounding-box extents as perception reports them (the model's nominal ones where it does not)."""
    return seen_extents(inp.obs, inp.scene, name)


def seen_extents(obs: Observation, scene: SceneFacts, name: str) -> tuple[float, float, float]:
    state = obs.objects.get(name)
    if state is not None and np.any(state.size):
        return tuple(float(v) for v in state.size)
    return scene.sizes.get(name, (0.05, 0.05, 0.05))


def _described(size) -> str:
    """An obstacle in words, from its bounding box alone: a flat one is a slab, anything else a block."""
    wide = f"{max(size[:2]):.2f} m wide"
    return f"slab, {wide}" if size[2] < min(size[:2]) / 2 else f"block, {wide}, {size[2]:.2f} m high"


def sweep_statements(inp: CheckInput, obstacle: str, held: set[str]) -> tuple[str, ...]:
    """Slide the hand (and whatever it holds) through the obstacle until it is clear of the target.

    The start must be free: the hand (or its load) does not come down on anything else there, once
    moved a little across the sweep if need be. The hand's start and end must lie within the arm's
    reach at the table (calibrated: a Panda gets its hand low only about 0.8 m from its base). Among
    such sweeps, sideways, towards the base or away from it, the side is the one where the swept
    obstacle ends farthest from everything else on the table (objects it rests on excepted). (Before
    the reach at the table was known, sideways sweeps were preferred as the ones that stay in reach;
    one left a slab 3 cm from the next object to grasp, with no reachable sweep left to clear it.)
    """
    state = inp.obs.objects[obstacle]
    size = extents(inp, obstacle)
    centre, half = np.asarray(state.pos, dtype=float), max(size[:2]) / 2
    # how far its centre moves: at best its near side ends an open finger's reach from the target (what is
    # put there may be grasped again: a slab swept only clear of it was in the fingers' way at the next
    # pick); where that would run it into something else, less, down to just clear of the target
    shifts = (
        half + FINGER_SPAN + SLIDE_SHORT,
        half + (FINGER_SPAN + CLEARANCE) / 2 + SLIDE_SHORT,
        half + CLEARANCE + SLIDE_SHORT,
    )
    carried = max((extents(inp, n) for n in held), key=lambda s: s[2], default=None)
    bottom = centre[2] - size[2] / 2
    # the held object's lower face (or the closed fingertips, ~2 cm below the grip site) just above the surface
    height = bottom + (0.012 + carried[2] / 2 if carried else 0.025)
    lead = carried[0] / 2 if carried else 0.01  # grip site to the face that touches the obstacle

    def beneath(name: str, seen) -> bool:
        """The obstacle rests on it: its top is below the obstacle's middle, under the obstacle's centre
        (its top read against the obstacle's bottom, each with perception's noise, would not tell)."""
        size = extents(inp, name)
        inside = np.all(np.abs(centre[:2] - seen.pos[:2]) < np.asarray(size[:2]) / 2)
        return bool(inside and seen.pos[2] + size[2] / 2 < centre[2])

    others = [
        (s.pos[:2], np.asarray(extents(inp, n)[:2]) / 2)
        for n, s in inp.obs.objects.items()
        if n != obstacle and n not in held and s.pos[2] + extents(inp, n)[2] / 2 > bottom + 0.005 and not beneath(n, s)
    ]

    # what comes down at the start: the load's footprint, or the closed fingertips'
    footprint = np.asarray(carried[:2], dtype=float) / 2 if carried else np.full(2, FINGERTIPS)

    base = np.asarray(inp.scene.base_xy, dtype=float)

    def reachable(point: np.ndarray) -> bool:
        return float(np.linalg.norm(point - base)) <= inp.scene.table_reach

    def gap(direction: np.ndarray, shift: float) -> float:
        end = centre[:2] + direction * shift
        if np.any((np.abs(end) + half > TABLE_LIMIT) & (np.abs(end) > np.abs(centre[:2]))):
            return -1.0  # farther out than it is, off the table (where it already lies out there, alongside is fine)
        return min((float(np.max(np.abs(end - pos) - extent - half)) for pos, extent in others), default=1.0)

    def start_of(direction: np.ndarray) -> tuple[bool, np.ndarray]:
        """Where the hand comes down to start the sweep, moved across the sweep off anything else lying
        there (by at most a quarter of the obstacle's width: the hand still pushes near its middle),
        and whether that leaves it free."""
        nominal = centre[:2] - direction * (half + lead + 0.02)
        across = np.abs(direction[::-1])  # the table axis across the sweep
        at = nominal.copy()
        for pos, extent in others:
            overlap = extent + footprint - np.abs(at - pos)
            if np.all(overlap > 0):
                away = 1.0 if float((at - pos) @ across) >= 0 else -1.0
                at = at + across * away * (float(overlap @ across) + START_MARGIN)
        clear = all(np.any(np.abs(at - pos) >= extent + footprint) for pos, extent in others)
        return clear and float(np.abs((at - nominal) @ across)) <= half / 2, at

    def plan(direction: np.ndarray) -> tuple[tuple, np.ndarray, np.ndarray]:
        """A sweep this way: its rank, and the hand's start and end. Its shift is the farthest of
        ``shifts`` that leaves the obstacle clear of everything else with the hand's end in reach
        (else the least)."""
        free, at = start_of(direction)
        ends = [(d, at + direction * (d + 0.02)) for d in shifts]  # where its near side ends clear
        fits = [(d, end) for d, end in ends if reachable(end)] or ends[-1:]
        d, end = next(((d, end) for d, end in fits if gap(direction, d) > 0.0), fits[-1])
        clear = gap(direction, d)
        return (free and reachable(at) and reachable(end), clear > 0.0, clear), at, end

    directions = [np.array(d, dtype=float) for d in ((0, 1), (0, -1), (-1, 0), (1, 0))]
    _, at, end = max((plan(d) for d in directions), key=lambda p: p[0])
    start, goal = np.array([*at, height]), np.array([*end, height])
    return _push_calls(inp, start, goal)


def _push_calls(inp: CheckInput, start: np.ndarray, goal: np.ndarray) -> tuple[str, ...]:
    """The robot's own push primitive when it has one, else its Cartesian moves along a push's path."""
    push = inp.api.providing("push_object")
    if push is not None:
        begin, end = push.by_role("push_start"), push.by_role("push_goal")
        if begin is not None and end is not None:
            return (
                f"{push.name}(env, task, {begin.name}={_argument(inp, begin, start)}, "
                f"{end.name}={_argument(inp, end, goal)})",
            )
    move = next(iter(inp.api.point_moves()), None)
    if move is None:
        return ()  # nothing to sweep with: the check reports what it saw, and the skill runs on
    at = {"push_start": start, "push_goal": goal}
    point = move.by_role(PATH_ROLE)
    return tuple(
        f"{move.name}(env, task, {point.name}={_argument(inp, point, at[w.role] + np.asarray(w.offset))})"
        for w in inp.scene.push_path
        if w.role in at
    )


POSITION_ROLES = ("grasp_target", "release_target", "motion_target", "push_start", "push_goal", "handle_target")


def within_reach(inp: CheckInput) -> Violation | None:
    """A target farther from the base (on the table plane) than the arm reaches, nearer to it than the
    hand gets pointing down (a long arm's elbow folds only so far: calibrated), or below the table
    top, cannot be attained: the skill is refused there, by name, before the arm is sent (no patch can
    move the robot, or bring back what fell off the table)."""
    base = np.asarray(inp.scene.base_xy, dtype=float)
    for role in POSITION_ROLES:
        target = _by_role(inp, role)
        if target is None:
            continue
        distance = float(np.linalg.norm(target[:2] - base))
        where = f"{role.replace('_', ' ')} {_fmt(target)} lies"
        if target[2] < inp.scene.table_top - OFF_TABLE:  # read from an object that left the table
            why = f"{inp.scene.table_top - target[2]:.2f} m below the table top: what it was read from left the table"
        elif distance > inp.scene.reach:
            why = f"{distance:.2f} m from the base, beyond the arm's {inp.scene.reach:.2f} m reach"
        elif distance > (limit := reach_in_the_air(inp.scene, float(target[2]) - inp.scene.table_top)):
            why = (
                f"{distance:.2f} m from the base, {(target[2] - inp.scene.table_top) * 100:.0f} cm above the table, "
                f"beyond the {limit:.2f} m the hand reaches pointing down there (calibrated)"
            )
        elif distance <= inp.scene.inner_reach:
            why = (
                f"{distance:.2f} m from the base, where the hand, pointing down, stops short (calibrated: within "
                f"{inp.scene.inner_reach:.2f} m)"
            )
        else:
            continue
        return Violation("within_reach", f"{where} {why}", refuse=True)
    return None


def reach_in_the_air(scene: SceneFacts, height: float) -> float:
    """How far from the base a target ``height`` above the table may lie before the hand, pointing
    down, stops farther short of it than a move settles: the farther of the calibrated limits at the
    heights walked either side (the reach bulges between them by under 2 mm); inf outside them, or
    where nothing was measured. Nearer the table no walk bounds a target: a push's goal may lie
    past the hand (the block gets there first), and an xArm 7 carried a rake 0.75 m out, 7 cm up,
    beyond the 0.72 m the walk at the table first stopped short of."""
    limits = sorted(scene.reach_limits)
    if not limits or not limits[0][0] <= height <= limits[-1][0]:
        return float("inf")
    below = [d for h, d in limits if h <= height][-1]
    above = next(d for h, d in limits if h >= height)
    return max(below, above)


def _moved_objects(inp: CheckInput) -> list[str]:
    """The loose objects the skill names: what its grasps and pushes act on."""
    return sorted(n for n in inp.named if n in inp.scene.loose and n in inp.obs.objects)


def object_held(inp: CheckInput) -> Violation | None:
    """After a grasp: one of the objects the skill names is held."""
    candidates = _moved_objects(inp)
    if not candidates or inp.obs.held() in candidates:
        return None
    where = "; ".join(f"{n} at {_fmt(inp.obs.objects[n].pos)}" for n in candidates)
    return Violation("object_held", f"nothing held after the grasp ({where})", rerun=True)


def pushed_to_goal(inp: CheckInput) -> Violation | None:
    """After a push: the object ended just ahead of where the hand stopped, on the push line."""
    start, goal = _by_role(inp, "push_start"), _by_role(inp, "push_goal")
    candidates = _moved_objects(inp)
    if start is None or goal is None or not candidates:
        return None
    direction = goal[:2] - start[:2]
    if np.linalg.norm(direction) < 1e-6:
        return None
    direction /= np.linalg.norm(direction)

    def miss(name: str) -> tuple[float, np.ndarray]:
        half = extents(inp, name)[0] / 2
        expected = goal[:2] + direction * (half + FINGER)
        return float(np.linalg.norm(inp.obs.objects[name].pos[:2] - expected)), expected

    name = min(candidates, key=lambda n: miss(n)[0])
    distance, expected = miss(name)
    if distance <= PUSH_TOLERANCE:
        return None
    return Violation(
        "pushed_to_goal",
        f"{name} ended at {_fmt(inp.obs.objects[name].pos)}, {100 * distance:.1f} cm from where the push should "
        f"leave it ([{expected[0]:.3f}, {expected[1]:.3f}])",
        rerun=True,
    )


def placed_at_target(inp: CheckInput) -> Violation | None:
    """After a place: an object the skill names, out of the hand, rests where it was put: within
    ``PLACE_TOLERANCE`` of the release point and at its height, or on or in the receptacle's box
    (a place by name, or a release point that was an object's own position before the call: the
    controllers put the load onto it). One that slid off, or fell beside, is grasped again and put
    there again. What the target stands on (the tower's base under the block it is put on) is not
    a candidate."""
    point = _by_role(inp, "release_target")
    receptacle = _named(inp, "release_receptacle")
    if receptacle is None and point is not None and inp.before is not None:
        onto = object_at(boxes(inp.before), point)  # one frame's read: its noise, SAME_POINT
        receptacle = None if onto is None else onto.name
    if receptacle is not None:
        support = inp.obs.objects.get(receptacle)
        if support is None:
            return None
        point = np.asarray(support.pos, dtype=float)
        box = extents(inp, receptacle)
        floor = point[2] - box[2] / 2  # its bottom: what lies lower is what it stands on
    if point is None:
        return None

    def below(name: str) -> bool:
        """Under the target: what it stands on."""
        pos = inp.obs.objects[name].pos
        if receptacle is not None:
            return pos[2] < floor and beyond_footprint(pos, point, box) == 0.0
        under = float(np.linalg.norm(pos[:2] - point[:2])) < PLACE_TOLERANCE
        return under and pos[2] < point[2] - extents(inp, name)[2] / 2 - 0.01

    def off(name: str) -> float:
        """How far the object is from resting there (0: it does), in metres."""
        pos = np.asarray(inp.obs.objects[name].pos, dtype=float)
        if receptacle is not None:
            return beyond_footprint(pos, point, box)
        if pos[2] > point[2] + SETTLED_ABOVE:  # resting on something lying on the target
            return float(np.linalg.norm(pos - point))
        return max(float(np.linalg.norm(pos[:2] - point[:2])) - PLACE_TOLERANCE, 0.0)

    # what the hand carried in, where it was put relative to the grip (a rake is held by its handle)
    carried = inp.before.held() if inp.before is not None else None
    if carried is not None and carried in inp.obs.objects and receptacle is None:
        point = point + np.r_[(inp.before.objects[carried].pos - inp.before.eef_pos)[:2], 0.0]
    held = inp.obs.held()
    candidates = [carried] if carried in inp.obs.objects else _moved_objects(inp)
    candidates = [n for n in candidates if n not in (receptacle, held) and not below(n)]
    if not candidates:
        return None
    name = min(candidates, key=off)
    if off(name) == 0.0:
        return None
    pos = inp.obs.objects[name].pos
    where = f"{receptacle} at {_fmt(point)}" if receptacle is not None else f"the release target {_fmt(point)}"
    across = 100 * float(np.linalg.norm(np.asarray(pos[:2]) - point[:2]))
    return Violation(
        "placed_at_target",
        f"{name} rests at {_fmt(pos)}, {across:.1f} cm across from {where}",
        rerun=True,
        regrasp=True,
    )


def underside_above(seen: ObjectState, support: ObjectState) -> float:
    """Metres the object's perceived underside lies above the support's perceived top (below: negative)."""
    return float(seen.pos[2] - seen.size[2] / 2 - (support.pos[2] + support.size[2] / 2))


def resting_on_other(name: str, over: str, obs: Observation) -> str | None:
    """The perceived object other than ``over`` that ``name`` lies on, above ``over``'s top: a dice
    set down on a slab that lay in the zone is over the zone, yet not on it. None where ``name``
    is down at ``over``'s top or below it (on a plate, inside a bin or a drawer, whatever is under it
    there), or where nothing else lies under it."""
    seen, support = obs.objects[name], obs.objects[over]
    if not np.any(seen.size):
        return None
    if underside_above(seen, support) <= RESTING_GAP:
        return None
    bottom = seen.pos[2] - seen.size[2] / 2
    for other, state in sorted(obs.objects.items()):
        if other in (name, over) or not np.any(state.size):
            continue
        top = state.pos[2] + state.size[2] / 2
        if abs(bottom - top) < RESTING_GAP and beyond_footprint(seen.pos, state.pos, state.size) == 0.0:
            return other
    return None


def marking(support: ObjectState) -> bool:
    """A box no taller than what rests on it can be told from (a zone, a plate): a mark on the table,
    not a support that stands up from it."""
    return support.size[2] <= RESTING_GAP


def leaning(seen: ObjectState, support: ObjectState) -> float | None:
    """Degrees an object set on top of a box standing up from the table leans (none of its faces flat,
    as perception reads its orientation), where that is over ``FLAT_DEG``; else None. A block that
    leans on the one below it is on its way off, however its centre lies: a cup that pressed on
    tipped the middle block of a tower, and the top one slid off after the check had passed it.
    Inside a bin or a drawer, or on a marking, a leaning object is where it should be."""
    quat = np.asarray(seen.quat, dtype=float)
    if not np.any(quat) or marking(support):
        return None
    if underside_above(seen, support) < -RESTING_GAP:
        return None  # down inside it, not on top
    upright = float(np.max(np.abs(quat2mat(quat / np.linalg.norm(quat))[2])))  # the face axis nearest vertical
    lean = math.degrees(math.acos(min(1.0, upright)))
    return lean if lean > FLAT_DEG else None


def beyond_footprint(pos, centre, size, widen: float = 3 * POSITION_SIGMA) -> float:
    """Metres across the table that ``pos`` lies outside a box's footprint, widened by ``widen`` (by default
    three sigmas of perception's accuracy) (0: over it)."""
    margin = np.asarray(size[:2], dtype=float) / 2 + widen
    offset = np.abs(np.asarray(pos[:2], dtype=float) - np.asarray(centre[:2], dtype=float))
    return float(np.linalg.norm(np.maximum(offset - margin, 0.0)))


def state_reached(effect: StateEffect, name: object, obs: Observation) -> tuple[bool, str]:
    """Once a skill has run: whether perception reads the object's state as the skill leaves it, and what it read."""
    seen = obs.objects.get(name) if isinstance(name, str) else None
    if seen is None:
        return False, f"{name!r} ({effect.parameter}) is not in view: its state cannot be read"
    return not effect.unmet(seen.state), f"{name}'s state reads {seen.state:.3f}; the skill leaves it {effect.wanted}"


def placement_reached(placement: Placement, name: object, over: object, obs: Observation) -> tuple[bool, str]:
    """Once a skill has run: whether perception sees the object over the other's box (its footprint, not
    below its bottom; wholly within it where the placement says ``inside``), resting on it, not on
    something else above it, and where it sees it. A box perception gives no extents for is not judged."""
    seen = obs.objects.get(name) if isinstance(name, str) else None
    support = obs.objects.get(over) if isinstance(over, str) else None
    if seen is None or support is None:
        missing = placement.parameter if seen is None else placement.over
        return False, f"{missing} is not in view: where {placement.parameter} ended cannot be read"
    where = f"{name} rests at {_fmt(seen.pos)}"
    if not np.any(support.size):
        return True, f"{where}; {over} has no perceived extents"
    # inside a marking is where its centre reads: widened by perception's noise, a cube pushed 1 cm beyond
    # a zone's edge passed and the task failed. A support that stands up holds what lies on it, so
    # there the read is given perception's three sigmas.
    room = np.asarray(support.size, dtype=float) - (np.asarray(seen.size, dtype=float) if placement.inside else 0.0)
    outside = beyond_footprint(seen.pos, support.pos, room, widen=0.0 if marking(support) else 3 * POSITION_SIGMA)
    under = seen.pos[2] < support.pos[2] - support.size[2] / 2 - POSITION_SIGMA
    if outside or under:
        beyond = f"{100 * outside:.1f} cm {'of it ' if placement.inside else ''}outside {over}'s box"
        return False, f"{where}, {beyond}{' and below it' if under else ''}"
    if other := resting_on_other(name, over, obs):
        return False, f"{where}, on {other}, not on {over}"
    if np.any(seen.size) and (gap := underside_above(seen, support)) > RESTING_GAP:
        # on nothing perception can name (tilted on the edge of a slab): held up, not on it
        return False, f"{where}, {100 * gap:.1f} cm above {over}'s top: resting on something else"
    if (lean := leaning(seen, support)) is not None:
        return False, f"{where}, leaning {lean:.0f} degrees on {over}: not lying flat on it"
    if placement.at is None:
        return True, f"{where}, {'within' if placement.inside else 'over'} {over}"
    # at a spot: it lies under the object's own perceived box (moved off it later, by a neighbour's carry, it does not)
    spot = np.asarray(support.pos[:2], dtype=float) + placement.at
    off = beyond_footprint(spot, seen.pos, seen.size)
    if off == 0.0:
        return True, f"{where}, on its spot of {over} at {_fmt(spot)}"
    return False, f"{where}, {100 * off:.1f} cm off its spot of {over} at {_fmt(spot)}"


CHECKS: dict[str, Check] = {
    "object_unmoved": object_unmoved,
    "object_present": object_present,
    "target_clear": target_clear,
    "fingers_clear": fingers_clear,
    "within_reach": within_reach,
    "object_held": object_held,
    "pushed_to_goal": pushed_to_goal,
    "placed_at_target": placed_at_target,
    "push_start_clear": push_start_clear,
}
