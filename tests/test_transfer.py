"""The transfer matrix: every cell's grounding classified, refusals named, files written and read back."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from lerobot_policy_recent.evaluation.transfer import classify, ground_cells, render_table, write_matrix


def test_cells_say_who_decided_and_why_a_robot_cannot(panda_agent, tmp_path):
    cells = ground_cells(panda_agent, ["put_in_bin", "stack_tower"], ["Panda", "Suction", "IIWAKRL"])
    at = {(c.skill, c.robot): c for c in cells}
    assert at["put_in_bin", "Panda"].grounding == "source"
    assert at["put_in_bin", "Suction"].grounding == "ontology" and at["put_in_bin", "Suction"].lm_calls == 0
    refused = at["stack_tower", "IIWAKRL"]
    assert refused.grounding == "refused" and "no primitive with the effects of place" in refused.reason
    assert not refused.defect  # the rule backend did not get it through validation
    paths = write_matrix(cells, tmp_path, {"backend": "rule"})
    data = json.loads(paths["json"].read_text())
    assert data["counts"]["refused"] == 1 and len(data["cells"]) == 6
    table = paths["md"].read_text()
    assert "| `stack_tower` | IIWAKRL | refused |" in table and paths["png"].stat().st_size > 1000


def test_a_refused_cell_the_lm_got_through_validation_is_a_defect(panda_agent):
    grounded, _ = panda_agent.ground("stack_tower", "IIWAKRL")
    forced = type(grounded)(**{**grounded.__dict__})
    forced.verdict = type(grounded.verdict)(True)
    cell = classify(forced, "FrankaHand")
    assert cell.grounding == "refused" and cell.defect
    assert "(defect)" in render_table([cell]) and "!" in render_table([cell])


def test_the_command_names_an_unknown_robot_in_one_line(tmp_path):
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "lerobot_policy_recent.scripts.cli",
            "transfer",
            "--robots",
            "Kuka",
            "--infiller.type",
            "rule",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
    )
    assert done.returncode != 0 and "--robots: unknown Kuka" in done.stderr.strip().splitlines()[-1]


def _record(task: str, robot: str, seed: int, success: bool, message: str = "") -> dict:
    """An episode record as the bench runner writes it (the fields the matrix reads)."""
    return {
        "task_id": task,
        "target": robot,
        "seed": seed,
        "success": success,
        "failure_category": None if success else "motion_planning",
        "failure_message": message,
    }


def test_each_grounded_cell_runs_beside_its_source_and_a_gap_is_listed_not_averaged():
    from lerobot_policy_recent.evaluation.transfer import Cell
    from lerobot_policy_recent.evaluation.transfer_execution import attach, execution_jobs, render_execution, summary

    cells = [
        Cell("put_in_bin", "UR5e", "ontology"),
        Cell("put_in_bin", "Suction", "ontology"),
        Cell("stack_tower", "IIWAKRL", "refused"),
    ]
    tasks = {"put_in_bin": "kinematic/cube_in_bin", "stack_tower": "end_effector/stack_tower"}
    sources = {"put_in_bin": "Panda", "stack_tower": "FrankaHand"}
    jobs = execution_jobs(cells, "recent", (3, 7), tasks, sources)
    # the source robot runs the same episodes; a refused cell runs nothing
    assert sorted({(j.target, j.seed) for j in jobs}) == [(r, s) for r in ("Panda", "Suction", "UR5e") for s in (3, 7)]
    task = "kinematic/cube_in_bin"
    records = [
        _record(task, "Panda", 3, True),
        _record(task, "Panda", 7, False, "the bin moved"),
        _record(task, "UR5e", 3, True),
        _record(task, "UR5e", 7, False, "blocked"),
        _record(task, "Suction", 3, False, "waypoint_blocked: held up by contact with bin"),
        _record(task, "Suction", 7, True),
    ]
    attach(cells, {"on": records}, tasks, sources)
    ur5e, suction = cells[0].execution["on"], cells[1].execution["on"]
    assert (ur5e.successes, ur5e.source_successes, ur5e.gaps, ur5e.at_par) == (1, 1, [], True)
    assert suction.gaps == ["seed 3: [motion_planning] waypoint_blocked: held up by contact with bin"]
    assert not cells[2].execution
    assert summary(cells) == {
        "executed": 2,
        "at_par": 2,
        "refused": 0,
        "gaps": 1,
        "refusals": 0,
    }  # 1 of 2, as the source
    table = render_execution(cells)
    assert "| `put_in_bin` | 1/2 | 1/2 |" in table
    assert "| `put_in_bin` | Suction | on | ontology | seed 3: [motion_planning]" in table


def test_an_episode_refused_as_out_of_reach_is_listed_apart_and_never_counts_as_par():
    """A target the robot cannot reach, refused by name, is not a gap; a cell that refused every
    episode its source succeeded on is refused at run time, not at par by default."""
    from lerobot_policy_recent.evaluation.transfer import Cell
    from lerobot_policy_recent.evaluation.transfer_execution import attach, render_execution, summary

    cells = [Cell("clear_into_bin", "IIWA", "ontology"), Cell("clear_into_bin", "UR5e", "ontology")]
    tasks, sources = {"clear_into_bin": "kinematic/clear_counter"}, {"clear_into_bin": "Panda"}
    task, why = "kinematic/clear_counter", "refused: motion target [-0.216, 0.006, 0.940] lies 0.34 m from the base"
    refusal = {**_record(task, "IIWA", 3, False, why), "failure_category": "unreachable_object"}
    records = [_record(task, "Panda", 3, True), refusal, _record(task, "UR5e", 3, False, "blocked")]
    attach(cells, {"off": records}, tasks, sources)
    iiwa = cells[0].execution["off"]
    assert (iiwa.gaps, iiwa.feasible_source_successes, iiwa.render()) == ([], 0, "0/1 (1 refused)")
    assert summary(cells) == {"executed": 2, "at_par": 0, "refused": 1, "gaps": 1, "refusals": 1}
    table = render_execution(cells)
    assert f"| `clear_into_bin` | IIWA | off | seed 3: [unreachable_object] {why} |" in table
    assert "| IIWA | off | 1 | 0/1 | 1/1 | 1 | 0 |" in table  # refused, not at par


@pytest.mark.slow
def test_the_command_executes_a_cell_on_ray_and_resumes(tmp_path):
    """One skill on one robot, one seed, variations off: the episodes of the cell and of its source
    run on a loopback Ray cluster; a second run finds them done and writes the same matrix."""
    command = [
        sys.executable,
        "-m",
        "lerobot_policy_recent.scripts.cli",
        "transfer",
        "--skills=press_button",
        "--robots=UR5e",
        "--infiller.type=rule",
        "--execute",
        "--seeds=3",
        "--variations=off",
        "--workers=1",
        f"--out={tmp_path}",
    ]
    first = subprocess.run(command, capture_output=True, text=True, timeout=900)
    assert first.returncode == 0, first.stderr[-2000:]
    records = sorted((tmp_path / "episodes" / "off").rglob("*__s3.json"))
    assert [p.parent.name for p in records] == ["Panda", "UR5e"]
    cell = json.loads((tmp_path / "transfer.json").read_text())["cells"][0]
    assert cell["robot"] == "UR5e" and cell["execution"]["off"]["episodes"] == 1
    assert (tmp_path / "transfer_execution.png").stat().st_size > 1000
    again = subprocess.run(command, capture_output=True, text=True, timeout=900)
    assert again.returncode == 0 and "0 episodes" not in again.stderr
    assert json.loads((tmp_path / "transfer.json").read_text())["cells"][0]["execution"] == cell["execution"]


def test_each_argument_the_lm_writes_is_scored_against_the_ontologys_rendering(ontology):
    """The paper's method asks the LM for every conflicting span: a Franka Hand stack_tower onto UR5e.
    Its first answer for the upper place puts the load on base instead of middle (rejected: the
    ontology named middle's position), its second is right; every other argument is copied right."""
    from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
    from lerobot_policy_recent.recent_plugin.infillers.base import Completion
    from lerobot_policy_recent.skills.repository import load_skill

    class Copying:
        """Writes the ontology's call, except the queued wrong answers for a place."""

        name, model = "copying", "fixed"

        def __init__(self, wrong: list[str]):
            self.wrong = wrong

        def infill(self, unit):
            call = unit.hints.substitute_call
            text = self.wrong.pop(0) if self.wrong and call.startswith("ur5_release_at") else call
            return Completion(text, generated_tokens=7, seconds=0.01)

        def count_tokens(self, text):
            return 100

    wrong = ["ur5_release_at(env, task, place_pos=task.get_object_position(base))"]
    cell = classify(
        ground_skill(load_skill("stack_tower"), ontology.target("UR5e"), ontology, Copying(wrong)), "FrankaHand"
    )
    places = [
        (d.role, d.expected, d.attempts, d.right_first, d.right) for d in cell.decisions if d.role == "release_target"
    ]
    assert places == [
        ("release_target", "the position of base", 1, True, True),
        ("release_target", "the position of middle", 2, False, True),
    ]
    assert all(d.right for d in cell.decisions) and len(cell.decisions) > len(places)
    assert "| release_target | 2 | 1 (50 %) | 2 (100 %) |" in render_table([cell])


def test_a_span_of_several_calls_is_scored_call_by_call_wherever_it_stands(ontology):
    """Spans of several lines, their later lines at the body's indentation as an LM writes them: the
    rake put back on the 2F-85, traced as three moves and an opening (each move's point its own
    decision), and the cup's move over the box before it lets go, mid-skill in fill_box. A copy of
    the rendering is right everywhere."""
    from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
    from lerobot_policy_recent.recent_plugin.infillers.base import Completion
    from lerobot_policy_recent.recent_plugin.refactoring.units import at_indent
    from lerobot_policy_recent.skills.repository import load_skill

    class Copying:
        name, model = "copying", "fixed"

        def infill(self, unit):
            text = at_indent(unit.hints.substitute_call, unit.indent)[len(unit.indent) :]
            return Completion(text, generated_tokens=7, seconds=0.01)

        def count_tokens(self, text):
            return 100

    def cell(skill, robot, source):
        grounded = ground_skill(load_skill(skill), ontology.target(robot), ontology, Copying())
        assert grounded.valid, grounded.verdict
        scored = classify(grounded, source)
        assert scored.decisions and all(d.right_first and d.right for d in scored.decisions)
        return scored

    back = [d.expected for d in cell("drag_with_tool", "Robotiq85", "Panda").decisions if d.role == "motion_target"]
    above, at = "[tool_pos[0], tool_pos[1], grip_z + 0.004 + 0.05]", "[tool_pos[0], tool_pos[1], grip_z + 0.004]"
    assert back[-3:] == [above, at, above]
    over = [d.expected for d in cell("fill_box", "Suction", "FrankaHand").decisions if d.role == "approach_object_name"]
    assert over == ["box"]


def test_an_open_receptacle_is_scored_against_where_the_plan_says_the_object_ends(ontology):
    """The README's own skill declares no placements, so on Robotiq85 the place's receptacle is the
    LM's to name. Its answer is scored against the ontology's rendering with the placements of the
    subtask's reference skill (the bundled put_in_bin: obj ends over receptacle)."""
    from pathlib import Path

    from doubles import ScriptedInfiller

    from lerobot_policy_recent.evaluation.transfer import answer_key, reference_placements
    from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
    from lerobot_policy_recent.recent_plugin.infillers.fast_path import FastPathInfiller
    from lerobot_policy_recent.skills.repository import serve_skill

    mine = serve_skill("put_in_bin", Path(__file__).parents[1] / "examples" / "skills")
    place = "place_robotiq85(env, task, obj_name={}, pointing_to='down')"
    lm = ScriptedInfiller([place.format("obj"), place.format("receptacle")])
    grounded = ground_skill(mine, ontology.target("Robotiq85"), ontology, FastPathInfiller(lm))
    assert reference_placements()["put_in_bin"] == {"obj": "receptacle"}
    cell = classify(grounded, "Panda", answer_key(ontology, mine, "Robotiq85", reference_placements()))
    assert cell.grounding == "lm"
    assert [(d.role, d.expected, d.attempts, d.right_first, d.right) for d in cell.decisions] == [
        ("release_receptacle", "receptacle", 2, False, True),
        ("approach_direction", "'down'", 2, True, True),
    ]
    assert classify(grounded, "Panda").decisions == []  # without the key, nothing says what is right


def test_bad_execution_options_are_named_before_anything_is_grounded(tmp_path):
    base = [sys.executable, "-m", "lerobot_policy_recent.scripts.cli", "transfer", "--execute", f"--out={tmp_path}"]
    for option, message in (
        ("--seeds=3,x", "--seeds: expected a comma list of integers"),
        ("--variations=bogus", "--variations: unknown variation(s) bogus"),
    ):
        done = subprocess.run([*base, option, "--infiller.type=rule"], capture_output=True, text=True)
        assert done.returncode != 0 and done.stderr.strip().splitlines()[-1].startswith(message)
    assert not (tmp_path / "transfer.json").exists()  # nothing grounded, nothing written
