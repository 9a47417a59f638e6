"""The held-out split: which episodes the benchmark reports as *test*, and which may be used for fixes.

* **The test tasks are one draw** of ``recent envs compose`` per family (kinematic, end-effector):
  compositions nobody has run. The draw's seed is fixed here only when the code for a snapshot is
  frozen, and recorded with the run; until then it is ``None`` and no episode is a test episode.
* **Test seeds** are the paper's five (0, 1, 42, 123, 2024); **dev seeds** are others.
* A test episode is a test-draw task on a test seed; every other episode is dev. A fix motivated by a
  test episode means a new test draw next time.
* The suites' own tasks are all dev. Until 2026-11-28 ten of them, and six + four of the ``-v1``
  suites', were the test tasks (``RETIRED_TEST_TASKS``): they were run on dev seeds as the acceptance
  slice of commits and three fixes came from their records, and a composition seen on any seed has
  been seen (issue 59). ``docs/benchmark.md`` says what was tuned on what.
"""

from __future__ import annotations

from lerobot_policy_recent.robosuite_envs.suites import SEEDS, SUITES

TEST_SEEDS: tuple[int, ...] = SEEDS
DEV_SEEDS: tuple[int, ...] = (3, 7, 11, 19, 23)
# the test draw's seed per family: None until the code for a snapshot is frozen (then: a seed no dev
# draw used, recorded in the run's results.json); its tasks are ``{family}/draw{seed}_NN``
TEST_DRAW: dict[str, int | None] = {"kinematic": None, "end_effector": None}
RETIRED_TEST_TASKS: dict[str, tuple[str, ...]] = {  # dev since 2026-11-28 (above)
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


def test_draw_prefix(family: str) -> str | None:
    """How the test draw's task ids begin (``kinematic/draw{seed}_``), or None while no draw is fixed."""
    seed = TEST_DRAW.get(family.removesuffix("-v1"))
    return None if seed is None else f"{family.removesuffix('-v1')}/draw{seed}_"


def is_test_task(task_id: str) -> bool:
    prefix = test_draw_prefix(task_id.split("/", 1)[0])
    return prefix is not None and task_id.startswith(prefix)


def split_of(task_id: str, seed: int) -> str:
    """``test`` for a task of the fixed test draw on a test seed, else ``dev``."""
    return "test" if is_test_task(task_id) and seed in TEST_SEEDS else "dev"


def no_test_split() -> str | None:
    """Why there are no test episodes yet (no test draw fixed), or None once there may be."""
    if any(seed is not None for seed in TEST_DRAW.values()):
        return None
    return (
        "no test draw is fixed yet (robosuite_envs/splits.py TEST_DRAW): the test split is drawn when the "
        "code for a snapshot is frozen; every episode before that is dev"
    )


def split_table() -> dict[str, object]:
    """The split as ``recent envs list --json`` prints it: task ids per suite and split, and the seeds."""
    table: dict[str, object] = {
        suite: {
            "dev": [t.task_id for t in tasks if not is_test_task(t.task_id)],
            "test": [t.task_id for t in tasks if is_test_task(t.task_id)],
            "retired_test": list(RETIRED_TEST_TASKS.get(suite, ())),
        }
        for suite, tasks in SUITES.items()
    }
    table["seeds"] = {"dev": list(DEV_SEEDS), "test": list(TEST_SEEDS)}
    table["test_draw"] = dict(TEST_DRAW)
    return table
