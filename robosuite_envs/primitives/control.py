"""Closed-loop controllers from observation to an OSC_POSE delta action, one step per ``next()``.

Every embodiment's primitive API is a thin, differently-named layer over these generators, so the
behaviour a skill relies on is identical across robots and only the bindings differ.
"""

from __future__ import annotations

from lerobot_policy_recent.robosuite_envs import runtime  # noqa: F401  (headless GL before robosuite loads)

# isort: split
from collections import deque
from collections.abc import Generator, Sequence
from dataclasses import replace

import numpy as np
from robosuite.utils.transform_utils import axisangle2quat, mat2quat, quat2axisangle, quat2mat, quat_multiply

from lerobot_policy_recent.robosuite_envs.observation import ACTION_DIM
from lerobot_policy_recent.robosuite_envs.primitives import clearance, squaring
from lerobot_policy_recent.robosuite_envs.primitives.session import CONTROL_FREQ, PrimitiveFailure, RobotSession
from lerobot_policy_recent.robosuite_envs.table import TABLE_OFFSET

Action = np.ndarray
Steps = Generator[Action, None, None]

POS_SCALE = 0.05  # metres per unit action (robosuite OSC_POSE output_max)
ROT_SCALE = 0.5  # radians per unit action
ROT_DEADBAND = 0.06  # radians of orientation error left uncorrected while moving
MAX_STEP = 0.02  # metres of goal displacement per control step (~0.4 m/s)
BREAKAWAY_GROWTH = 1.25  # per step, the factor by which a stopped free arm's setpoint reach grows (_breakaway)
POS_TOL = 0.008
VIA_TOL = 0.02  # metres within which a waypoint the planner put on the way counts as passed
SETTLED = 0.001  # metres per control step below which a servoed grip site counts as stopped
STALL_STEPS = 10  # control steps over which a grip site is judged stopped (a lowered load set down, an arm stalled)
# A drag (a drawer pulled against its damping, a lid swung by its knob) stalls 1-2 cm short of its
# goal: a settling move that has stopped within DRAG_TOL while it drives a mechanism has arrived.
DRAG_TOL = 0.025
DRIVEN = 0.01  # change of an object's perceived state (m, rad, share) that shows the hand drove its mechanism
SET_DOWN_GAP = 0.02  # metres above its target a grip site may stop once the held object rests on the surface
APPROACH_HEIGHT = 0.10
PUSH_BACK_OFF = 0.04  # metres a push's fist withdraws back along the push as it rises (_withdrawal)
TABLE_CLEARANCE = 0.805  # z below which the fingers would hit the table top (metres, world)
FIST_FLOOR = 0.001  # metres above the table top a closed, empty hand's lowest point is kept
GRIPPER_WAIT_S = 3.0  # longest a gripper command is held by default (a slower calibrated stroke: longer)
OPEN_ENOUGH = 0.8  # fraction of its calibrated stroke a gripper must open to let go
STROKE_MARGIN = 1.5  # a full stroke may take this multiple of its calibrated time (under load, against friction)
UNFOLD_RISE = 0.12  # metres a trapped arm rises before it goes back by the table's middle (_unfold)
UNFOLD_SHORT = 0.05  # metres short of its goal a stopped arm counts as trapped, not off by its tracking error
SQUARE_S = 2.0  # longest a grasp turns its jaw square to the object before it descends anyway
SQUEEZE_STEPS = 10  # control steps a closing gripper keeps closing on what it holds before its command is held


def servo_action(
    session: RobotSession, target_pos: np.ndarray, reach: float = MAX_STEP, *, deadband: float = ROT_DEADBAND
) -> Action:
    """One P-step towards ``target_pos`` holding the session's orientation, with its gripper command.
    ``reach``: how far ahead of the grip site the step's setpoint may lie, per axis (metres); a
    reach grown past ``MAX_STEP`` (:func:`_breakaway`) scales the error by as much, so that an arm
    stalled near its goal, where the error and not the reach sets the step, is pushed harder too.
    ``deadband``: the orientation error left uncorrected (radians)."""
    obs = session.obs
    delta = np.clip((target_pos - obs.eef_pos) * max(1.0, reach / MAX_STEP), -reach, reach)
    rot = rotation_error(session)
    if np.linalg.norm(rot) < deadband:
        rot = np.zeros(3)  # small tilts are harmless; fighting them stalls arms near singular postures
    action = np.zeros(ACTION_DIM)
    action[:3] = np.clip(delta / POS_SCALE, -1.0, 1.0)
    action[3:6] = np.clip(rot / ROT_SCALE, -1.0, 1.0)
    action[6] = session.gripper_command
    return action


def as_position(value: Sequence[float], what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64).reshape(-1)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise PrimitiveFailure("unreachable", f"{what} must be three finite numbers [x, y, z], got {value!r}")
    return arr


