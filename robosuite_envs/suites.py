"""The task suites: ``kinematic`` (20 tasks) and ``end_effector`` (12 tasks), of the paper's length,
the earlier, shorter ``kinematic-v1`` (26) and ``end_effector-v1`` (16), plus ``cube_in_bin``.

A suite task is a scene (objects with nominal poses and seeded jitter) and a plan of up to five
subtasks, each bound to the reference skill of the same name. Task ids are ``<setting>/<name>``
whichever suite lists them (``kinematic/tidy_bench`` is a ``kinematic-v1`` task);
``lerobot-eval --env.type=recent --env.task=kinematic/serve_then_clear`` runs one. Which tasks are
held out for testing is :mod:`.splits`'s.

The paper-length suites count 27.85 and 30.25 primitive calls per task on average (the paper: 24.6
and 29), the longest 51 (the paper: 54); ``recent envs list`` recounts them from the skills.
"""

from __future__ import annotations

import functools
import json
import os
from pathlib import Path

from lerobot_policy_recent.robosuite_envs.subtasks import SUBTASKS
from lerobot_policy_recent.robosuite_envs.tasks import ObjectSpec, PlanStep, TaskSpec
from lerobot_policy_recent.robosuite_envs.variations import OBSTACLE

SEEDS = (0, 1, 42, 123, 2024)  # the paper's evaluation seeds
STEPS_PER_SUBTASK = 400
# In the paper-length suites, a subtask that handles several objects gets the control steps of as many
# single-object ones (the -v1 suites keep 400 per subtask, so their committed runs still reproduce).
SUBTASK_STEPS = {
    "clear_into_bin": 1600,
    "arrange_in_row": 1200,
    "fill_drawer": 800,
    "stack_tower": 800,
    "sweep_into_pen": 800,
    "press_buttons": 600,
}
# ... and an LM call budget of at least two calls per primitive call of the task (the -v1 suites keep
# the flat per-task budget, ``--max_lm_calls``)
LM_CALLS_PER_PRIMITIVE = 2

RED, GREEN, BLUE, YELLOW = (0.85, 0.15, 0.1, 1.0), (0.2, 0.7, 0.25, 1.0), (0.2, 0.35, 0.85, 1.0), (0.9, 0.8, 0.1, 1.0)
WOOD, GREY, MARK = (0.35, 0.25, 0.15, 1.0), (0.6, 0.6, 0.62, 1.0), (0.95, 0.95, 0.3, 0.35)
OBSTACLE_SLAB = ObjectSpec(OBSTACLE, "slab", (0.0, 0.0), (0.1, 0.1, 0.03), rgba=(0.25, 0.25, 0.25, 1.0))


def step(subtask: str, **args: str) -> PlanStep:
    return PlanStep(subtask, subtask, args)


def task(
    suite: str, name: str, instruction: str, objects: tuple[ObjectSpec, ...], *plan: PlanStep, v1: bool = False
) -> TaskSpec:
    steps = {} if v1 else SUBTASK_STEPS
    return TaskSpec(
        task_id=f"{suite}/{name}",
        instruction=instruction,
        objects=objects,
        plan=plan,
        max_steps=sum(steps.get(s.subtask, STEPS_PER_SUBTASK) for s in plan) + 200,
        suite=suite,
        lm_calls_per_primitive=0 if v1 else LM_CALLS_PER_PRIMITIVE,
    )


def task_v1(*args, **kwargs) -> TaskSpec:
    """A task of the earlier suites: 400 control steps per subtask, whatever it handles, and the flat LM budget."""
    return task(*args, v1=True, **kwargs)


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

