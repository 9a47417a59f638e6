"""The task suites: ``kinematic`` (26 tasks) and ``end_effector`` (16 tasks), plus ``cube_in_bin``.

The last 6 and 4 tasks of the suites are the held-out test tasks (:mod:`.splits`): compositions
in orders and bindings no earlier task had.

A suite task is a scene (objects with nominal poses and seeded jitter) and a plan of up to five
subtasks, each bound to the reference skill of the same name. Task ids are ``<suite>/<name>``;
``lerobot-eval --env.type=recent --env.task=kinematic/tidy_bench`` runs one.
"""

from __future__ import annotations

import functools

from lerobot_policy_recent.robosuite_envs.tasks import ObjectSpec, PlanStep, TaskSpec
from lerobot_policy_recent.robosuite_envs.variations import OBSTACLE

SEEDS = (0, 1, 42, 123, 2024)  # the paper's evaluation seeds
STEPS_PER_SUBTASK = 400

RED, GREEN, BLUE, YELLOW = (0.85, 0.15, 0.1, 1.0), (0.2, 0.7, 0.25, 1.0), (0.2, 0.35, 0.85, 1.0), (0.9, 0.8, 0.1, 1.0)
WOOD, GREY, MARK = (0.35, 0.25, 0.15, 1.0), (0.6, 0.6, 0.62, 1.0), (0.95, 0.95, 0.3, 0.35)
OBSTACLE_SLAB = ObjectSpec(OBSTACLE, "slab", (0.0, 0.0), (0.1, 0.1, 0.03), rgba=(0.25, 0.25, 0.25, 1.0))


def step(subtask: str, **args: str) -> PlanStep:
    return PlanStep(subtask, subtask, args)


def task(suite: str, name: str, instruction: str, objects: tuple[ObjectSpec, ...], *plan: PlanStep) -> TaskSpec:
    return TaskSpec(
        task_id=f"{suite}/{name}",
        instruction=instruction,
        objects=objects,
        plan=plan,
        max_steps=STEPS_PER_SUBTASK * len(plan) + 200,
        suite=suite,
    )


# ---------------------------------------------------------------------------- scenes
WORKBENCH = (
    ObjectSpec("cube", "box", (-0.05, -0.12), (0.045, 0.045, 0.045), 0.02, RED),
    ObjectSpec("block", "box", (0.12, -0.22), (0.05, 0.05, 0.05), 0.015, GREEN),
    ObjectSpec("bin", "bin", (0.05, 0.17), (0.2, 0.2, 0.08), 0.0, WOOD),
    ObjectSpec("plate", "plate", (0.17, -0.02), (0.14, 0.14, 0.012), 0.0, GREY),
    ObjectSpec("button", "button", (-0.14, 0.07), None, 0.01),
    ObjectSpec("zone", "region", (-0.05, -0.3), (0.1, 0.1, 0.001), 0.0, MARK),
    OBSTACLE_SLAB,
)
ASSEMBLY = (
    ObjectSpec("peg", "box", (-0.1, -0.18), (0.024, 0.024, 0.08), 0.015, YELLOW),
    ObjectSpec("hole", "peg_hole", (0.12, -0.15), None, 0.01),
    ObjectSpec("lid", "lid", (-0.12, 0.12), None, 0.015),
    ObjectSpec("jar", "bin", (0.12, 0.16), (0.09, 0.09, 0.06), 0.0, BLUE),
    ObjectSpec("button", "button", (-0.15, -0.02), None, 0.01),
)
TOOLS = (
    ObjectSpec("rake", "rake", (-0.12, -0.03), None, 0.01),
    ObjectSpec("cube", "box", (0.2, 0.15), (0.045, 0.045, 0.045), 0.015, RED),
    ObjectSpec("zone", "region", (0.0, 0.15), (0.12, 0.12, 0.001), 0.0, MARK),
    ObjectSpec("stain", "stain", (0.02, -0.22), (0.16, 0.12, 0.001), 0.0, (0.45, 0.3, 0.1, 0.5)),
    ObjectSpec("button", "button", (-0.17, -0.25), None, 0.01),
)