def move_to(
    session: RobotSession,
    target: Sequence[float],
    *,
    timeout_s: float = 6.0,
    tol: float | None = None,
    stop_on_contact: bool = False,
    settle: bool = False,
    straight: bool = False,
    set_down: bool = False,
    plan: bool = True,
) -> Steps:
    """Servo the grip site to ``target`` (world frame, metres); fail with ``timeout`` if it does not settle.

    ``stop_on_contact``: a compliant tool (a vacuum cup) arrives once it rests on a surface right
    above the target — it cannot go through what it would seal on — or once what it carries rests
    on something on the way down; resting means stopped there: a button's cap gives way under it
    until it bottoms out (stopped on first touch, the cup pressed nothing).
    ``settle``: for an arm whose tracking stops short of the target, ``tol`` is where it may stop,
    not where it stops trying: the move ends within ``POS_TOL``, or within ``tol`` once the grip
    site no longer moves (a press that returned on entering ``tol`` stopped 2 cm above the button).
    ``tol`` defaults to the arm's calibrated ``settle_tol_m`` when settling, else ``POS_TOL``.
    ``straight``: follow the line from where the move (or each leg of a planned one) starts (a push
    slides an object along it); otherwise each axis closes its own error, and a diagonal move bends.
    ``set_down``: lowering a held object, which may reach the surface before the grip site reaches
    ``target`` (a target computed from a noisy read of the object's height): the move ends once
    the grip site has stopped just above it with the load in hand (:func:`load_rests`).
    ``plan``: the move goes over the perceived boxes its line would run the
    hand or its load through (:mod:`.clearance`), and once held up on the way, it climbs over what
    stopped it and plans again from there before it fails. A descent that comes down on the object
    its goal lies in ends where the hand meets it (:func:`landed`): a goal read with noise may lie
    inside the object, and what the step was for is checked by its effect, not by millimetres.
    Without ``plan`` the line is kept whatever lies on it: a push's slide, and the Franka Hand's and
    the 2F-85's ``move_to_position``, whose line may push something along.
    """
    goal = as_position(target, "target position")
    if tol is None:
        tol = session.calibration.settle_tol_m if settle else POS_TOL
    if goal[2] < TABLE_CLEARANCE:
        raise PrimitiveFailure("out_of_workspace", f"target z={goal[2]:.3f} m is below the table surface")
    goal = _fist_above_table(session, goal)
    if plan:
        final = dict(tol=tol, settle=settle, set_down=set_down, stop_on_contact=stop_on_contact, straight=straight)
        yield from _planned(session, goal, timeout_s, final)
        return
    max_steps = max(1, int(timeout_s * CONTROL_FREQ))
    towards = _line_follower(session.obs.eef_pos, goal) if straight else (lambda _: goal)
    states = {name: state.state for name, state in session.obs.objects.items()}  # as the move begins
    last, reach = None, MAX_STEP
    trail: deque[np.ndarray] = deque(maxlen=STALL_STEPS + 1)  # the grip site's latest positions
    for _ in range(max_steps):
        err = float(np.linalg.norm(goal - session.obs.eef_pos))
        trail.append(session.obs.eef_pos.copy())
        if set_down and load_rests(session, goal, trail, tol):
            return
        if not straight and landed(session, goal, trail):
            return
        still = last is not None and float(np.linalg.norm(session.obs.eef_pos - last)) < SETTLED
        if settle:
            driven = err < DRAG_TOL and _creeping(trail) and drives_mechanism(session, states)
            arrived = err < POS_TOL or (err < tol and still) or driven
        else:
            arrived = err < tol
        if arrived or (
            stop_on_contact and still and (resting_above(session, goal, tol) or carried_rests(session, goal))
        ):
            return
        last = session.obs.eef_pos.copy()
        if err > tol and ((still and reach > MAX_STEP) or _creeping(trail)):
            reach = _breakaway(session, reach, drag=not straight and _slides(session, goal))
        yield servo_action(session, towards(session.obs.eef_pos), reach)
    err = float(np.linalg.norm(goal - session.obs.eef_pos))
    if settle and err < tol:
        return
    stalled = last is not None and float(np.linalg.norm(session.obs.eef_pos - last)) < SETTLED
    # pushed harder and still no nearer: at a limit, however it moves there (an arm beyond its reach sags)
    nearer = float(np.linalg.norm(goal - trail[0]) - np.linalg.norm(goal - trail[-1]))
    stalled = stalled or (reach > MAX_STEP and nearer < STALL_STEPS * SETTLED)
    blocked, load = session.obs.eef_contact, session.obs.held()
    resting = load is not None and not load_hangs(session)
    if stalled and (blocked or resting):  # pressing on something, or carrying a load that rests on something
        near = session.obs.in_contact()
        why = (
            f"held up by contact{' with ' + near[0] if near else ''}"
            if blocked
            else f"with {load} in hand resting on something"
        )
        raise PrimitiveFailure(
            "waypoint_blocked", f"the arm stopped {err * 100:.1f} cm short of {np.round(goal, 3).tolist()}, {why}"
        )
    if stalled:
        raise PrimitiveFailure(
            "cannot_track",
            f"the arm stopped {err * 100:.1f} cm short of {np.round(goal, 3).tolist()}"
            f"{f', {load} hanging free in hand,' if load else ''} and does not move on "
            f"(its calibrated steady-state error is {session.calibration.tracking_error_m * 1000:.1f} mm)",
        )
    raise PrimitiveFailure(
        "timeout", f"did not reach {np.round(goal, 3).tolist()} within {timeout_s:.1f} s (error {err * 100:.1f} cm)"
    )


def _fist_above_table(session: RobotSession, goal: np.ndarray) -> np.ndarray:
    """``goal``, raised where the closed, empty hand's lowest point would go below the table top
    (``FIST_FLOOR`` above it): a point beside an object at its height (a sweep's start, a push's
    goal) is the source hand's, and a deeper fist sent there presses its fingertips into the table,
    whose friction then holds the slide (linkage fingers swing lower as they close). The fist
    still meets what it pushes, just above the table."""
    if session.gripper_command <= 0 or session.obs.held() is not None:
        return goal
    floor = session.calibration.table_top_z + session.calibration.fist_below_site_m + FIST_FLOOR
    return goal if goal[2] >= floor else np.r_[goal[:2], floor]


def drives_mechanism(session: RobotSession, before: dict[str, float]) -> bool:
    """The hand, touching something, has driven a mechanism since ``before``: an object's perceived
    state (a lid's angle, a drawer's opening) changed by ``DRIVEN``. Its joint, not an obstacle, then
    holds the hand: a knob's arc written for the source hand's grip is a wider one for a grip that
    holds the knob farther out (a UR5e's 2F-85 stopped 1.4 cm off the arc, above it, while the lid
    still swung), and a drawer at the end of its travel stops the pull."""
    if not (session.obs.eef_contact or any(session.obs.finger_contact)):
        return False
    return any(
        abs(state.state - before[name]) >= DRIVEN for name, state in session.obs.objects.items() if name in before
    )


