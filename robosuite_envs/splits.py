"""The held-out split: which episodes the benchmark reports as *test*, and which may be used for fixes.

* **Test tasks** are compositions of the subtasks in orders and argument bindings that no dev task
  of their suite has. They were checked only for feasibility, with the Panda reference skills on
  dev seeds; no fix may be motivated by one of their episodes.
* **Test seeds** are the paper's five (0, 1, 42, 123, 2024); **dev seeds** are others.
* A test episode is a test task on a test seed; every other episode is dev. The ``-v1`` suites'
  first 20 + 12 tasks were developed against the paper's seeds, so they are dev tasks whatever the
  seed (``docs/benchmark.md`` says what was tuned on what).
"""

from __future__ import annotations

from lerobot_policy_recent.robosuite_envs.suites import SEEDS, SUITES

TEST_SEEDS: tuple[int, ...] = SEEDS
DEV_SEEDS: tuple[int, ...] = (3, 7, 11, 19, 23)
TEST_TASKS: dict[str, tuple[str, ...]] = {
    "kinematic": (
        "kinematic/panel_then_clear",
        "kinematic/stack_zone_bin_lift",
        "kinematic/panel_peg_lid_zone",
        "kinematic/panel_then_tools",
        "kinematic/bin_plate_zone_panel",
        "kinematic/clear_then_panel",
    ),
    "end_effector": (
        "end_effector/drawer_then_box",
        "end_effector/fill_both_close",
        "end_effector/stock_and_close",
        "end_effector/open_both_then_fill",
    ),
    "kinematic-v1": (
        "kinematic/button_bin_plate",
        "kinematic/bin_push_button_plate",
        "kinematic/cube_bin_block_plate",
        "kinematic/peg_lid_button",
        "kinematic/button_then_assembly",
        "kinematic/button_wipe_drag_lift",
    ),
    "end_effector-v1": (
        "end_effector/box_drawer_routine",
        "end_effector/box_then_drawer",
        "end_effector/drawer_box_cube",
        "end_effector/open_all_then_tidy",
    ),
}
SPLITS = ("dev", "test")


def split_of(task_id: str, seed: int) -> str:
    """``test`` for a test task on a test seed, else ``dev``."""
    held_out = any(task_id in tasks for tasks in TEST_TASKS.values())
    return "test" if held_out and seed in TEST_SEEDS else "dev"


def split_table() -> dict[str, object]:
    """The split as ``recent envs list --json`` prints it: task ids per suite and split, and the seeds."""
    table: dict[str, object] = {
        suite: {
            "dev": [t.task_id for t in tasks if t.task_id not in TEST_TASKS[suite]],
            "test": list(TEST_TASKS[suite]),
        }
        for suite, tasks in SUITES.items()
    }
    table["seeds"] = {"dev": list(DEV_SEEDS), "test": list(TEST_SEEDS)}
    return table
