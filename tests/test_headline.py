"""``recent bench headline``: the README's table, test split only, with a caption taken from the records."""

from __future__ import annotations

import gzip
import json

from lerobot_policy_recent.evaluation.runner import PACKED
from lerobot_policy_recent.scripts.cli import main

TASK = (
    "kinematic/panel_peg_lid_zone"  # a test task until 2026-11-28: 24 primitive calls, so 48 LM calls at two per call
)
OUTCOMES = {"recent": (True, True), "oracle-rule": (True, False), "cap": (False, False)}  # (UR5e, Sawyer)


def _record(method: str, target: str, success: bool, *, seed: int = 0, commit: str = "a" * 40) -> dict:
    rule = method == "oracle-rule"
    return {
        "method": method,
        "suite": "kinematic",
        "task_id": TASK,
        "target": target,
        "seed": seed,
        "split": "test" if seed == 0 else "dev",
        "success": success,
        "gc": 1.0 if success else 0.25,
        "subtasks": 4,
        "go": 0.0 if rule else 10.0,
        "go_pre": 0.0 if rule else 80.0,
        "ei": 0 if rule else 1,
        "it": 0.0 if rule else 5.0,
        "igt": 1.0,
        "patches": 1,
        "lm_calls": 0 if rule else (48 if method == "cap" else 20),  # cap's loop ran until the 48-call budget was spent
        "backend": "rule" if rule else "llamacpp",
        "model": "ontology-substitution" if rule else "qwen2.5-coder-1.5b-instruct-q4_k_m.gguf",
        "rule_coverage": 75.0 if method == "recent" else None,
        "commit": commit,
    }


def _run_dir(tmp_path, records: list[dict]):
    with gzip.open(tmp_path / PACKED, "wt") as f:
        f.writelines(json.dumps(r) + "\n" for r in records)
    header = {
        "date": "2026-11-26T18:47:12+00:00",
        "config": {"max_lm_calls": 24, "temperature": 0.2},
        "machine": {"cpu": "AMD EPYC", "cores": 2},
        "engine": "ray",
        "workers": 1,
        "cpus_per_worker": 2.0,
        "gpus_per_worker": 0.0,
        "variations": "on",
    }
    (tmp_path / "results.json").write_text(json.dumps({**header, "runs": [header]}))
    return tmp_path


def test_the_headline_is_the_test_split_with_a_caption_of_what_the_records_say_was_run(tmp_path, capsys):
    records = [_record(m, t, ok) for m, oks in OUTCOMES.items() for t, ok in zip(("UR5e", "Sawyer"), oks, strict=True)]
    records.append(_record("recent", "UR5e", False, seed=3))  # a dev episode: counted in the caption, in no cell
    assert main(["bench", "headline", str(_run_dir(tmp_path, records))]) == 0
    text = (tmp_path / "headline.md").read_text()
    assert text.strip() in capsys.readouterr().out  # printed as written
    rows = {line.split(" | ")[0]: line for line in text.splitlines() if line.startswith("| `")}
    assert list(rows) == ["| `recent`", "| `cap`", "| `oracle-rule`"]  # the table's order; the no-LM floor is a row
    assert rows["| `recent`"].startswith("| `recent` | 2 / 2 [100, 100] | 100.0 [100, 100] | – | – | – |")
    assert "| 1 / 2 [0, 100] | 62.5 [25, 100] | – | – | +50 [+0, +100] |" in rows["| `oracle-rule`"]  # paired
    assert "| 10.0 / – | 80.0 / – | 1.00 / – | 5.0 / – |" in rows["| `cap`"]  # GO beside GO-pre, per setting
    assert "| *reference: the paper's `recent` (7B)* | *73.0 %* | *81.8* |" in text  # labelled, not a target
    # every row of the paper's table shows: the ones that did not run here say so
    assert "| *reference: the paper's `cap-llm` (GPT-5.2-Codex), not run here* | *67.5 %* |" in text
    assert "| *reference: the paper's `cap` (7B)* |" in text and "`cap` (7B), not run here" not in text
    caption = text.split("Caption: ", 1)[1]
    for fact in (
        "held-out **test** split",
        "kinematic: 1 test task (test when run; dev since 2026-11-28: run during development), on Sawyer and UR5e: "
        "`panel_peg_lid_zone` (24)",
        "2 episodes per method",
        "seeds [0]; variations on",
        "the same for every method: 48 (the larger of 24 and two per primitive call of the task)",
        "used per episode: `cap` 48 (mean 48.0; budget spent in 2/2), `oracle-rule` 0 (mean 0.0; budget spent in "
        "0/2), `recent` 20 (mean 20.0; budget spent in 0/2)",
        "Model: qwen2.5-coder-1.5b-instruct-q4_k_m.gguf via llamacpp; `oracle-rule`: ontology-substitution via rule",
        "seeded sampling at temperature 0.2",
        "AMD EPYC, 2 cores",
        "every episode ran at commit `aaaaaaa`, clean; 2026-11-26",
        "Dev-split episodes in the same directory: 1",
        "RECENT's rule coverage",
    ):
        assert fact in caption, fact


def test_a_headline_of_several_commits_says_so_and_one_without_test_episodes_is_refused(tmp_path, capsys):
    records = [_record("recent", "UR5e", True), _record("cap", "UR5e", False, commit="b" * 40 + "+dirty")]
    assert main(["bench", "headline", str(_run_dir(tmp_path, records))]) == 0
    text = (tmp_path / "headline.md").read_text()
    assert "NOT one clean commit: aaaaaaa (1), bbbbbbb+dirty (1)" in text
    assert "1 episode per method, every method on the same episodes" in text
    (tmp_path / PACKED).unlink()
    _run_dir(tmp_path, [*records, _record("recent", "Sawyer", True)])  # a run stopped part way: cap lacks one
    assert main(["bench", "headline", str(tmp_path)]) == 0
    assert (
        "except where one lacks some (`cap` 1): RECENT − method uses the shared ones"
        in (tmp_path / "headline.md").read_text()
    )
    dev_only = tmp_path / "dev"
    dev_only.mkdir()
    assert main(["bench", "headline", str(_run_dir(dev_only, [_record("recent", "UR5e", True, seed=3)]))]) == 2
    assert "no test-split episodes to make a headline of" in capsys.readouterr().err