# the paper-length suites' scenes: more objects, so that a task can chain up to five subtasks
KITCHEN = (
    *WORKBENCH[:2],
    ObjectSpec("bin", "bolted_bin", (0.05, 0.17), (0.2, 0.2, 0.08), 0.0, WOOD),  # bolted down: no contacts to solve
    WORKBENCH[3],
    ObjectSpec("zone", "region", (-0.05, -0.3), (0.1, 0.1, 0.001), 0.0, MARK),
    ObjectSpec("can", "box", (-0.18, -0.1), (0.04, 0.04, 0.04), 0.015, YELLOW),
    ObjectSpec("dice", "box", (-0.22, 0.0), (0.04, 0.04, 0.04), 0.015, BLUE),
    ObjectSpec("power", "button", (-0.14, 0.07), None, 0.01),
    ObjectSpec("channel", "button", (-0.17, 0.22), None, 0.01),
    ObjectSpec("volume", "button", (-0.24, -0.22), None, 0.01),
    OBSTACLE_SLAB,
)
WORKSHOP = (  # ASSEMBLY with a button panel, a cube and a zone
    *ASSEMBLY,
    ObjectSpec("channel", "button", (-0.24, -0.08), None, 0.01),
    ObjectSpec("volume", "button", (-0.02, 0.02), None, 0.01),
    ObjectSpec("cube", "box", (0.0, -0.15), (0.045, 0.045, 0.045), 0.015, RED),
    ObjectSpec("zone", "region", (-0.03, -0.3), (0.1, 0.1, 0.001), 0.0, MARK),
)
TOOL_BENCH = (  # TOOLS with a button panel and a block
    *TOOLS,
    ObjectSpec("channel", "button", (-0.22, 0.2), None, 0.01),
    ObjectSpec("volume", "button", (0.2, -0.05), None, 0.01),
    ObjectSpec("block", "box", (0.2, -0.2), (0.05, 0.05, 0.05), 0.015, GREEN),
)


def pantry(drawer_open: float = 0.0, lid_angle: float = 0.0) -> tuple[ObjectSpec, ...]:
    """The cabinet with three loose objects, clear of where the drawer opens and the box's lid swings."""
    return (
        *cabinet(drawer_open, lid_angle)[:2],
        ObjectSpec("cube", "box", (-0.16, 0.02), (0.04, 0.04, 0.04), 0.015, RED),
        ObjectSpec("green", "box", (-0.05, 0.02), (0.045, 0.045, 0.045), 0.015, GREEN),
        ObjectSpec("blue", "box", (-0.1, 0.12), (0.04, 0.04, 0.04), 0.015, BLUE),
    )


PEN_AND_ROW = (  # SWEEP with a third block and a row to line the blocks up on
    *SWEEP,
    ObjectSpec("green", "box", (-0.05, -0.25), (0.045, 0.045, 0.045), 0.015, GREEN),
    ObjectSpec("row", "region", (-0.25, 0.0), (0.06, 0.28, 0.001), 0.0, MARK),
)

# The scenes by name, as draw files name them (recent envs compose)
SCENES: dict[str, tuple[ObjectSpec, ...]] = {
    "kitchen": KITCHEN,
    "workshop": WORKSHOP,
    "tool_bench": TOOL_BENCH,
    "pantry": pantry(),
    "pen_and_row": PEN_AND_ROW,
}
TASKS_ENV = "RECENT_TASKS"  # draw files (os.pathsep-separated JSON) whose tasks join the suites'
DRAW_FORMAT = 1

# ---------------------------------------------------------------------------- suites
K, E = "kinematic", "end_effector"
PANEL = {"first": "power", "second": "channel", "third": "volume"}
WORKSHOP_PANEL = {"first": "button", "second": "channel", "third": "volume"}
CLEAR = {"first": "cube", "second": "block", "third": "can", "fourth": "dice", "receptacle": "bin"}

