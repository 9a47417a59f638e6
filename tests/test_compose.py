"""``recent envs compose``: seeded draws of new tasks over the subtask grammar and the suites' scenes."""

from __future__ import annotations

import json

import pytest

from lerobot_policy_recent.robosuite_envs.compose import LENGTHS, PAPER_CALLS, draw, plan_key
from lerobot_policy_recent.robosuite_envs.subtasks import SUBTASKS
from lerobot_policy_recent.robosuite_envs.suites import SUITES
from lerobot_policy_recent.scripts.cli import main
from lerobot_policy_recent.skills.repository import task_calls


def calls(spec) -> int:
    return task_calls([s.skill for s in spec.plan]).primitives


@pytest.mark.parametrize("family", ["kinematic", "end_effector"])
@pytest.mark.parametrize("seed", [101, 102, 103])
def test_a_dev_draw_meets_the_papers_constraints_and_repeats_no_suite_task(seed, family):
    tasks = draw(family, seed, 6, calls)
    assert [t.task_id for t in tasks] == [f"{family}/draw{seed}_{i:02d}" for i in range(6)]
    assert all(LENGTHS[0] <= len(t.plan) <= LENGTHS[-1] for t in tasks)
    assert sum(calls(t) for t in tasks) / len(tasks) >= PAPER_CALLS[family]
    family = {s.category for s in SUBTASKS.values() if s.family == family}
    assert {SUBTASKS[s.subtask].category for t in tasks for s in t.plan} == family
    known = {plan_key(t.plan) for suite in SUITES.values() for t in suite}
    assert not {plan_key(t.plan) for t in tasks} & known and len({plan_key(t.plan) for t in tasks}) == 6
    for t in tasks:  # every argument is an object of the task's scene, and a pick-and-lift ends the plan
        assert {v for s in t.plan for v in s.args.values()} <= set(t.object_names())
        assert "pick_and_lift" not in [s.subtask for s in t.plan[:-1]]


def test_a_seed_names_one_draw():
    first, again, other = (draw("kinematic", s, 6, calls) for s in (7, 7, 8))
    assert [plan_key(t.plan) for t in first] == [plan_key(t.plan) for t in again]
    assert [plan_key(t.plan) for t in first] != [plan_key(t.plan) for t in other]


def test_a_tower_is_taken_down_into_the_row_from_its_top():
    """The pen-and-row chain that holds the end-effector family's scene rearrangement and tool use: a
    tower, taken down top first into the row, then two of its blocks swept into the pen."""
    (pen,) = [t for t in draw("end_effector", 101, 6, calls) if "pen" in t.object_names()]
    stack, arrange, sweep = pen.plan
    assert (stack.subtask, arrange.subtask, sweep.subtask) == ("stack_tower", "arrange_in_row", "sweep_into_pen")
    assert [arrange.args[k] for k in ("first", "second", "third")] == [stack.args[k] for k in ("top", "middle", "base")]
    assert stack.args["base"] == "green"  # the widest block: a tower narrows upwards


def test_a_family_whose_scenes_cannot_hold_all_its_categories_says_which(monkeypatch):
    from lerobot_policy_recent.robosuite_envs import compose

    pantry_only = compose.scenes("end_effector")[:1]
    monkeypatch.setattr(compose, "scenes", lambda family: pantry_only)
    with pytest.raises(ValueError, match="scene rearrangement, tool use: a draw cannot hold all four"):
        draw("end_effector", 5, 4, calls)
    with pytest.raises(SystemExit, match="no end_effector scene chains"):
        main(["envs", "compose", "--seed", "5", "--family", "end_effector"])


def test_the_command_prints_a_draw(capsys):
    assert main(["envs", "compose", "--seed", "101", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["seed"] == 101 and len(out["tasks"]) == 6 and out["mean_calls"] >= 24.6
    assert out["tasks"][0]["plan"][0]["subtask"] in SUBTASKS


def test_a_draw_file_makes_its_tasks_runnable_and_a_bad_one_is_named(tmp_path, monkeypatch, capsys):
    from lerobot_policy_recent.robosuite_envs.suites import TASKS_ENV, get_task, tasks

    path = tmp_path / "draw.json"
    assert main(["envs", "compose", "--seed", "101", "--out", str(path)]) == 0
    monkeypatch.setenv(TASKS_ENV, str(path))
    tasks.cache_clear()
    try:
        drawn = get_task("kinematic/draw101_03")
        assert drawn.plan == draw("kinematic", 101, 6, calls)[3].plan and "bin" in drawn.object_names()
        from lerobot_policy_recent.evaluation.jobs import BenchConfig

        jobs = BenchConfig(out=tmp_path, tasks=("draw101_03",), targets=("UR5e",), seeds=(3,)).jobs()
        assert [(j.suite, j.task_id) for j in jobs] == [("kinematic", "kinematic/draw101_03")]  # recent bench runs it
        data = json.loads(path.read_text())
        data["tasks"][1]["plan"][0]["subtask"] = "juggle"
        path.write_text(json.dumps(data))
        tasks.cache_clear()
        with pytest.raises(ValueError, match=rf"{path}: tasks\[1\]\.plan\[0\]\.subtask: unknown subtask 'juggle'"):
            get_task("kinematic/draw101_03")
    finally:
        monkeypatch.delenv(TASKS_ENV)
        tasks.cache_clear()


@pytest.mark.slow
@pytest.mark.parametrize("family", ["kinematic", "end_effector"])
def test_every_task_of_a_dev_draw_is_checked_on_its_source_robot(capsys, family):
    """Feasibility is a simulation run: the source robot's reference skills, variations off, one dev seed."""
    assert main(["envs", "compose", "--seed", "101", "--family", family, "--check", "3", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["tasks"]
    assert [row["check"] for row in rows] == ["ok"] * 6