def cabinet(drawer_open: float = 0.0, lid_angle: float = 0.0) -> tuple[ObjectSpec, ...]:
    return (
        ObjectSpec("drawer", "drawer", (0.08, -0.16), None, 0.0, state=drawer_open),
        ObjectSpec("box", "hinged_box", (0.05, 0.16), None, 0.0, state=lid_angle),
        ObjectSpec("cube", "box", (-0.16, 0.04), (0.04, 0.04, 0.04), 0.015, RED),  # the hand clears the drawer
    )


BLOCKS = (
    ObjectSpec("red", "box", (-0.1, -0.2), (0.05, 0.05, 0.05), 0.015, RED),
    ObjectSpec("green", "box", (-0.12, 0.0), (0.045, 0.045, 0.045), 0.015, GREEN),
    ObjectSpec("blue", "box", (-0.1, 0.2), (0.04, 0.04, 0.04), 0.015, BLUE),
    ObjectSpec("row", "region", (0.12, 0.0), (0.06, 0.28, 0.001), 0.0, MARK),
)
SWEEP = (
    ObjectSpec("pen", "pen", (0.15, 0.0), None, 0.0),
    ObjectSpec("red", "box", (-0.1, -0.045), (0.04, 0.04, 0.04), 0.01, RED),
    ObjectSpec("blue", "box", (-0.1, 0.05), (0.04, 0.04, 0.04), 0.01, BLUE),
)

# ---------------------------------------------------------------------------- suites
K, E = "kinematic", "end_effector"