# The paper's length: 3-5 subtasks per task, its four subtask categories across the suite.
KINEMATIC = (
    task(K, "serve_then_clear", "Move the red cube to the zone, set the can on the plate and the dice on the block, "
         "switch the panel on, then clear all four into the bin.", KITCHEN,
         step("move_to_region", obj="cube", region="zone"), step("place_on_plate", obj="can", target="plate"),
         step("stack", obj="dice", target="block"), step("press_buttons", **PANEL),
         step("clear_into_bin", **{**CLEAR, "second": "dice", "third": "block"})),  # the dice off the block first
    task(K, "plate_clear_switch", "Set the cube on the plate, clear all four objects into the bin, then switch the "
         "panel on.", KITCHEN,
         step("place_on_plate", obj="cube", target="plate"), step("clear_into_bin", **CLEAR),
         step("press_buttons", **PANEL)),
    task(K, "plate_stack_panel", "Set the cube on the plate, the block on the cube, switch the panel on, and move "
         "the can to the zone.", KITCHEN,
         step("place_on_plate", obj="cube", target="plate"), step("stack", obj="block", target="cube"),
         step("press_buttons", **PANEL), step("move_to_region", obj="can", region="zone")),
    task(K, "zone_bin_plate_panel", "Move the dice to the zone, put the block in the bin, set the cube on the plate, "
         "then switch the panel on.", KITCHEN,
         step("move_to_region", obj="dice", region="zone"), step("put_in_bin", obj="block", receptacle="bin"),
         step("place_on_plate", obj="cube", target="plate"), step("press_buttons", **PANEL)),
    task(K, "push_then_clear", "Push the cube into the zone, press the power button, then clear all four objects "
         "into the bin.", KITCHEN,
         step("push_to_region", obj="cube", region="zone"), step("press_button", button="power"),
         step("clear_into_bin", **CLEAR)),
    task(K, "bench_panel", "Put the cube in the bin, the block on the plate, the can in the zone, switch the panel "
         "on and pick up the dice.", KITCHEN,
         step("put_in_bin", obj="cube", receptacle="bin"), step("place_on_plate", obj="block", target="plate"),
         step("move_to_region", obj="can", region="zone"), step("press_buttons", **PANEL),
         step("pick_and_lift", obj="dice")),
    task(K, "lift_panel_bin", "Switch the panel on, put the cube in the bin, and move the block to the zone.",
         KITCHEN, step("press_buttons", **PANEL), step("put_in_bin", obj="cube", receptacle="bin"),
         step("move_to_region", obj="block", region="zone")),
    task(K, "assembly_panel", "Close the jar, insert the peg, press the three buttons, and move the cube to the zone.",
         WORKSHOP, step("close_lid", lid="lid", container="jar"), step("insert_peg", peg="peg", hole="hole"),
         step("press_buttons", **WORKSHOP_PANEL), step("move_to_region", obj="cube", region="zone")),
    task(K, "peg_panel_lid", "Insert the peg, press the three buttons, close the jar, and move the cube to the zone.",
         WORKSHOP, step("insert_peg", peg="peg", hole="hole"), step("press_buttons", **WORKSHOP_PANEL),
         step("close_lid", lid="lid", container="jar"), step("move_to_region", obj="cube", region="zone")),
    task(K, "assembly_zone", "Move the cube to the zone, close the jar, insert the peg, and press the button.",
         WORKSHOP, step("move_to_region", obj="cube", region="zone"), step("close_lid", lid="lid", container="jar"),
         step("insert_peg", peg="peg", hole="hole"), step("press_button", button="button")),
    task(K, "tool_panel", "Rake the cube into the zone, wipe the stain, press the three buttons, and pick up the block.",
         TOOL_BENCH, step("drag_with_tool", obj="cube", tool="rake", region="zone"), step("wipe_area", area="stain"),
         step("press_buttons", **WORKSHOP_PANEL), step("pick_and_lift", obj="block")),
    task(K, "wipe_drag_panel", "Wipe the stain, press the three buttons, rake the cube into the zone, and pick it up.",
         TOOL_BENCH, step("wipe_area", area="stain"), step("press_buttons", **WORKSHOP_PANEL),
         step("drag_with_tool", obj="cube", tool="rake", region="zone"), step("pick_and_lift", obj="cube")),
    task(K, "wipe_panel_drag", "Wipe the stain, rake the cube into the zone, then press the three buttons.",
         TOOL_BENCH, step("wipe_area", area="stain"), step("drag_with_tool", obj="cube", tool="rake", region="zone"),
         step("press_buttons", **WORKSHOP_PANEL)),
    task(K, "tools_panel_wipe", "Rake the cube into the zone, press the three buttons, wipe the stain, and pick up "
         "the block.", TOOL_BENCH,
         step("drag_with_tool", obj="cube", tool="rake", region="zone"), step("press_buttons", **WORKSHOP_PANEL),
         step("wipe_area", area="stain"), step("pick_and_lift", obj="block")),
    # held-out test tasks (splits.py): checked for feasibility with the Panda skills on dev seeds only
    task(K, "panel_then_clear", "Switch the panel on, move the block to the zone, then clear all four objects into "
         "the bin.", KITCHEN,
         step("press_buttons", **PANEL), step("move_to_region", obj="block", region="zone"),
         step("clear_into_bin", **CLEAR)),
    task(K, "stack_zone_bin_lift", "Stack the can on the block, move the cube to the zone, put the dice in the bin, "
         "switch the panel on, and pick up the cube.", KITCHEN,
         step("stack", obj="can", target="block"), step("move_to_region", obj="cube", region="zone"),
         step("put_in_bin", obj="dice", receptacle="bin"), step("press_buttons", **PANEL),
         step("pick_and_lift", obj="cube")),
    task(K, "panel_peg_lid_zone", "Press the three buttons, move the cube to the zone, insert the peg, and close the jar.",
         WORKSHOP, step("press_buttons", **WORKSHOP_PANEL), step("move_to_region", obj="cube", region="zone"),
         step("insert_peg", peg="peg", hole="hole"), step("close_lid", lid="lid", container="jar")),
    task(K, "panel_then_tools", "Press the three buttons, rake the cube into the zone, wipe the stain, and pick up "
         "the block.", TOOL_BENCH,
         step("press_buttons", **WORKSHOP_PANEL), step("drag_with_tool", obj="cube", tool="rake", region="zone"),
         step("wipe_area", area="stain"), step("pick_and_lift", obj="block")),
    task(K, "bin_plate_zone_panel", "Put the block in the bin, set the dice on the plate, move the can to the zone, "
         "then switch the panel on.", KITCHEN,
         step("put_in_bin", obj="block", receptacle="bin"), step("place_on_plate", obj="dice", target="plate"),
         step("move_to_region", obj="can", region="zone"), step("press_buttons", **PANEL)),
    task(K, "clear_then_panel", "Push the cube into the zone, clear all four objects into the bin, then switch the "
         "panel on.", KITCHEN,
         step("push_to_region", obj="cube", region="zone"), step("clear_into_bin", **CLEAR),
         step("press_buttons", **PANEL)),
)  # fmt: skip