def _creeping(trail: Sequence[np.ndarray]) -> bool:
    """The grip site moved under SETTLED a step on average over the last STALL_STEPS steps."""
    return len(trail) > STALL_STEPS and float(np.linalg.norm(trail[-1] - trail[0])) < STALL_STEPS * SETTLED


def _breakaway(session: RobotSession, reach: float, *, drag: bool = False) -> float:
    """The setpoint reach for a free arm that creeps or has stopped short of its goal (under SETTLED
    a step on average over the last STALL_STEPS steps: not an arm at rest as the move begins, nor
    one that slows for a step), and then for each step it is still: grown by BREAKAWAY_GROWTH up to
    the controller's full delta (``POS_SCALE``) and kept for the rest of the move, so that the force
    it commands overcomes its joints' friction (an arm with high joint friction, folded by a sweep,
    stalls under the force a MAX_STEP setpoint commands, and stalls again as soon as the force
    drops back); a grown reach scales the error too (:func:`servo_action`), so a stall near the
    goal is pushed as well. Touching something (the hand, or an empty hand's finger pad on the
    table) or carrying a load that may rest on something (:func:`load_hangs`: not clear of every
    box below it), it is back to ``MAX_STEP``: there a stop is contact, and pushing harder would
    press into it. A load hanging free is no contact: an arm carrying a block stalls on its
    friction as an empty one does. ``drag``: a resting load is dragged along the table by a
    planned move (:func:`_slides`: a rake's crossbar pulling a cube, held short by its friction);
    it grows too. Not on a straight line's slide: a push stalled with its fist on the cube
    it pushes (read as held) rode over it when pushed harder, where pushing again from behind
    brings it on."""
    if session.obs.eef_contact:
        return MAX_STEP
    if session.obs.held() is None and any(session.obs.finger_contact):
        return MAX_STEP
    if session.obs.held() is not None and not load_hangs(session) and not drag:
        return MAX_STEP
    return min(reach * BREAKAWAY_GROWTH, POS_SCALE)


def _slides(session: RobotSession, goal: np.ndarray) -> bool:
    """What is left of the move is mostly along the surface: a load resting on it is dragged, and
    more force overcomes its friction instead of pressing it down."""
    error = goal - session.obs.eef_pos
    return float(np.linalg.norm(error[:2])) > abs(float(error[2]))


def _planned(session: RobotSession, goal: np.ndarray, timeout_s: float, final: dict) -> Steps:
    """:func:`move_to` along the planner's path over perceived boxes; held up on the way, climb once
    over what the hand or its load meets there and plan again from above it; stopped far short with
    nothing in the way, rise, go back by the table's middle and plan again; once more without the
    rise (failing so again, the first stop is the failure named: beyond reach stays
    ``cannot_track``). Each leg (climb, pass, descent) has the move's ``timeout_s``: a detour is
    never cut short by a budget set for a line.
    An empty hand that slides from behind a box it is against into it pushes it
    (:func:`clearance.pushed`): it keeps to the line, as the end-effector APIs' moves do, and never
    climbs over what it pushes."""
    sweep = clearance.Sweep.of(session.obs, session.calibration.hand_half_xy)
    pushing: list[clearance.Box] = []
    if session.obs.held() is None:  # an empty hand set down behind what it sweeps (a carried tool's drag bends)
        pushing = clearance.pushed(session.obs.eef_pos, goal, clearance.boxes(session.obs), sweep)
    if pushing:  # bent, a sweep's fist sideswiped its block and climbed over it when the block stalled
        final = {**final, "straight": True}
    climbed, trapped, rises = False, None, iter((UNFOLD_RISE, 0.0))
    while True:
        path = clearance.path_over(session.obs.eef_pos, goal, clearance.boxes(session.obs), sweep)
        try:
            for via in path[:-1]:
                yield from move_to(
                    session, via, timeout_s=timeout_s, tol=VIA_TOL, plan=False, straight=final["straight"]
                )
            yield from move_to(session, goal, timeout_s=timeout_s, plan=False, **final)
            return
        except PrimitiveFailure as failure:
            if _trapped(session, goal, failure):
                rise = next(rises, None)
                if rise is None:  # the same again: the first stop says why (beyond reach, a trap)
                    raise PrimitiveFailure(
                        trapped.kind, f"{trapped.message}; the same after going back by the table's middle"
                    ) from failure
                trapped = trapped or failure
                yield from _unfold(session, goal, timeout_s, sweep, rise)
                continue
            climb = None if climbed or failure.kind != "waypoint_blocked" else _climb(session, goal, sweep, pushing)
            if climb is None:
                raise
            climbed = True
            yield from move_to(session, climb, timeout_s=timeout_s, tol=VIA_TOL, plan=False)


def _trapped(session: RobotSession, goal: np.ndarray, failure: PrimitiveFailure) -> bool:
    """The arm stopped, or crept, far short of its goal with nothing in its way (no contact): more
    than ``UNFOLD_SHORT``, or than twice its calibrated steady-state error, which a slow-tracking
    arm with its elbow bent past straight may stop within. A redundant arm folded by a stretch can
    sit where operational-space control no longer moves it towards a goal it reaches at once from
    a posture nearer the middle of the table."""
    if failure.kind not in ("cannot_track", "timeout") or session.obs.eef_contact:
        return False
    short = min(UNFOLD_SHORT, 2 * session.calibration.tracking_error_m)
    return float(np.linalg.norm(goal - session.obs.eef_pos)) > short