KINEMATIC = (
    task(K, "cube_in_bin", "Put the red cube in the bin.", WORKBENCH, step("put_in_bin", obj="cube", receptacle="bin")),
    task(K, "lift_cube", "Pick up the red cube and hold it up.", WORKBENCH, step("pick_and_lift", obj="cube")),
    task(K, "cube_on_plate", "Put the red cube on the plate.", WORKBENCH, step("place_on_plate", obj="cube", target="plate")),
    task(K, "stack_cube", "Stack the red cube on the green block.", WORKBENCH, step("stack", obj="cube", target="block")),
    task(K, "press_button", "Press the button.", WORKBENCH, step("press_button", button="button")),
    task(K, "push_cube", "Push the red cube into the marked zone.", WORKBENCH, step("push_to_region", obj="cube", region="zone")),
    task(K, "plate_then_button", "Put the red cube on the plate, then press the button.", WORKBENCH,
         step("place_on_plate", obj="cube", target="plate"), step("press_button", button="button")),
    task(K, "bin_then_button", "Put the red cube in the bin, then press the button.", WORKBENCH,
         step("put_in_bin", obj="cube", receptacle="bin"), step("press_button", button="button")),
    task(K, "tidy_bench", "Put the red cube on the plate and the green block in the bin, then press the button.",
         WORKBENCH, step("place_on_plate", obj="cube", target="plate"),
         step("put_in_bin", obj="block", receptacle="bin"), step("press_button", button="button")),
    task(K, "push_then_bin", "Push the red cube into the zone, then put the green block in the bin.", WORKBENCH,
         step("push_to_region", obj="cube", region="zone"), step("put_in_bin", obj="block", receptacle="bin")),
    task(K, "bench_routine",
         "Push the red cube into the zone, set it on the plate, stack the green block on it, press the button.",
         WORKBENCH, step("push_to_region", obj="cube", region="zone"), step("place_on_plate", obj="cube", target="plate"),
         step("stack", obj="block", target="cube"), step("press_button", button="button")),
    task(K, "insert_peg", "Insert the peg into the hole.", ASSEMBLY, step("insert_peg", peg="peg", hole="hole")),
    task(K, "close_jar", "Put the lid on the jar.", ASSEMBLY, step("close_lid", lid="lid", container="jar")),
    task(K, "lid_and_peg", "Put the lid on the jar, then insert the peg into the hole.", ASSEMBLY,
         step("close_lid", lid="lid", container="jar"), step("insert_peg", peg="peg", hole="hole")),
    task(K, "assembly_line", "Close the jar, insert the peg, and press the button.", ASSEMBLY,
         step("close_lid", lid="lid", container="jar"), step("insert_peg", peg="peg", hole="hole"),
         step("press_button", button="button")),
    task(K, "drag_cube", "Use the rake to drag the red cube into the zone.", TOOLS,
         step("drag_with_tool", obj="cube", tool="rake", region="zone")),
    task(K, "wipe_table", "Wipe the stain off the table.", TOOLS, step("wipe_area", area="stain")),
    task(K, "drag_then_lift", "Drag the red cube into the zone with the rake, then pick it up.", TOOLS,
         step("drag_with_tool", obj="cube", tool="rake", region="zone"), step("pick_and_lift", obj="cube")),
    task(K, "wipe_then_button", "Wipe the stain, then press the button.", TOOLS,
         step("wipe_area", area="stain"), step("press_button", button="button")),
    task(K, "tool_routine", "Drag the cube into the zone with the rake, wipe the stain, press the button.", TOOLS,
         step("drag_with_tool", obj="cube", tool="rake", region="zone"), step("wipe_area", area="stain"),
         step("press_button", button="button")),
    # held-out test tasks (splits.py): checked for feasibility with the Panda skills on dev seeds only
    task(K, "button_bin_plate", "Press the button, put the green block in the bin, then set the red cube on the plate.",
         WORKBENCH, step("press_button", button="button"), step("put_in_bin", obj="block", receptacle="bin"),
         step("place_on_plate", obj="cube", target="plate")),
    task(K, "bin_push_button_plate",
         "Put the green block in the bin, push the red cube into the zone, press the button, then set the cube on the plate.",
         WORKBENCH, step("put_in_bin", obj="block", receptacle="bin"), step("push_to_region", obj="cube", region="zone"),
         step("press_button", button="button"), step("place_on_plate", obj="cube", target="plate")),
    task(K, "cube_bin_block_plate", "Put the red cube in the bin, set the green block on the plate, press the button.",
         WORKBENCH, step("put_in_bin", obj="cube", receptacle="bin"), step("place_on_plate", obj="block", target="plate"),
         step("press_button", button="button")),
    task(K, "peg_lid_button", "Insert the peg, put the lid on the jar, then press the button.", ASSEMBLY,
         step("insert_peg", peg="peg", hole="hole"), step("close_lid", lid="lid", container="jar"),
         step("press_button", button="button")),
    task(K, "button_then_assembly", "Press the button, then insert the peg and close the jar.", ASSEMBLY,
         step("press_button", button="button"), step("insert_peg", peg="peg", hole="hole"),
         step("close_lid", lid="lid", container="jar")),
    task(K, "button_wipe_drag_lift", "Press the button, wipe the stain, rake the cube into the zone, and pick it up.",
         TOOLS, step("press_button", button="button"), step("wipe_area", area="stain"),
         step("drag_with_tool", obj="cube", tool="rake", region="zone"), step("pick_and_lift", obj="cube")),
)  # fmt: skip