END_EFFECTOR = (
    task(E, "stock_drawer", "Open the drawer, put the cube and the green block in it, and close it.", pantry(),
         step("open_drawer", drawer="drawer"), step("fill_drawer", first="cube", second="green", drawer="drawer"),
         step("close_drawer", drawer="drawer")),
    task(E, "box_and_drawer", "Open the box, put the blue block in it and close it, then open the drawer and put "
         "the cube in.", pantry(),
         step("open_hinged_box", box="box"), step("fill_box", obj="blue", box="box"), step("close_hinged_box", box="box"),
         step("open_drawer", drawer="drawer"), step("put_in_drawer", obj="cube", drawer="drawer")),
    task(E, "pantry_routine", "Stock the drawer with the cube and the green block and close it, then open the box and "
         "put the blue block in.", pantry(),
         step("open_drawer", drawer="drawer"), step("fill_drawer", first="cube", second="green", drawer="drawer"),
         step("close_drawer", drawer="drawer"), step("open_hinged_box", box="box"), step("fill_box", obj="blue", box="box")),
    task(E, "box_then_stock", "Open the box and put the cube in, then stock the drawer with the green and blue blocks "
         "and close it.", pantry(),
         step("open_hinged_box", box="box"), step("fill_box", obj="cube", box="box"), step("open_drawer", drawer="drawer"),
         step("fill_drawer", first="green", second="blue", drawer="drawer"), step("close_drawer", drawer="drawer")),
    task(E, "open_both_fill", "Open the drawer and the box, put the blue block in the box and the cube and the green "
         "block in the drawer.", pantry(),
         step("open_drawer", drawer="drawer"), step("open_hinged_box", box="box"), step("fill_box", obj="blue", box="box"),
         step("fill_drawer", first="cube", second="green", drawer="drawer")),
    task(E, "stock_and_box", "Stock the drawer with the cube and the green block, then open the box, put the blue "
         "block in and close it.", pantry(),
         step("open_drawer", drawer="drawer"), step("fill_drawer", first="cube", second="green", drawer="drawer"),
         step("open_hinged_box", box="box"), step("fill_box", obj="blue", box="box"), step("close_hinged_box", box="box")),
    task(E, "line_up_then_sweep", "Line the three blocks up on the row, then sweep the red and blue ones into the pen.",
         PEN_AND_ROW, step("arrange_in_row", first="red", second="green", third="blue", row="row"),
         step("sweep_into_pen", first="red", second="blue", pen="pen")),
    task(E, "line_up_then_stack", "Line the three blocks up on the row, then stack them on the green one.", PEN_AND_ROW,
         step("arrange_in_row", first="red", second="green", third="blue", row="row"),
         step("stack_tower", base="green", middle="red", top="blue")),
    # held-out test tasks (splits.py): checked for feasibility with the Panda skills on dev seeds only
    task(E, "drawer_then_box", "Open the drawer, put the blue block in and close it, then open the box and put the "
         "green block in.", pantry(),
         step("open_drawer", drawer="drawer"), step("put_in_drawer", obj="blue", drawer="drawer"),
         step("close_drawer", drawer="drawer"), step("open_hinged_box", box="box"), step("fill_box", obj="green", box="box")),
    task(E, "fill_both_close", "Open the box, put the cube in and close it, then open the drawer and put the green "
         "and blue blocks in.", pantry(),
         step("open_hinged_box", box="box"), step("fill_box", obj="cube", box="box"), step("close_hinged_box", box="box"),
         step("open_drawer", drawer="drawer"), step("fill_drawer", first="green", second="blue", drawer="drawer")),
    task(E, "stock_and_close", "Open the box and the drawer, put the blue block and the cube in the drawer, close "
         "the drawer, then close the box.", pantry(),
         step("open_hinged_box", box="box"), step("open_drawer", drawer="drawer"),
         step("fill_drawer", first="blue", second="cube", drawer="drawer"), step("close_drawer", drawer="drawer"),
         step("close_hinged_box", box="box")),
    task(E, "open_both_then_fill", "Open the box and the drawer, put the green block in the box and the cube in the "
         "drawer, then close the drawer.", pantry(),
         step("open_hinged_box", box="box"), step("open_drawer", drawer="drawer"), step("fill_box", obj="green", box="box"),
         step("put_in_drawer", obj="cube", drawer="drawer"), step("close_drawer", drawer="drawer")),
)  # fmt: skip

