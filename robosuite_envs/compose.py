"""Seeded compositions of subtasks into new tasks: where a test draw nobody has run comes from.

A draw is ``count`` tasks of one family (``kinematic``, ``end_effector``), each a scene of the
suites and 3 to 5 subtasks chained on it. What each subtask needs of the scene and what it leaves
(an object still on the table, the zone still empty, the drawer open, the panel still off) is
written once per scene as :class:`Move` facts, so a chain never asks for what an earlier subtask
took away (an object in the bin is not picked again; nothing follows a pick-and-lift, which ends
holding its object). A draw is kept only if, over its tasks, the paper's lengths hold (mean
primitive calls per task at least 24.6 kinematic, 29 end-effector), all four of the family's
subtask categories appear, and no task repeats a suite task's plan; otherwise the next attempt of
the same seed is drawn, so a seed names one draw. Feasibility on the source robot is a simulation
run (``recent envs compose --check``), not a property of the grammar.

Dev draws use dev draw seeds as often as wanted; the test draw's seed is chosen when the code for
the snapshot is frozen, and recorded with it (docs/benchmark.md).
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass
from statistics import mean

from lerobot_policy_recent.robosuite_envs.subtasks import SUBTASKS
from lerobot_policy_recent.robosuite_envs.suites import (
    CLEAR,
    DRAW_FORMAT,
    KITCHEN,
    PANEL,
    PEN_AND_ROW,
    SCENES,
    SUITES,
    TOOL_BENCH,
    WORKSHOP,
    WORKSHOP_PANEL,
    step,
    task,
)
from lerobot_policy_recent.robosuite_envs.tasks import PlanStep, TaskSpec

# the paper's mean primitive calls per task (Table 1), the floor a draw's mean must reach
PAPER_CALLS = {"kinematic": 24.6, "end_effector": 29.0}
LENGTHS = (3, 4, 5)  # subtasks per task
MAX_ATTEMPTS = 200


@dataclass(frozen=True)
class Move:
    """One subtask a scene allows, bound to its objects: the facts it needs, ends and starts."""

    step: PlanStep
    needs: frozenset[str] = frozenset()
    ends: frozenset[str] = frozenset()
    starts: frozenset[str] = frozenset()
    last: bool = False  # it ends holding an object: nothing may follow


@dataclass(frozen=True)
class Scene:
    name: str
    family: str
    objects: tuple
    facts: frozenset[str]  # what holds at the start
    moves: tuple[Move, ...]


def _move(subtask: str, needs=(), ends=(), starts=(), last: bool = False, **args: str) -> Move:
    return Move(step(subtask, **args), frozenset(needs), frozenset(ends), frozenset(starts), last)


def _loose(name: str) -> str:
    return f"loose:{name}"  # graspable: on the table, in a zone or on the plate, with nothing on it


def _kitchen() -> Scene:
    movable = ("cube", "block", "can", "dice")
    moves = []
    for obj in movable:
        moves += [
            _move("move_to_region", [_loose(obj), "zone_empty"], ["zone_empty"], obj=obj, region="zone"),
            _move("put_in_bin", [_loose(obj)], [_loose(obj)], obj=obj, receptacle="bin"),
            _move("place_on_plate", [_loose(obj), "plate_empty"], ["plate_empty"], obj=obj, target="plate"),
            _move("pick_and_lift", [_loose(obj)], [_loose(obj)], last=True, obj=obj),
        ]
        for target in movable:
            if target != obj:
                moves.append(_move("stack", [_loose(obj), _loose(target)], [_loose(target)], obj=obj, target=target))
    moves += [
        _move("push_to_region", [_loose("cube"), "zone_empty"], ["zone_empty"], obj="cube", region="zone"),
        _move("press_buttons", ["panel_off"], ["panel_off"], **PANEL),
        _move("press_button", ["panel_off"], ["panel_off"], button="power"),
        _move("clear_into_bin", [_loose(o) for o in movable], [_loose(o) for o in movable], **CLEAR),
    ]
    facts = frozenset([*(_loose(o) for o in movable), "zone_empty", "plate_empty", "panel_off"])
    return Scene("kitchen", "kinematic", KITCHEN, facts, tuple(moves))


def _workshop() -> Scene:
    moves = (
        _move("close_lid", ["lid_off"], ["lid_off"], lid="lid", container="jar"),
        _move("insert_peg", ["peg_out"], ["peg_out"], peg="peg", hole="hole"),
        _move("press_buttons", ["panel_off"], ["panel_off"], **WORKSHOP_PANEL),
        _move("press_button", ["panel_off"], ["panel_off"], button="button"),
        _move("move_to_region", [_loose("cube"), "zone_empty"], ["zone_empty"], obj="cube", region="zone"),
        _move("pick_and_lift", [_loose("cube")], [_loose("cube")], last=True, obj="cube"),
    )
    facts = frozenset(["lid_off", "peg_out", "panel_off", _loose("cube"), "zone_empty"])
    return Scene("workshop", "kinematic", WORKSHOP, facts, moves)


def _tool_bench() -> Scene:
    moves = (
        _move("drag_with_tool", [_loose("cube"), "zone_empty"], ["zone_empty"], obj="cube", tool="rake", region="zone"),
        _move("wipe_area", ["stain"], ["stain"], area="stain"),
        _move("press_buttons", ["panel_off"], ["panel_off"], **WORKSHOP_PANEL),
        _move("pick_and_lift", [_loose("block")], [_loose("block")], last=True, obj="block"),
    )
    facts = frozenset([_loose("cube"), _loose("block"), "zone_empty", "stain", "panel_off"])
    return Scene("tool_bench", "kinematic", TOOL_BENCH, facts, moves)


def _pantry() -> Scene:
    loose = ("cube", "green", "blue")
    moves = [
        _move("open_drawer", ["drawer_shut"], ["drawer_shut"], ["drawer_open"], drawer="drawer"),
        _move("close_drawer", ["drawer_open"], ["drawer_open"], ["drawer_done"], drawer="drawer"),
        _move("open_hinged_box", ["box_shut"], ["box_shut"], ["box_open"], box="box"),
        _move("close_hinged_box", ["box_open"], ["box_open"], ["box_done"], box="box"),
    ]
    for obj in loose:
        moves += [
            _move(
                "put_in_drawer",
                [_loose(obj), "drawer_open", "drawer_room"],
                [_loose(obj), "drawer_room"],
                obj=obj,
                drawer="drawer",
            ),
            _move("fill_box", [_loose(obj), "box_open", "box_room"], [_loose(obj), "box_room"], obj=obj, box="box"),
        ]
        for second in loose:
            if second != obj:
                moves.append(
                    _move("fill_drawer", [_loose(obj), _loose(second), "drawer_open", "drawer_room"],
                          [_loose(obj), _loose(second), "drawer_room"], first=obj, second=second, drawer="drawer")
                )  # fmt: skip
    facts = frozenset([*(_loose(o) for o in loose), "drawer_shut", "box_shut", "drawer_room", "box_room"])
    return Scene("pantry", "end_effector", SCENES["pantry"], facts, tuple(moves))


def _pen_and_row() -> Scene:
    """Blocks stay loose on the row (the suites line them up, then stack or sweep them), and a tower
    is taken down into the row from its top: the chain that holds both of the family's categories
    that only this scene has (stack, unstack into the row, sweep two into the pen)."""
    blocks = ("red", "blue", "green")
    width = {o.name: max(o.size[:2]) for o in PEN_AND_ROW if o.name in blocks}  # a tower narrows upwards
    on_table = [_loose(b) for b in blocks]
    moves = []
    for first in blocks:
        for second in blocks:
            if second == first:
                continue
            moves.append(
                _move("sweep_into_pen", [_loose(first), _loose(second), "pen_empty"],
                      [_loose(first), _loose(second), "pen_empty"], first=first, second=second, pen="pen")
            )  # fmt: skip
            third = next(b for b in blocks if b not in (first, second))
            moves += [
                _move("arrange_in_row", [*on_table, "row_empty"], ["row_empty"],
                      first=first, second=second, third=third, row="row"),
                # top first: what lies on a block is taken off it before it
                _move("arrange_in_row", [_tower(third, second, first), "row_empty"],
                      [_tower(third, second, first), "row_empty"], on_table,
                      first=first, second=second, third=third, row="row"),
            ]  # fmt: skip
            if width[first] >= width[second] >= width[third]:  # green on the smaller blue slid off (draw 102)
                moves.append(_move("stack_tower", on_table, on_table, [_tower(first, second, third)],
                                   base=first, middle=second, top=third))  # fmt: skip
    facts = frozenset([*on_table, "pen_empty", "row_empty"])
    return Scene("pen_and_row", "end_effector", PEN_AND_ROW, facts, tuple(moves))


def _tower(base: str, middle: str, top: str) -> str:
    return f"tower:{base},{middle},{top}"


def scenes(family: str) -> tuple[Scene, ...]:
    """The scenes a family's draws use."""
    known = {"kinematic": (_kitchen(), _workshop(), _tool_bench()), "end_effector": (_pantry(), _pen_and_row())}
    try:
        return known[family]
    except KeyError:
        raise ValueError(f"unknown family {family!r}; choose from {', '.join(known)}") from None