def _unfold(
    session: RobotSession, goal: np.ndarray, timeout_s: float, sweep: clearance.Sweep, rise: float = 0.0
) -> Steps:
    """Up by ``rise``, then back over the middle of the table, at the higher of the grip site's
    and the goal's heights, over the perceived boxes: from there an arm takes its ordinary posture.
    Not reached either, the move is planned again from wherever the arm got to. The rise: an arm
    whose elbow a far grasp bent past straight, its wrist at its limit, moves neither inwards nor
    to the middle until it has risen (a Jaco's, history "Transfer, part 14"). Where a rise does not
    free it, :func:`_planned` tries once without."""
    here = np.asarray(session.obs.eef_pos, dtype=float)
    middle = np.array([*TABLE_OFFSET[:2], max(here[2], goal[2])])
    if rise > 0.0:
        try:
            yield from move_to(session, here + [0.0, 0.0, rise], timeout_s=timeout_s, tol=VIA_TOL, plan=False)
        except PrimitiveFailure:
            pass  # an arm at the top of its reach goes to the middle from where it is
    try:
        for via in clearance.path_over(session.obs.eef_pos, middle, clearance.boxes(session.obs), sweep):
            yield from move_to(session, via, timeout_s=timeout_s, tol=VIA_TOL, plan=False)
    except PrimitiveFailure:
        return


def _climb(
    session: RobotSession, goal: np.ndarray, sweep: clearance.Sweep, pushing: Sequence[clearance.Box] = ()
) -> np.ndarray | None:
    """Straight above the grip site, just high enough for the hand and its load to clear the perceived
    boxes it meets where it stopped (not the goal's own, nor one the move pushes: climbed over, a
    stalled sweep left its block behind); None where perception shows nothing there."""
    here = np.asarray(session.obs.eef_pos, dtype=float)
    pushed = {box.name for box in pushing}
    met = [
        box
        for box in clearance.boxes(session.obs)
        if not box.contains(goal, clearance.GOAL_MARGIN) and box.name not in pushed and sweep.against(box, here)
    ]
    if not met:
        return None
    height = max(sweep.over(box) for box in met) + clearance.CLIMB_SPARE
    return np.r_[here[:2], height] if height > here[2] + clearance.CLIMB_SPARE else None


def landed(session: RobotSession, goal: np.ndarray, trail: Sequence[np.ndarray]) -> bool:
    """The empty hand has come down on the object its goal lies in and stopped there: the grip site
    has not moved over the last ``STALL_STEPS`` steps, the end effector's contact sensor fires, the
    goal lies below it, and inside (or within perception's noise of) the box of an object it touches.
    A load that comes down on something is :func:`load_rests`' to judge: set down on an obstacle
    lying on the target, it must stay a blocked move the record names, not a release on top of it."""
    # cheapest first: this runs every control step of every move, and nearly always stops at the stall test
    if len(trail) <= STALL_STEPS or float(np.linalg.norm(trail[-1] - trail[0])) >= SETTLED:
        return False
    if goal[2] >= session.obs.eef_pos[2] or not session.obs.eef_contact or session.obs.held() is not None:
        return False
    touched = set(session.obs.in_contact())
    return any(
        box.name in touched and box.contains(goal, clearance.GOAL_MARGIN) for box in clearance.boxes(session.obs)
    )


def _line_follower(origin: np.ndarray, goal: np.ndarray):
    """Per step, the point one step ahead of the grip site's projection on the line origin → goal.

    One step ahead along the line's dominant axis: the move takes as many steps as a bent one.
    """
    origin = np.array(origin, dtype=np.float64)
    length = float(np.linalg.norm(goal - origin))
    if length < 1e-6:
        return lambda _: goal
    direction = (goal - origin) / length
    lead = MAX_STEP / float(np.max(np.abs(direction)))

    def towards(position: np.ndarray) -> np.ndarray:
        along = float(np.dot(position - origin, direction))
        return origin + direction * float(np.clip(along + lead, 0.0, length))

    return towards


def load_rests(session: RobotSession, goal: np.ndarray, trail: Sequence[np.ndarray], tol: float = POS_TOL) -> bool:
    """The held object sits on what is below: the grip site, a little above ``goal`` and over it,
    has not moved over the last ``STALL_STEPS`` control steps (``trail``: its latest positions)."""
    if held_position(session) is None or len(trail) <= STALL_STEPS:
        return False
    error = goal - session.obs.eef_pos
    stalled = float(np.linalg.norm(trail[-1] - trail[0])) < SETTLED
    return stalled and -SET_DOWN_GAP < error[2] < 0 and float(np.linalg.norm(error[:2])) < tol


def carried_rests(session: RobotSession, goal: np.ndarray) -> bool:
    """What the tool holds has come down on something on the way to a point below: a load a cup
    holds by its top face hangs lower than one held between fingers, and rests sooner."""
    return held_position(session) is not None and (goal - session.obs.eef_pos)[2] < 0


def resting_above(session: RobotSession, goal: np.ndarray, tol: float = POS_TOL) -> bool:
    """The tool touches something besides what it holds, right above ``goal``: it cannot get any lower."""
    error = goal - session.obs.eef_pos
    return session.obs.eef_contact and error[2] < 0 and float(np.linalg.norm(error[:2])) < tol