# Where each multi-object subtask runs alone (reference validation, the transfer matrix), in no suite:
# the suites are long. The -v1 suites' single-subtask tasks of stack_tower, arrange_in_row and
# sweep_into_pen keep 400 steps for the subtask; these give it what the paper-length suites give it.
VALIDATION_TASKS = (
    task(K, "clear_counter", "Clear the four objects into the bin.", KITCHEN, step("clear_into_bin", **CLEAR)),
    task(K, "move_cube", "Move the red cube to the zone.", KITCHEN, step("move_to_region", obj="cube", region="zone")),
    task(K, "press_panel", "Press the power, channel and volume buttons.", KITCHEN, step("press_buttons", **PANEL)),
    task(E, "fill_open_drawer", "Put the cube and the green block into the open drawer.", pantry(drawer_open=0.12),
         step("fill_drawer", first="cube", second="green", drawer="drawer")),
    task(E, "fill_open_box", "Put the blue block into the open box.", pantry(lid_angle=1.75),
         step("fill_box", obj="blue", box="box")),
    task(E, "tower_of_three", "Stack the green and blue blocks on the red one.", BLOCKS,
         step("stack_tower", base="red", middle="green", top="blue")),
    task(E, "row_of_three", "Line the three blocks up on the marked row, not touching.", BLOCKS,
         step("arrange_in_row", first="red", second="green", third="blue", row="row")),
    task(E, "sweep_both", "Sweep both blocks into the pen.", SWEEP,
         step("sweep_into_pen", first="red", second="blue", pen="pen")),
)  # fmt: skip

