"""The subtask library: what each subtask means, as a success predicate over an observation.

Predicates read only the env's exact :class:`~lerobot_policy_recent.robosuite_envs.observation.Observation` (true
object poses, articulation state, and its :class:`~lerobot_policy_recent.robosuite_envs.observation.GroundTruth`:
what the gripper holds) and the task's object sizes, so the env can latch per-subtask
success for goal-conditioned success (GC) and anyone holding a recorded observation can recompute it.
Families and categories mirror the paper's two evaluation suites.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from lerobot_policy_recent.robosuite_envs.observation import ObjectState, Observation
from lerobot_policy_recent.robosuite_envs.table import TABLE_Z
from lerobot_policy_recent.robosuite_envs.tasks import TaskSpec

# Geometry of the articulated models (robosuite_envs/objects/assets), as the predicates need it.
DRAWER_TRAY_OFFSET = np.array([0.1125, 0.0, -0.05])  # knob → tray interior centre (floor top)
DRAWER_TRAY_HALF = 0.065
DRAWER_OPEN, DRAWER_CLOSED = 0.09, 0.015  # metres of travel
LID_OPEN, LID_CLOSED = 1.2, 0.08  # radians
ROW_SLOTS = (-0.1, 0.0, 0.1)  # y offsets of the three slots along a row marker
PEN_HALF = 0.085  # interior half-width of the pen, minus a wall's thickness
WIPED = 0.8  # fraction of a wipe area's cells the end effector must pass over
BOX_INNER_HALF = 0.06  # half the hinged box's interior, inside its walls
CLEARED = ("first", "second", "third", "fourth")  # clear_into_bin's objects
PRESSED = ("first", "second", "third")  # press_buttons' buttons, in the order they are pressed


@dataclass(frozen=True)
class Subtask:
    name: str
    family: str  # "kinematic" or "end_effector"
    category: str  # the paper's subtask category within the family
    roles: tuple[str, ...]  # argument names the plan binds to object names
    description: str
    predicate: Callable[[TaskSpec, Observation, dict[str, str]], bool]

    def check(self, task: TaskSpec, obs: Observation, args: dict[str, str]) -> bool:
        missing = [role for role in self.roles if role not in args]
        if missing:
            raise ValueError(f"subtask {self.name!r} needs argument(s) {', '.join(missing)}; got {sorted(args)}")
        if any(args[role] not in obs.objects for role in self.roles):
            return False  # an object not (yet) observed cannot satisfy anything
        return bool(self.predicate(task, obs, args))


# ------------------------------------------------------------------ geometry helpers
def _half(task: TaskSpec, name: str) -> np.ndarray:
    return np.array(task.spec(name).size) / 2


def held(obs: Observation, name: str) -> bool:
    """The simulator's answer: the gripper holds ``name`` (an observation without ground truth holds nothing)."""
    return obs.truth is not None and name in obs.truth.held


def _xy_within(state: ObjectState, centre: np.ndarray, half: float | np.ndarray) -> bool:
    return bool(np.all(np.abs(state.pos[:2] - centre[:2]) < half))


def rests_on(task: TaskSpec, obs: Observation, obj: str, support: str, *, xy_tol: float | None = None) -> bool:
    """``obj`` lies released on top of ``support`` (a centre-origin box, plate, bin or block)."""
    state, base = obs.objects[obj], obs.objects[support]
    base_half, obj_half = _half(task, support), _half(task, obj)
    tol = xy_tol if xy_tol is not None else np.maximum(base_half[:2], 0.02)
    on_top = abs((state.pos[2] - obj_half[2]) - (base.pos[2] + base_half[2])) < 0.02
    return _xy_within(state, base.pos, tol) and on_top and not held(obs, obj)


def on_table(task: TaskSpec, obs: Observation, obj: str) -> bool:
    return bool(obs.objects[obj].pos[2] < TABLE_Z + _half(task, obj)[2] + 0.015)


def in_region(task: TaskSpec, obs: Observation, obj: str, region: str) -> bool:
    state = obs.objects[obj]
    return _xy_within(state, obs.objects[region].pos, _half(task, region)[:2]) and not held(obs, obj)