def actuate_gripper(
    session: RobotSession, command: float, *, duration_s: float = 0.4, max_duration_s: float | None = None
) -> Steps:
    """Drive the gripper to ``command`` (-1 open … +1 closed), holding the arm, until the fingers settle.

    Runs at least ``duration_s`` and then until the opening stops changing (fingers closed on an
    object or at their limit), at most ``max_duration_s``: by default ``GRIPPER_WAIT_S``, or longer
    for a gripper whose calibrated stroke takes longer (a slow linkage, a three-finger hand).

    A gripper whose calibration says a zero command holds it is told zero once it has held the object
    for ``SQUEEZE_STEPS`` (fingers on an object may jitter and never read still): its command steps at
    a fixed rate, and a close left on winds on past the object, which a later open must unwind before
    a finger moves (a slow hand's for seconds). A fast gripper's fingers stop first, and its command,
    wound to its end within its short stroke, stays as it is.
    """
    if max_duration_s is None:
        max_duration_s = max(GRIPPER_WAIT_S, STROKE_MARGIN * stroke_seconds(session, command))
    session.gripper_command = float(np.clip(command, -1.0, 1.0))
    hold_closed = command > 0 and session.calibration.zero_holds
    hold = np.array(session.obs.eef_pos)
    min_steps = max(1, int(duration_s * CONTROL_FREQ))
    previous, still, squeezed = session.obs.gripper_opening, 0, 0
    for step in range(max(min_steps, int(max_duration_s * CONTROL_FREQ))):
        yield servo_action(session, hold)
        opening = session.obs.gripper_opening
        still = still + 1 if abs(opening - previous) < 1e-3 else 0
        squeezed = squeezed + 1 if hold_closed and session.obs.held() is not None else 0
        previous = opening
        stopped = still >= 3 or squeezed >= SQUEEZE_STEPS
        if step + 1 >= min_steps and stopped and (command > -1.0 or opened(session)):
            break  # stopped (on an object, at the limit); a full open also reads open (fingers on an object stall first)
    if hold_closed and squeezed >= SQUEEZE_STEPS:
        session.gripper_command = 0.0  # squeezed: a rate command is wound on far enough to hold the grip


def opened(session: RobotSession, fraction: float = OPEN_ENOUGH) -> bool:
    """The gripper's opening reads at least ``fraction`` of its calibrated stroke open (always true
    without a calibrated stroke)."""
    calibration = session.calibration
    if calibration.opening_open is None or calibration.opening_closed is None:
        return True
    stroke = calibration.opening_open - calibration.opening_closed
    if abs(stroke) < 1e-6:
        return True
    return (session.obs.gripper_opening - calibration.opening_closed) / stroke >= fraction


def set_opening(session: RobotSession, fraction: float, velocity: float) -> Steps:
    """Drive the gripper to ``fraction`` of its opening (1 = open, 0 = closed) at ``velocity``."""
    command = 1.0 - 2.0 * float(np.clip(fraction, 0.0, 1.0))
    yield from actuate_gripper(session, command, max_duration_s=stroke_time(velocity, session, command))


def stroke_time(velocity: float, session: RobotSession, command: float) -> float:
    """Longest time to sweep the gripper stroke at ``velocity`` (stroke fractions per 0.1 s), clamped;
    never shorter than the calibrated stroke of a slow gripper allows."""
    longest = max(4.0, STROKE_MARGIN * stroke_seconds(session, command))
    return float(min(longest, max(0.5, 0.6 / max(velocity, 1e-3))))


def stroke_seconds(session: RobotSession, command: float) -> float:
    """The calibrated time of a full close (``command`` > 0) or open of this session's gripper."""
    calibration = session.calibration
    return calibration.close_time_s if command > 0 else calibration.open_time_s


def grasp_at(
    session: RobotSession, position: Sequence[float], *, timeout_s: float = 10.0, object_name: str | None = None
) -> Steps:
    """Open, approach from above, turn the jaw square to a long object, descend, close, and lift;
    fail with ``grasp_lost`` if nothing is held."""
    point = as_position(position, "grasp position")
    target = grip_site_for(session, point)
    above = target + np.array([0.0, 0.0, APPROACH_HEIGHT])
    yield from actuate_gripper(session, -1.0)
    yield from move_to(session, above, timeout_s=timeout_s, settle=True)
    free_yaw = not session.hold_yaw
    try:
        if (yield from square_to(session, object_name or squaring.grasped(session.obs, point))):
            target = grip_site_for(session, point)  # the pads' offset from the grip site turned with the hand
        yield from move_to(session, target, timeout_s=timeout_s / 2, tol=0.006)
        yield from actuate_gripper(session, 1.0)
        yield from move_to(session, above, timeout_s=timeout_s / 2, settle=True)
    finally:
        if free_yaw:  # squared for the grasp only, whether it held or failed: later moves keep the yaw free
            session.hold_yaw = False
    held = session.obs.held()
    if held is None or (object_name is not None and held != object_name):
        raise PrimitiveFailure("grasp_lost", f"nothing is held after grasping at {np.round(target, 3).tolist()}")


def square_to(session: RobotSession, name: str | None) -> Generator[Action, None, bool]:
    """Turn a jaw about the vertical until it closes square to ``name``'s perceived faces (the least
    turn; a long object's only, ``squaring.grasp_turn``), and hold that yaw; True where it turned. A
    cup has no closing axis, and an object without orientation, or one the jaw is square to within
    the controller's deadband, needs no turn. Best effort: the descent goes on holding the yaw where
    the turn runs out of time."""
    state = None if name is None else session.obs.objects.get(name)
    if session.calibration.closing_axis is None or state is None:
        return False
    turn = squaring.grasp_turn(session.obs.eef_quat, state)
    if abs(turn) < ROT_DEADBAND:
        return False
    yaw = squaring.yaw_of(session.obs.eef_quat) + turn - squaring.yaw_of(session.hold_quat)
    about_z = np.array([0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2)])
    session.hold_quat, session.hold_yaw = quat_multiply(about_z, session.hold_quat), True  # the tool axis, turned
    hold = np.array(session.obs.eef_pos)
    for _ in range(int(SQUARE_S * CONTROL_FREQ)):
        if orientation_error(session) < ROT_DEADBAND:
            break
        yield servo_action(session, hold)
    return True


def grip_site_for(session: RobotSession, point: np.ndarray) -> np.ndarray:
    """Where the grip site goes so that the calibrated grasp point (where closed pads hold) is over
    ``point``: shifted horizontally by that point's offset, as the grip site is turned now."""
    across = np.asarray(session.calibration.grasp_point, dtype=np.float64) * [1.0, 1.0, 0.0]  # not along the tool axis
    offset = quat2mat(session.obs.eef_quat) @ across
    return point - np.array([offset[0], offset[1], 0.0])