# The earlier suites: most tasks one or two subtasks of a few calls each; kept to compare with.
KINEMATIC_V1 = (
    task_v1(K, "cube_in_bin", "Put the red cube in the bin.", WORKBENCH, step("put_in_bin", obj="cube", receptacle="bin")),
    task_v1(K, "lift_cube", "Pick up the red cube and hold it up.", WORKBENCH, step("pick_and_lift", obj="cube")),
    task_v1(K, "cube_on_plate", "Put the red cube on the plate.", WORKBENCH, step("place_on_plate", obj="cube", target="plate")),
    task_v1(K, "stack_cube", "Stack the red cube on the green block.", WORKBENCH, step("stack", obj="cube", target="block")),
    task_v1(K, "press_button", "Press the button.", WORKBENCH, step("press_button", button="button")),
    task_v1(K, "push_cube", "Push the red cube into the marked zone.", WORKBENCH, step("push_to_region", obj="cube", region="zone")),
    task_v1(K, "plate_then_button", "Put the red cube on the plate, then press the button.", WORKBENCH,
         step("place_on_plate", obj="cube", target="plate"), step("press_button", button="button")),
    task_v1(K, "bin_then_button", "Put the red cube in the bin, then press the button.", WORKBENCH,
         step("put_in_bin", obj="cube", receptacle="bin"), step("press_button", button="button")),
    task_v1(K, "tidy_bench", "Put the red cube on the plate and the green block in the bin, then press the button.",
         WORKBENCH, step("place_on_plate", obj="cube", target="plate"),
         step("put_in_bin", obj="block", receptacle="bin"), step("press_button", button="button")),
    task_v1(K, "push_then_bin", "Push the red cube into the zone, then put the green block in the bin.", WORKBENCH,
         step("push_to_region", obj="cube", region="zone"), step("put_in_bin", obj="block", receptacle="bin")),
    task_v1(K, "bench_routine",
         "Push the red cube into the zone, set it on the plate, stack the green block on it, press the button.",
         WORKBENCH, step("push_to_region", obj="cube", region="zone"), step("place_on_plate", obj="cube", target="plate"),
         step("stack", obj="block", target="cube"), step("press_button", button="button")),
    task_v1(K, "insert_peg", "Insert the peg into the hole.", ASSEMBLY, step("insert_peg", peg="peg", hole="hole")),
    task_v1(K, "close_jar", "Put the lid on the jar.", ASSEMBLY, step("close_lid", lid="lid", container="jar")),
    task_v1(K, "lid_and_peg", "Put the lid on the jar, then insert the peg into the hole.", ASSEMBLY,
         step("close_lid", lid="lid", container="jar"), step("insert_peg", peg="peg", hole="hole")),
    task_v1(K, "assembly_line", "Close the jar, insert the peg, and press the button.", ASSEMBLY,
         step("close_lid", lid="lid", container="jar"), step("insert_peg", peg="peg", hole="hole"),
         step("press_button", button="button")),
    task_v1(K, "drag_cube", "Use the rake to drag the red cube into the zone.", TOOLS,
         step("drag_with_tool", obj="cube", tool="rake", region="zone")),
    task_v1(K, "wipe_table", "Wipe the stain off the table.", TOOLS, step("wipe_area", area="stain")),
    task_v1(K, "drag_then_lift", "Drag the red cube into the zone with the rake, then pick it up.", TOOLS,
         step("drag_with_tool", obj="cube", tool="rake", region="zone"), step("pick_and_lift", obj="cube")),
    task_v1(K, "wipe_then_button", "Wipe the stain, then press the button.", TOOLS,
         step("wipe_area", area="stain"), step("press_button", button="button")),
    task_v1(K, "tool_routine", "Drag the cube into the zone with the rake, wipe the stain, press the button.", TOOLS,
         step("drag_with_tool", obj="cube", tool="rake", region="zone"), step("wipe_area", area="stain"),
         step("press_button", button="button")),
    # held-out test tasks (splits.py): checked for feasibility with the Panda skills on dev seeds only
    task_v1(K, "button_bin_plate", "Press the button, put the green block in the bin, then set the red cube on the plate.",
         WORKBENCH, step("press_button", button="button"), step("put_in_bin", obj="block", receptacle="bin"),
         step("place_on_plate", obj="cube", target="plate")),
    task_v1(K, "bin_push_button_plate",
         "Put the green block in the bin, push the red cube into the zone, press the button, then set the cube on the plate.",
         WORKBENCH, step("put_in_bin", obj="block", receptacle="bin"), step("push_to_region", obj="cube", region="zone"),
         step("press_button", button="button"), step("place_on_plate", obj="cube", target="plate")),
    task_v1(K, "cube_bin_block_plate", "Put the red cube in the bin, set the green block on the plate, press the button.",
         WORKBENCH, step("put_in_bin", obj="cube", receptacle="bin"), step("place_on_plate", obj="block", target="plate"),
         step("press_button", button="button")),
    task_v1(K, "peg_lid_button", "Insert the peg, put the lid on the jar, then press the button.", ASSEMBLY,
         step("insert_peg", peg="peg", hole="hole"), step("close_lid", lid="lid", container="jar"),
         step("press_button", button="button")),
    task_v1(K, "button_then_assembly", "Press the button, then insert the peg and close the jar.", ASSEMBLY,
         step("press_button", button="button"), step("insert_peg", peg="peg", hole="hole"),
         step("close_lid", lid="lid", container="jar")),
    task_v1(K, "button_wipe_drag_lift", "Press the button, wipe the stain, rake the cube into the zone, and pick it up.",
         TOOLS, step("press_button", button="button"), step("wipe_area", area="stain"),
         step("drag_with_tool", obj="cube", tool="rake", region="zone"), step("pick_and_lift", obj="cube")),
)  # fmt: skip