# ------------------------------------------------------------------ predicates
def _pick_and_lift(task, obs, a):
    state = obs.objects[a["obj"]]
    return held(obs, a["obj"]) and state.pos[2] > TABLE_Z + _half(task, a["obj"])[2] + 0.06


def _put_in_bin(task, obs, a):
    state, centre = obs.objects[a["obj"]], obs.objects[a["receptacle"]].pos
    half = _half(task, a["receptacle"])
    return _xy_within(state, centre, half[:2] - 0.01) and state.pos[2] < centre[2] + half[2] and not held(obs, a["obj"])


def _place_on(task, obs, a):
    return rests_on(task, obs, a["obj"], a["target"])


def _lies_in_region(task, obs, a):
    """Pushed, dragged or set down: the object lies on the table inside the region."""
    return in_region(task, obs, a["obj"], a["region"]) and on_table(task, obs, a["obj"])


def _press_button(task, obs, a):
    return obs.objects[a["button"]].state > 0.5


def _close_lid(task, obs, a):
    return rests_on(task, obs, a["lid"], a["container"], xy_tol=0.015)


def _insert_peg(task, obs, a):
    peg, hole = obs.objects[a["peg"]], obs.objects[a["hole"]]
    hole_top = hole.pos[2] + task.spec(a["hole"]).size[2]
    bottom = peg.pos[2] - _half(task, a["peg"])[2]
    return _xy_within(peg, hole.pos, 0.012) and bottom < hole_top - 0.02 and not held(obs, a["peg"])


def _wipe_area(task, obs, a):
    return obs.objects[a["area"]].state >= WIPED


def _open_drawer(task, obs, a):
    return obs.objects[a["drawer"]].state > DRAWER_OPEN


def _close_drawer(task, obs, a):
    return obs.objects[a["drawer"]].state < DRAWER_CLOSED


def _put_in_drawer(task, obs, a):
    state, knob = obs.objects[a["obj"]], obs.objects[a["drawer"]].pos
    tray = knob + DRAWER_TRAY_OFFSET
    return _xy_within(state, tray, DRAWER_TRAY_HALF) and state.pos[2] < knob[2] and not held(obs, a["obj"])


def _open_hinged_box(task, obs, a):
    return obs.objects[a["box"]].state > LID_OPEN


def _close_hinged_box(task, obs, a):
    return obs.objects[a["box"]].state < LID_CLOSED


def _stack_tower(task, obs, a):
    return rests_on(task, obs, a["middle"], a["base"]) and rests_on(task, obs, a["top"], a["middle"])


def _arrange_in_row(task, obs, a):
    row = obs.objects[a["row"]].pos
    names = [a["first"], a["second"], a["third"]]
    for name, dy in zip(names, ROW_SLOTS, strict=True):
        state = obs.objects[name]
        if not _xy_within(state, row + np.array([0.0, dy, 0.0]), 0.025) or held(obs, name):
            return False
    for i, first in enumerate(names):  # "without contact": a visible gap between neighbours
        for second in names[i + 1 :]:
            gap = np.linalg.norm(obs.objects[first].pos[:2] - obs.objects[second].pos[:2])
            if gap < _half(task, first)[0] + _half(task, second)[0] + 0.01:
                return False
    return True


def _clear_into_bin(task, obs, a):
    return all(_put_in_bin(task, obs, {"obj": a[role], "receptacle": a["receptacle"]}) for role in CLEARED)


def _press_buttons(task, obs, a):
    return all(obs.objects[a[role]].state > 0.5 for role in PRESSED)


def _fill_drawer(task, obs, a):
    return all(_put_in_drawer(task, obs, {"obj": a[role], "drawer": a["drawer"]}) for role in ("first", "second"))


def _fill_box(task, obs, a):
    """Inside the box's walls, below its rim, let go (``box`` is observed at its bottom centre)."""
    state, base = obs.objects[a["obj"]], obs.objects[a["box"]].pos
    rim = base[2] + task.spec(a["box"]).size[2]
    return _xy_within(state, base, BOX_INNER_HALF) and state.pos[2] < rim and not held(obs, a["obj"])