def suction_grasp_at(session: RobotSession, position: Sequence[float], *, timeout_s: float = 10.0) -> Steps:
    """Approach a top face from above, descend until the cup touches, switch suction on, lift."""
    target = as_position(position, "suction position")
    above = target + np.array([0.0, 0.0, APPROACH_HEIGHT])
    yield from actuate_gripper(session, -1.0, duration_s=0.1, max_duration_s=0.2)
    yield from move_to(session, above, timeout_s=timeout_s, settle=True)
    # A cup seals only flat on the face: its axis comes down along the face's normal (the world's
    # vertical), not along the tool axis the arm started with (a Panda's, 7 degrees off it, and up
    # to the rotation deadband more), whose edge met a 5 cm block on two points and never sealed.
    started, session.hold_quat = session.hold_quat, vertical(session.obs.eef_quat)
    try:
        yield from descend_until_contact(session, target, timeout_s=timeout_s / 2, deadband=0.0)
        yield from actuate_gripper(session, 1.0, duration_s=0.3, max_duration_s=0.5)
        yield from move_to(session, above, timeout_s=timeout_s / 2, settle=True)
    finally:
        session.hold_quat = started
    if not session.obs.object_detected:  # the vacuum sensor reads no seal
        raise PrimitiveFailure(
            "grasp_lost",
            f"suction did not hold anything at {np.round(target, 3).tolist()} (no seal: surface not flat, porous, or missed)",
        )


def descend_until_contact(
    session: RobotSession,
    target: np.ndarray,
    *,
    timeout_s: float = 5.0,
    overshoot: float = 0.01,
    press_steps: int = 3,
    deadband: float = ROT_DEADBAND,
) -> Steps:
    """Lower towards ``target`` (and ``overshoot`` below it) until the end effector's contact sensor fires,
    then press on for ``press_steps`` so a cup's whole face comes down on the surface. ``deadband``:
    the tilt left uncorrected on the way down (:func:`servo_action`)."""
    goal = np.array(target) - np.array([0.0, 0.0, overshoot])
    pressed = 0
    for _ in range(max(1, int(timeout_s * CONTROL_FREQ))):
        if session.obs.eef_contact:
            if pressed >= press_steps:
                return
            pressed += 1
        yield servo_action(session, goal, deadband=deadband)
    raise PrimitiveFailure("unreachable", f"no contact while descending to {np.round(target, 3).tolist()}")


def push_to(session: RobotSession, start: Sequence[float], goal: Sequence[float], *, timeout_s: float = 10.0) -> Steps:
    """Put the closed gripper at ``start`` (from above) and slide it along the table to ``goal``."""
    begin, end = as_position(start, "push start"), as_position(goal, "push goal")
    yield from actuate_gripper(session, 1.0, duration_s=0.2, max_duration_s=1.0)
    above = np.array([0.0, 0.0, APPROACH_HEIGHT])
    yield from move_to(session, begin + above, timeout_s=timeout_s, settle=True)
    try:
        yield from move_to(session, begin, timeout_s=timeout_s / 2, settle=True)  # a push needs contact, not mm
    except PrimitiveFailure as failure:
        if failure.kind != "waypoint_blocked":
            raise
        begin = _behind(session, begin, end)  # came down on the edge of what it is to push: farther back, once
        yield from move_to(session, begin + above, timeout_s=timeout_s, settle=True)
        yield from move_to(session, begin, timeout_s=timeout_s / 2, settle=True)
    yield from move_to(session, end, timeout_s=timeout_s, tol=0.015, straight=True, plan=False)
    yield from move_to(session, _withdrawal(begin, end), timeout_s=timeout_s / 2, tol=0.02)