END_EFFECTOR_V1 = (
    task_v1(E, "open_drawer", "Open the drawer.", cabinet(), step("open_drawer", drawer="drawer")),
    task_v1(E, "close_drawer", "Close the drawer.", cabinet(drawer_open=0.12), step("close_drawer", drawer="drawer")),
    task_v1(E, "cube_in_drawer", "Open the drawer, put the cube in it and close it.", cabinet(),
         step("open_drawer", drawer="drawer"), step("put_in_drawer", obj="cube", drawer="drawer"),
         step("close_drawer", drawer="drawer")),
    task_v1(E, "open_box", "Open the box.", cabinet(), step("open_hinged_box", box="box")),
    task_v1(E, "close_box", "Close the box.", cabinet(lid_angle=1.75), step("close_hinged_box", box="box")),
    task_v1(E, "cube_into_drawer", "Put the cube into the open drawer.", cabinet(drawer_open=0.12),
         step("put_in_drawer", obj="cube", drawer="drawer")),
    task_v1(E, "drawer_and_box", "Open the drawer and the box, then close both.", cabinet(),
         step("open_drawer", drawer="drawer"), step("open_hinged_box", box="box"),
         step("close_hinged_box", box="box"), step("close_drawer", drawer="drawer")),
    task_v1(E, "build_tower", "Stack the green and blue blocks on the red one.", BLOCKS,
         step("stack_tower", base="red", middle="green", top="blue")),
    task_v1(E, "arrange_row", "Line the three blocks up on the marked row, not touching.", BLOCKS,
         step("arrange_in_row", first="red", second="green", third="blue", row="row")),
    task_v1(E, "row_then_tower", "Line the blocks up on the row, then stack them into a tower.", BLOCKS,
         step("arrange_in_row", first="red", second="green", third="blue", row="row"),
         step("stack_tower", base="red", middle="green", top="blue")),
    task_v1(E, "sweep_blocks", "Sweep both blocks into the pen.", SWEEP,
         step("sweep_into_pen", first="red", second="blue", pen="pen")),
    task_v1(E, "cabinet_routine", "Put the cube away in the drawer, then open and close the box.", cabinet(),
         step("open_drawer", drawer="drawer"), step("put_in_drawer", obj="cube", drawer="drawer"),
         step("close_drawer", drawer="drawer"), step("open_hinged_box", box="box"),
         step("close_hinged_box", box="box")),
    # held-out test tasks (splits.py): checked for feasibility with the Panda skills on dev seeds only
    task_v1(E, "box_drawer_routine", "Open the box, put the cube away in the drawer, then close the box.", cabinet(),
         step("open_hinged_box", box="box"), step("open_drawer", drawer="drawer"),
         step("put_in_drawer", obj="cube", drawer="drawer"), step("close_drawer", drawer="drawer"),
         step("close_hinged_box", box="box")),
    task_v1(E, "box_then_drawer", "Open and close the box, then open and close the drawer.", cabinet(),
         step("open_hinged_box", box="box"), step("close_hinged_box", box="box"),
         step("open_drawer", drawer="drawer"), step("close_drawer", drawer="drawer")),
    task_v1(E, "drawer_box_cube", "Open the drawer and the box, put the cube in the drawer, close the drawer.", cabinet(),
         step("open_drawer", drawer="drawer"), step("open_hinged_box", box="box"),
         step("put_in_drawer", obj="cube", drawer="drawer"), step("close_drawer", drawer="drawer")),
    task_v1(E, "open_all_then_tidy", "Open the box, open the drawer, close the drawer, close the box.", cabinet(),
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

SUITES: dict[str, tuple[TaskSpec, ...]] = {
    K: KINEMATIC,
    E: END_EFFECTOR,
    f"{K}-v1": KINEMATIC_V1,
    f"{E}-v1": END_EFFECTOR_V1,
}


def all_tasks() -> tuple[TaskSpec, ...]:
    return (CUBE_IN_BIN, *KINEMATIC, *END_EFFECTOR, *KINEMATIC_V1, *END_EFFECTOR_V1, *VALIDATION_TASKS)


def get_suite(name: str) -> tuple[TaskSpec, ...]:
    """A suite's tasks, then those of the draw files on ``RECENT_TASKS`` of that family (read once,
    with the registry: :func:`tasks`)."""
    try:
        listed = SUITES[name]
    except KeyError:
        raise KeyError(f"unknown suite {name!r}; known suites: {', '.join(SUITES)}") from None
    built_in = {t.task_id for t in all_tasks()}
    return (*listed, *(t for tid, t in tasks().items() if tid not in built_in and t.suite == name))


def validation_task(subtask: str) -> TaskSpec:
    """The task that exercises ``subtask`` alone, with the control steps the paper-length suites give
    it: where its reference skill is validated and its transfer-matrix cells run."""
    for tasks in (VALIDATION_TASKS, *SUITES.values()):
        for spec in tasks:
            if [step.subtask for step in spec.plan] == [subtask]:
                return spec
    raise KeyError(f"no single-subtask task for {subtask!r} in the suites")


@functools.cache
def tasks() -> dict[str, TaskSpec]:
    """Every task id → spec: ``cube_in_bin``, the suites' ``<suite>/<task>`` ids, and the tasks of the
    draw files on ``RECENT_TASKS`` (``recent envs compose --out``)."""
    return {task.task_id: task for task in (*all_tasks(), *drawn_tasks())}


def drawn_tasks() -> tuple[TaskSpec, ...]:
    """The tasks of the draw files on ``RECENT_TASKS`` (``os.pathsep``-separated JSON files)."""
    found: list[TaskSpec] = []
    for entry in filter(None, os.environ.get(TASKS_ENV, "").split(os.pathsep)):
        path = Path(entry)
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError) as err:
            raise ValueError(f"{path}: not a draw file ({TASKS_ENV}): {err}") from None
        found += tasks_from_document(data, str(path))
    return tuple(found)


def tasks_from_document(data: dict, source: str) -> tuple[TaskSpec, ...]:
    """The tasks of a draw file; a bad file fails naming it and the field."""
    try:
        if data.get("format") != DRAW_FORMAT:
            raise ValueError(f"format: expected {DRAW_FORMAT}, got {data.get('format')!r}")
        family = data["family"]
        named = {name: objects for name, objects in SCENES.items()}
        out = []
        for k, row in enumerate(data["tasks"]):
            where = f"tasks[{k}]"
            if row.get("scene") not in named:
                raise ValueError(f"{where}.scene: {row.get('scene')!r} is not a scene ({', '.join(named)})")
            plan = []
            for j, entry in enumerate(row["plan"]):
                args = {key: str(value) for key, value in entry.items() if key != "subtask"}
                if entry.get("subtask") not in SUBTASKS:
                    raise ValueError(f"{where}.plan[{j}].subtask: unknown subtask {entry.get('subtask')!r}")
                plan.append(step(entry["subtask"], **args))
            suite, name = row["task_id"].split("/", 1)
            if suite != family:
                raise ValueError(f"{where}.task_id: {row['task_id']!r} is not a {family} task")
            out.append(task(family, name, row["instruction"], named[row["scene"]], *plan))
        return tuple(out)
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(f"{source}: {err}") from None


def get_task(task_id: str) -> TaskSpec:
    try:
        return tasks()[task_id]
    except KeyError:
        raise KeyError(f"unknown task {task_id!r}; known tasks: {', '.join(tasks())}") from None
