"""What the whole-program methods wrote, counted from the recorded prompts and answers (report.md)."""

from __future__ import annotations

import gzip
import json

from lerobot_policy_recent.evaluation.baselines.program_prompt import PROGRAM
from lerobot_policy_recent.evaluation.programs import called_names, program_counts
from lerobot_policy_recent.evaluation.report.document import render_report
from lerobot_policy_recent.evaluation.runner import LM_CALLS, PACKED

RIGHT = "obj_pos = task.get_object_position(obj)\n    ur5_grasp_at(env, task, grasp_pos=obj_pos)\n    n = len(obj_pos)"
COPIED = "open_gripper(env, task)\n    ur5_grasp_at(env, task, grasp_pos=task.get_object_position(obj))"
INVENTED = "ur5_pick(env, task, obj)"  # neither robot has it
CUT = "ur5_grasp_at(env, task, grasp_pos=[obj_pos[0], obj_pos["  # stopped at the token budget


def _program(method: str, completion: str, seed: int = 0, skill: str = "put_in_bin") -> dict:
    return {
        "method": method,
        "task_id": "kinematic/cube_in_bin",
        "robot": "UR5e",
        "seed": seed,
        "skill": skill,
        "event": "infill_call",
        "span_type": PROGRAM,
        "completion": completion,
    }


def test_a_programs_calls_are_read_as_python_reads_them():
    assert called_names(RIGHT) == ["ur5_grasp_at", "len"]  # task.get_object_position is a scene query
    assert called_names("def helper():\n        pass\n    helper()\n    go(env)") == ["go"]  # its own helper
    assert called_names(CUT) is None


def test_programs_are_counted_per_method_by_what_they_call_and_whether_they_repeat():
    rows = [
        _program("cap", COPIED),
        _program("cap", COPIED),  # regenerated, the same calls again
        _program("cap", RIGHT),
        _program("cap", CUT, seed=1),
        _program("cap", INVENTED, seed=2),
        _program("progprompt", RIGHT),
        {**_program("recent", COPIED), "span_type": "api_substitution"},  # RECENT edits spans: not a program
        {**_program("cap", COPIED), "event": "validation_verdict"},
    ]
    cap, progprompt = program_counts(rows)
    assert (cap.method, cap.programs, cap.unparsable, cap.foreign, cap.copied) == ("cap", 5, 1, 3, 2)
    assert (cap.regenerations, cap.repeated) == (2, 1)  # the second COPIED repeats; RIGHT does not
    assert (progprompt.programs, progprompt.foreign, progprompt.regenerations) == (1, 0, 0)


def test_the_report_says_what_the_programs_called_from_the_packed_prompts(tmp_path):
    record = {
        "method": "cap",
        "suite": "kinematic",
        "task_id": "kinematic/cube_in_bin",
        "target": "UR5e",
        "seed": 0,
        "success": False,
        "gc": 0.0,
        "subtasks": 1,
        "failure_category": "hallucinated_api",
    }
    with gzip.open(tmp_path / PACKED, "wt") as f:
        f.write(json.dumps(record) + "\n")
    with gzip.open(tmp_path / LM_CALLS, "wt") as f:
        f.writelines(
            json.dumps({**_program("cap", text), "order": i}) + "\n" for i, text in enumerate([COPIED, COPIED])
        )
    report = render_report([tmp_path], tmp_path).read_text()
    assert "## What the whole programs called" in report
    assert "| cap | 2 | 0 (0 %) | 2 (100 %) | 2 (100 %) | 1 | 1 of 1 |" in report


def test_a_run_with_test_and_dev_episodes_reports_the_test_split_and_keeps_dev_apart(tmp_path):
    """RECENT on test and dev, a baseline on test only: pooling dev into RECENT's row would compare two task sets."""

    def episode(method: str, task: str, seed: int, success: bool) -> dict:
        return {
            "method": method,
            "suite": "kinematic",
            "task_id": f"kinematic/{task}",
            "target": "UR5e",
            "seed": seed,
            "success": success,
            "gc": float(success),
            "subtasks": 3,
            "failure_category": None if success else "motion_planning",
            # the split as recorded when it ran: panel_then_clear was a test task until 2026-11-28
            "split": "test" if (task, seed) == ("panel_then_clear", 0) else "dev",
        }

    records = [
        episode("recent", "panel_then_clear", 0, True),  # a test task on a test seed
        episode("recent", "serve_then_clear", 3, False),  # dev
        episode("recent", "panel_then_clear", 3, False),  # a test task on a dev seed is dev too
        episode("cap", "panel_then_clear", 0, False),
    ]
    with gzip.open(tmp_path / PACKED, "wt") as f:
        f.writelines(json.dumps(r) + "\n" for r in records)
    report = render_report([tmp_path], tmp_path).read_text()
    assert "4 episodes from" in report and "Figures: the 2 test-split episodes; the 2 dev ones are apart." in report
    main = report.split("## Main table")[1].split("##")[0]
    assert "| **recent** | 100.0 [100.0, 100.0] |" in main  # test alone, not 1 of 3
    apart = report.split("## Held-out test split and dev, apart")[1].split("##")[0]
    assert "| recent | kinematic | 1 | 100.0 [100.0, 100.0] | 100.0 [100.0, 100.0] | 2 | 0.0 [0.0, 0.0] |" in apart
    assert "## Dev split, apart (2 episodes)" in report