def _withdrawal(begin: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Where a push's fist goes once it has slid to ``end``: ``APPROACH_HEIGHT`` up and
    ``PUSH_BACK_OFF`` back along the push, away from what it pushed. Straight up at the edge of
    an arm's reach unbends its elbow towards straight, and past it on the way back the wrist comes
    to its limit (a Jaco's wipe, history "Transfer, part 14")."""
    line = np.r_[end[:2] - begin[:2], 0.0]
    length = float(np.linalg.norm(line))
    back = line / length * min(PUSH_BACK_OFF, length) if length > 1e-6 else np.zeros(3)
    return end - back + np.array([0.0, 0.0, APPROACH_HEIGHT])


def _behind(session: RobotSession, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """``start`` moved back from ``goal`` along the table by half the hand's footprint along the push,
    as the hand is turned now: a start written for the load's face (or the source's fist) lets a hand
    whose fingers lead it, closed along the push (a Sawyer's 10 cm), come down on the edge of what it
    is to push."""
    line = np.r_[goal[:2] - start[:2], 0.0]
    length = float(np.linalg.norm(line))
    if length < 1e-6:
        return start
    direction = line / length
    half_xy = session.calibration.hand_half_xy or (clearance.HAND_RADIUS, clearance.HAND_RADIUS)
    reach = np.abs(direction[:2]) @ np.asarray(clearance.across_table(half_xy, session.obs.eef_quat))
    return start - direction * float(reach) / 2


def align_to(
    session: RobotSession, quat_xyzw: Sequence[float], *, timeout_s: float = 4.0, tol_rad: float = 0.05
) -> Steps:
    """Rotate the grip site to ``quat_xyzw`` (world frame) in place; fail with ``misaligned`` if it cannot."""
    quat = np.asarray(quat_xyzw, dtype=np.float64).reshape(-1)
    if quat.shape != (4,) or not np.all(np.isfinite(quat)) or np.linalg.norm(quat) < 1e-6:
        raise PrimitiveFailure("misaligned", f"orientation must be a quaternion [x, y, z, w], got {quat_xyzw!r}")
    session.hold_quat = quat / np.linalg.norm(quat)
    session.hold_yaw = True
    hold = np.array(session.obs.eef_pos)
    for _ in range(max(1, int(timeout_s * CONTROL_FREQ))):
        if orientation_error(session) < tol_rad:
            return
        yield servo_action(session, hold)
    raise PrimitiveFailure(
        "misaligned", f"gripper still {np.degrees(orientation_error(session)):.1f} deg from the requested orientation"
    )


def align_if_turned(
    session: RobotSession, quat_xyzw: Sequence[float], *, timeout_s: float = 4.0, tol_rad: float = 0.035
) -> Steps:
    """A pose's rotation: turn the tool only where it differs from the tool's by more than ``tol_rad``
    (a controller sent to the orientation it has does not move; the held yaw stays free)."""
    quat = np.asarray(quat_xyzw, dtype=np.float64).reshape(-1)
    if quat.shape == (4,) and np.all(np.isfinite(quat)) and np.linalg.norm(quat) > 1e-6:
        quat = quat / np.linalg.norm(quat)
        if 2 * np.arccos(min(1.0, abs(float(np.dot(quat, session.obs.eef_quat))))) < tol_rad:
            return
    yield from align_to(session, quat_xyzw, timeout_s=timeout_s)


def rotate_about_z(session: RobotSession, angle_rad: float, *, timeout_s: float = 4.0) -> Steps:
    """Turn the gripper by ``angle_rad`` about the world z axis."""
    turn = np.array([0.0, 0.0, np.sin(angle_rad / 2), np.cos(angle_rad / 2)])
    yield from align_to(session, quat_multiply(turn, session.hold_quat), timeout_s=timeout_s)


def rotation_error(session: RobotSession) -> np.ndarray:
    """Axis-angle (world frame) from the current grip-site orientation to the held one.

    Unless a primitive aligned the gripper explicitly (``session.hold_yaw``), only the tool axis is
    held: yaw stays free, which keeps top-down motions feasible across the workspace (an arm
    holding its start yaw may not reach the far side of the table).
    """
    current, held = quat2mat(session.obs.eef_quat), quat2mat(session.hold_quat)
    if session.hold_yaw:
        return quat2axisangle(mat2quat(held @ current.T))
    return _turn_between(current[:, 2], held[:, 2])


def _turn_between(z_now: np.ndarray, z_goal: np.ndarray) -> np.ndarray:
    """Axis-angle (world frame) of the least rotation taking unit axis ``z_now`` onto ``z_goal``."""
    axis = np.cross(z_now, z_goal)
    sin, cos = float(np.linalg.norm(axis)), float(np.clip(np.dot(z_now, z_goal), -1.0, 1.0))
    if sin < 1e-9:
        return np.zeros(3)
    return axis / sin * np.arctan2(sin, cos)


def vertical(quat_xyzw: Sequence[float]) -> np.ndarray:
    """``quat_xyzw`` turned the least that puts its z axis along the world's vertical (the way it
    points, up or down): a tool pointing down, square to the table, its yaw kept."""
    quat = np.asarray(quat_xyzw, dtype=np.float64)
    z_now = quat2mat(quat)[:, 2]
    turn = _turn_between(z_now, np.array([0.0, 0.0, 1.0 if z_now[2] >= 0 else -1.0]))
    return quat if not np.any(turn) else quat_multiply(axisangle2quat(turn), quat)


def orientation_error(session: RobotSession) -> float:
    return float(np.linalg.norm(rotation_error(session)))


def held_position(session: RobotSession) -> np.ndarray | None:
    """The held object's perceived centre (None when nothing is held)."""
    held = session.obs.held()
    return None if held is None else np.asarray(session.obs.objects[held].pos, dtype=np.float64)


def held_offset(session: RobotSession) -> np.ndarray:
    """Where the held object's centre sits relative to the grip site (zero when nothing is held)."""
    position = held_position(session)
    return np.zeros(3) if position is None else position - session.obs.eef_pos


def load_hangs(session: RobotSession) -> bool:
    """The held object hangs free in the air, by perception: its box's underside lies above the table
    and above every other box below it by more than the planner's load clearance. A load that still
    rests or slides on something (a block dragged along the table, a lid on its box) does not."""
    held = session.obs.held()
    if held is None:
        return False
    load = session.obs.objects[held]
    bottom = float(load.pos[2] - load.size[2] / 2)
    if bottom < TABLE_CLEARANCE + clearance.LOAD_CLEARANCE:
        return False
    reach = np.asarray(load.size[:2], dtype=float) / 2
    below = [
        box.top
        for box in clearance.boxes(session.obs)
        if np.all(np.abs(box.centre[:2] - np.asarray(load.pos[:2])) < box.half[:2] + reach)
    ]
    return all(bottom > top + clearance.LOAD_CLEARANCE for top in below)


def hold_until_still(session: RobotSession, hold: np.ndarray, *, max_duration_s: float = 2.0) -> Steps:
    """Hold the arm at ``hold`` until the held object stops moving (3 steps under 1 mm each)."""
    previous, still = held_position(session), 0
    for _ in range(int(max_duration_s * CONTROL_FREQ)):
        if previous is None or still >= 3:
            return
        yield servo_action(session, hold)
        current = held_position(session)
        still = still + 1 if current is not None and np.linalg.norm(current - previous) < 0.001 else 0
        previous = current


def release_at(session: RobotSession, position: Sequence[float], *, timeout_s: float = 10.0) -> Steps:
    """Carry the held object above ``position`` (where the grip site goes), lower to it, open, and retreat upwards.

    A ``position`` that is a perceived object's own (a block's, a box's: the object's track, as
    ``task.get_object_position`` reads it, within ``GOAL_MARGIN``) stands for that object, not for
    a height to stop at: the load is put onto it (:func:`release_onto`), as a place by name does.
    That is the point a name-based place's receptacle gives a position API."""
    target = as_position(position, "release position")
    tracked = [replace(box, centre=session.tracked_position(box.name)) for box in clearance.boxes(session.obs)]
    if clearance.object_at(tracked, target, clearance.GOAL_MARGIN) is not None:
        yield from release_onto(session, target, timeout_s=timeout_s)
        return
    above = target + np.array([0.0, 0.0, APPROACH_HEIGHT / 2])
    lift = np.array([session.obs.eef_pos[0], session.obs.eef_pos[1], max(session.obs.eef_pos[2], above[2])])
    yield from move_to(session, lift, timeout_s=timeout_s / 2, tol=0.02)
    yield from move_to(session, above, timeout_s=timeout_s, settle=True)
    yield from move_to(session, target, timeout_s=timeout_s / 2, set_down=True)
    yield from actuate_gripper(session, -1.0)
    yield from move_to(session, above, timeout_s=timeout_s / 2, tol=0.02)


def release_onto(session: RobotSession, position: Sequence[float], *, timeout_s: float = 10.0) -> Steps:
    """Carry the held object above what is at ``position`` (a block, a box, a plate) and lower it
    until it rests there, however tall that is; then open and retreat upwards.

    Unlike :func:`release_at`, ``position`` is the support's, not where the grip site stops: a
    place by name knows what to put the object on, not at which height it will rest.
    """
    support = as_position(position, "receptacle position")
    goal = np.array([support[0], support[1], max(support[2], TABLE_CLEARANCE + 0.001)])
    above = goal + np.array([0.0, 0.0, APPROACH_HEIGHT])
    lift = np.array([session.obs.eef_pos[0], session.obs.eef_pos[1], max(session.obs.eef_pos[2], above[2])])
    yield from move_to(session, lift, timeout_s=timeout_s / 2, tol=0.02)
    yield from move_to(session, above, timeout_s=timeout_s, settle=True)
    yield from lower_until_resting(session, goal, timeout_s=timeout_s / 2)
    yield from actuate_gripper(session, -1.0)
    yield from move_to(session, above, timeout_s=timeout_s / 2, tol=0.02)


def release_below(session: RobotSession, *, depth: float = 1.5 * APPROACH_HEIGHT, timeout_s: float = 6.0) -> Steps:
    """Lower a load held by a cup straight down until it rests on what is below (at most ``depth``),
    switch suction off and back away: a vacuum lets go where it is (the paper's detach)."""
    if held_position(session) is None:
        raise PrimitiveFailure("grasp_lost", "nothing is attached to let go of")
    here = np.array(session.obs.eef_pos, dtype=np.float64)
    yield from hold_until_still(session, here)
    goal = here - np.array([0.0, 0.0, depth])
    goal[2] = max(goal[2], TABLE_CLEARANCE + 0.001)
    yield from lower_until_resting(session, goal, timeout_s=timeout_s, landed_rate=LANDED_RATE)
    yield from actuate_gripper(session, -1.0, duration_s=0.3, max_duration_s=0.5)
    yield from move_to(session, session.obs.eef_pos + [0.0, 0.0, APPROACH_HEIGHT / 2], tol=0.02)


LOWERING_STEP = 0.01  # metres ahead of the grip site a load is lowered towards, where it rests is unknown
LANDED_RATE = 1 / 3  # a cup's lowering that slows to this share of its free descent has met what is below


def lower_until_resting(
    session: RobotSession, goal: np.ndarray, *, timeout_s: float = 5.0, landed_rate: float = 0.0
) -> Steps:
    """Lower slowly towards ``goal`` until the grip site stops coming down (by ``SETTLED`` in
    ``STALL_STEPS`` steps) above it: what it carries, or the hand itself, rests on something. Slowly: a load that
    lands fast on an edge slides off it. Reaching ``goal`` ends it too.

    With ``landed_rate``, coming down at under that share of the fastest it came down on the way counts
    as resting too: a cup is compliant, and what it presses a load onto (a stack of blocks) yields a
    little every step; pressing on until that stops tips the stack over."""
    trail: deque[np.ndarray] = deque(maxlen=STALL_STEPS + 1)
    fastest = 0.0  # metres the grip site came down over STALL_STEPS steps, at most, on the way
    for _ in range(max(1, int(timeout_s * CONTROL_FREQ))):
        here = session.obs.eef_pos
        trail.append(here.copy())
        error = goal - here
        if float(np.linalg.norm(error)) < POS_TOL:
            return
        if len(trail) > STALL_STEPS and error[2] < 0:
            descent = float(trail[0][2] - trail[-1][2])
            if descent < max(SETTLED, landed_rate * fastest):
                return  # no longer coming down, or only as what is below yields (a cup may still sway sideways)
            fastest = max(fastest, descent)
        yield servo_action(session, here + np.clip(error, -LOWERING_STEP, LOWERING_STEP))
    raise PrimitiveFailure(
        "timeout", f"still lowering towards {np.round(goal, 3).tolist()} after {timeout_s:.1f} s: nothing held it up"
    )


def grasp_handle_at(session: RobotSession, position: Sequence[float], *, timeout_s: float = 10.0) -> Steps:
    """Open, come down on the handle at ``position`` from above, and close on it (no lift: it stays in hand)."""
    handle = as_position(position, "handle position")
    yield from actuate_gripper(session, -1.0)
    yield from move_to(session, handle + np.array([0.0, 0.0, APPROACH_HEIGHT]), timeout_s=timeout_s, settle=True)
    yield from move_to(session, handle, timeout_s=timeout_s / 2, tol=0.006)
    yield from actuate_gripper(session, 1.0)


def release_handle(session: RobotSession) -> Steps:
    """Open on the handle held and back off upwards."""
    yield from actuate_gripper(session, -1.0)
    yield from move_to(session, session.obs.eef_pos + [0.0, 0.0, APPROACH_HEIGHT / 2], tol=0.02)