def draw(family: str, seed: int, count: int, calls: Callable[[TaskSpec], int]) -> tuple[TaskSpec, ...]:
    """``count`` new tasks of ``family`` from draw seed ``seed``: the same seed, the same tasks.
    ``calls`` counts a task's primitive calls (its reference skills', which the world does not read)."""
    if count < 1:
        raise ValueError(f"count must be at least 1, got {count}")
    known_plans = {plan_key(t.plan) for tasks in SUITES.values() for t in tasks}
    categories = {s.category for s in SUBTASKS.values() if s.family == family}
    reachable = {SUBTASKS[s].category for scene in scenes(family) for s in _chainable(scene)}
    if not reachable >= categories:
        missing = ", ".join(sorted(categories - reachable))
        raise ValueError(
            f"no {family} scene chains {LENGTHS[0]} or more subtasks with the categories {missing}: "
            "a draw cannot hold all four (add a scene that does)"
        )
    weight = {m.step.subtask: calls(_one_step(family, m.step)) for scene in scenes(family) for m in scene.moves}
    for attempt in range(MAX_ATTEMPTS):
        rng = random.Random(f"{family}/{seed}/{attempt}")
        tasks = tuple(_compose(rng, family, seed, i, known_plans, weight) for i in range(count))
        plans = [plan_key(t.plan) for t in tasks]
        if len(set(plans)) < len(plans):
            continue
        drawn = {SUBTASKS[s.subtask].category for t in tasks for s in t.plan}
        if mean(calls(t) for t in tasks) >= PAPER_CALLS[family] and drawn >= categories:
            return tasks
    raise ValueError(f"no draw of {count} {family} task(s) meets the constraints for seed {seed}")