END_EFFECTOR = (
    task(E, "open_drawer", "Open the drawer.", cabinet(), step("open_drawer", drawer="drawer")),
    task(E, "close_drawer", "Close the drawer.", cabinet(drawer_open=0.12), step("close_drawer", drawer="drawer")),
    task(E, "cube_in_drawer", "Open the drawer, put the cube in it and close it.", cabinet(),
         step("open_drawer", drawer="drawer"), step("put_in_drawer", obj="cube", drawer="drawer"),
         step("close_drawer", drawer="drawer")),
    task(E, "open_box", "Open the box.", cabinet(), step("open_hinged_box", box="box")),
    task(E, "close_box", "Close the box.", cabinet(lid_angle=1.75), step("close_hinged_box", box="box")),
    task(E, "cube_into_drawer", "Put the cube into the open drawer.", cabinet(drawer_open=0.12),
         step("put_in_drawer", obj="cube", drawer="drawer")),
    task(E, "drawer_and_box", "Open the drawer and the box, then close both.", cabinet(),
         step("open_drawer", drawer="drawer"), step("open_hinged_box", box="box"),
         step("close_hinged_box", box="box"), step("close_drawer", drawer="drawer")),
    task(E, "build_tower", "Stack the green and blue blocks on the red one.", BLOCKS,
         step("stack_tower", base="red", middle="green", top="blue")),
    task(E, "arrange_row", "Line the three blocks up on the marked row, not touching.", BLOCKS,
         step("arrange_in_row", first="red", second="green", third="blue", row="row")),
    task(E, "row_then_tower", "Line the blocks up on the row, then stack them into a tower.", BLOCKS,
         step("arrange_in_row", first="red", second="green", third="blue", row="row"),
         step("stack_tower", base="red", middle="green", top="blue")),
    task(E, "sweep_blocks", "Sweep both blocks into the pen.", SWEEP,
         step("sweep_into_pen", first="red", second="blue", pen="pen")),
    task(E, "cabinet_routine", "Put the cube away in the drawer, then open and close the box.", cabinet(),
         step("open_drawer", drawer="drawer"), step("put_in_drawer", obj="cube", drawer="drawer"),
         step("close_drawer", drawer="drawer"), step("open_hinged_box", box="box"),
         step("close_hinged_box", box="box")),
    # held-out test tasks (splits.py): checked for feasibility with the Panda skills on dev seeds only
    task(E, "box_drawer_routine", "Open the box, put the cube away in the drawer, then close the box.", cabinet(),
         step("open_hinged_box", box="box"), step("open_drawer", drawer="drawer"),
         step("put_in_drawer", obj="cube", drawer="drawer"), step("close_drawer", drawer="drawer"),
         step("close_hinged_box", box="box")),
    task(E, "box_then_drawer", "Open and close the box, then open and close the drawer.", cabinet(),
         step("open_hinged_box", box="box"), step("close_hinged_box", box="box"),
         step("open_drawer", drawer="drawer"), step("close_drawer", drawer="drawer")),
    task(E, "drawer_box_cube", "Open the drawer and the box, put the cube in the drawer, close the drawer.", cabinet(),
         step("open_drawer", drawer="drawer"), step("open_hinged_box", box="box"),
         step("put_in_drawer", obj="cube", drawer="drawer"), step("close_drawer", drawer="drawer")),
    task(E, "open_all_then_tidy", "Open the box, open the drawer, close the drawer, close the box.", cabinet(),
         step("open_hinged_box", box="box"), step("open_drawer", drawer="drawer"),
         step("close_drawer", drawer="drawer"), step("close_hinged_box", box="box")),
)  # fmt: skip

CUBE_IN_BIN = TaskSpec(
    task_id="cube_in_bin",
    instruction="Pick the cube and place it in the bin.",
    objects=(
        ObjectSpec("cube", "box", (-0.02, -0.12), (0.045, 0.045, 0.045), 0.03, (0.85, 0.15, 0.1, 1.0)),
        ObjectSpec("bin", "bin", (0.02, 0.16), (0.20, 0.20, 0.08), 0.0, (0.35, 0.25, 0.15, 1.0)),
    ),
    plan=(step("put_in_bin", obj="cube", receptacle="bin"),),
)

SUITES: dict[str, tuple[TaskSpec, ...]] = {K: KINEMATIC, E: END_EFFECTOR}


def all_tasks() -> tuple[TaskSpec, ...]:
    return (CUBE_IN_BIN, *KINEMATIC, *END_EFFECTOR)


def get_suite(name: str) -> tuple[TaskSpec, ...]:
    try:
        return SUITES[name]
    except KeyError:
        raise KeyError(f"unknown suite {name!r}; known suites: {', '.join(SUITES)}") from None


def validation_task(subtask: str) -> TaskSpec:
    """The suite task that exercises ``subtask`` alone: where its reference skill is validated."""
    for tasks in SUITES.values():
        for spec in tasks:
            if [step.subtask for step in spec.plan] == [subtask]:
                return spec
    raise KeyError(f"no single-subtask task for {subtask!r} in the suites")


@functools.cache
def tasks() -> dict[str, TaskSpec]:
    """Every task id → spec: ``cube_in_bin`` and the suites' ``<suite>/<task>`` ids."""
    return {task.task_id: task for task in all_tasks()}


def get_task(task_id: str) -> TaskSpec:
    try:
        return tasks()[task_id]
    except KeyError:
        raise KeyError(f"unknown task {task_id!r}; known tasks: {', '.join(tasks())}") from None