def _sweep_into_pen(task, obs, a):
    pen = obs.objects[a["pen"]].pos
    return all(
        _xy_within(obs.objects[a[role]], pen, PEN_HALF) and not held(obs, a[role]) for role in ("first", "second")
    )


SUBTASKS: dict[str, Subtask] = {
    s.name: s
    for s in (
        Subtask("pick_and_lift", "kinematic", "single-object manipulation", ("obj",),
                "grasp an object and hold it at least 6 cm above the table", _pick_and_lift),
        Subtask("push_to_region", "kinematic", "single-object manipulation", ("obj", "region"),
                "push an object along the table into a marked region", _lies_in_region),
        Subtask("put_in_bin", "kinematic", "inter-object manipulation", ("obj", "receptacle"),
                "put an object into an open bin", _put_in_bin),
        Subtask("place_on_plate", "kinematic", "inter-object manipulation", ("obj", "target"),
                "place an object on a plate", _place_on),
        Subtask("stack", "kinematic", "inter-object manipulation", ("obj", "target"),
                "stack one block on another", _place_on),
        Subtask("press_button", "kinematic", "precision interaction", ("button",),
                "press a spring-loaded button down", _press_button),
        Subtask("close_lid", "kinematic", "precision interaction", ("lid", "container"),
                "put a loose lid onto a container, centred within 1.5 cm", _close_lid),
        Subtask("insert_peg", "kinematic", "precision interaction", ("peg", "hole"),
                "insert a peg at least 2 cm deep into a square hole", _insert_peg),
        Subtask("drag_with_tool", "kinematic", "tool use", ("obj", "tool", "region"),
                "drag a far object into a region with a rake", _lies_in_region),
        Subtask("wipe_area", "kinematic", "tool use", ("area",),
                "wipe a marked area of the table with the closed gripper", _wipe_area),
        Subtask("move_to_region", "kinematic", "single-object manipulation", ("obj", "region"),
                "pick an object up and set it down inside a marked region", _lies_in_region),
        Subtask("clear_into_bin", "kinematic", "inter-object manipulation", (*CLEARED, "receptacle"),
                "put four objects into an open bin, one per corner", _clear_into_bin),
        Subtask("press_buttons", "kinematic", "precision interaction", PRESSED,
                "press three buttons one after another (a panel: power, channel, volume)", _press_buttons),
        Subtask("fill_drawer", "end_effector", "object placement", ("first", "second", "drawer"),
                "put two objects into an open drawer, one behind the other", _fill_drawer),
        Subtask("fill_box", "end_effector", "articulated objects", ("obj", "box"),
                "put an object into a hinged box whose lid is open", _fill_box),
        Subtask("put_in_drawer", "end_effector", "object placement", ("obj", "drawer"),
                "put an object into an open drawer", _put_in_drawer),
        Subtask("open_drawer", "end_effector", "articulated objects", ("drawer",),
                "pull a drawer open by its knob", _open_drawer),
        Subtask("close_drawer", "end_effector", "articulated objects", ("drawer",),
                "push a drawer shut", _close_drawer),
        Subtask("open_hinged_box", "end_effector", "articulated objects", ("box",),
                "swing a hinged lid open", _open_hinged_box),
        Subtask("close_hinged_box", "end_effector", "articulated objects", ("box",),
                "swing a hinged lid shut", _close_hinged_box),
        Subtask("stack_tower", "end_effector", "scene rearrangement", ("base", "middle", "top"),
                "stack three blocks into a tower", _stack_tower),
        Subtask("arrange_in_row", "end_effector", "scene rearrangement", ("first", "second", "third", "row"),
                "place three objects on a row's slots, none touching another", _arrange_in_row),
        Subtask("sweep_into_pen", "end_effector", "tool use", ("first", "second", "pen"),
                "sweep two objects along the table into a pen", _sweep_into_pen),
    )
}  # fmt: skip


def get_subtask(name: str) -> Subtask:
    try:
        return SUBTASKS[name]
    except KeyError:
        raise KeyError(f"unknown subtask {name!r}; known subtasks: {', '.join(SUBTASKS)}") from None