def _one_step(family: str, plan_step: PlanStep) -> TaskSpec:
    return task(family, "one_step", "", (), plan_step)


def _chainable(scene: Scene) -> set[str]:
    """The subtasks that appear in some chain of at least ``LENGTHS[0]`` subtasks on ``scene``."""
    found: set[str] = set()

    def walk(facts: frozenset[str], plan: tuple[str, ...], ended: bool) -> None:
        if len(plan) >= LENGTHS[0]:
            found.update(plan)
        # a chain ends at the longest length, after a move that ends tasks, or (to bound the search)
        # once it is long enough and its last subtask is already known to be chainable
        if ended or len(plan) == LENGTHS[-1] or (len(plan) >= LENGTHS[0] and plan[-1] in found):
            return
        for move in scene.moves:
            if move.needs <= facts and move.step.subtask not in plan:
                walk((facts - move.ends) | move.starts, (*plan, move.step.subtask), move.last)

    walk(scene.facts, (), False)
    return found


def _compose(
    rng: random.Random, family: str, seed: int, index: int, known_plans: set, weight: dict[str, int]
) -> TaskSpec:
    """One task: a scene, then subtasks chosen one by one among those its facts allow, a subtask that
    makes more primitive calls the likelier (the paper's tasks are long: the weights are the reference
    skills' call counts, so a seed names one draw for one library; the draw file is the record)."""
    while True:
        scene = rng.choice(scenes(family))
        length = rng.choice(LENGTHS)
        facts, plan, used = set(scene.facts), [], set()
        while len(plan) < length:
            options = [m for m in scene.moves if m.needs <= facts and m.step.subtask not in used]
            if not options:
                break
            move = rng.choices(options, weights=[max(1, weight[m.step.subtask]) for m in options])[0]
            plan.append(move.step)
            used.add(move.step.subtask)
            facts = (facts - move.ends) | move.starts
            if move.last:
                break
        if len(plan) >= LENGTHS[0] and plan_key(plan) not in known_plans:
            name = f"draw{seed}_{index:02d}"
            instruction = "; then ".join(_describe(s) for s in plan).capitalize() + "."
            return task(family, name, instruction, scene.objects, *plan)


def plan_key(plan) -> tuple:
    """A plan as a hashable value: its subtasks with their bindings, in order."""
    return tuple((s.subtask, tuple(sorted(s.args.items()))) for s in plan)


def _describe(plan_step: PlanStep) -> str:
    arguments = ", ".join(f"{k}={v}" for k, v in plan_step.args.items())
    return f"{plan_step.subtask.replace('_', ' ')} ({arguments})"


# ---------------------------------------------------------------------------------------- draw files


def draw_document(family: str, seed: int, tasks: tuple[TaskSpec, ...]) -> dict:
    """A draw as data: what ``recent envs compose --out`` writes and ``RECENT_TASKS`` reads back
    (``suites.tasks_from_document``).
    Each task is its scene's name and its plan, so the file is the draw, whatever the grammar becomes."""

    def scene_of(spec: TaskSpec) -> str:
        return next(name for name, objects in SCENES.items() if objects == spec.objects)

    return {
        "format": DRAW_FORMAT,
        "family": family,
        "seed": seed,
        "tasks": [
            {
                "task_id": t.task_id,
                "instruction": t.instruction,
                "scene": scene_of(t),
                "plan": [{"subtask": s.subtask, **s.args} for s in t.plan],
            }
            for t in tasks
        ],
    }
