"""``recent bench``: records per episode, resumable runs, results.json, the paper's metrics, the report."""

from __future__ import annotations

import json

import pytest

from lerobot_policy_recent.evaluation.methods import parse_methods
from lerobot_policy_recent.evaluation.metrics import seed_metrics, summarize
from lerobot_policy_recent.evaluation.runner import load_records
from lerobot_policy_recent.scripts.cli import main

RUN = [
    "bench",
    "--suite=kinematic-v1",
    "--tasks=cube_on_plate",
    "--target=UR5e",
    "--method=recent,recent-no-insitu",
    "--seeds=0,1",
    "--variations=on",
    "--infiller.type=rule",
    "--log-sinks=mcap,dataset",
]


@pytest.fixture(scope="module")
def bench_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    assert main([*RUN, f"--out={out}"]) == 0
    return out


def test_every_episode_has_a_record_and_results_json_aggregates_them(bench_dir):
    records = load_records(bench_dir)
    assert sorted((r["method"], r["seed"]) for r in records) == [
        ("recent", 0),
        ("recent", 1),
        ("recent-no-insitu", 0),
        ("recent-no-insitu", 1),
    ]
    for r in records:
        assert {"success", "gc", "go", "go_pre", "ei", "it", "igt", "igt_cold", "failure_category", "model"} <= r.keys()
        assert r["go"] == pytest.approx(100 * r["adaptation_tokens"] / r["skill_tokens"], abs=1e-3)
        assert r["log_dir"] == str(bench_dir / "logs") and (bench_dir / "logs" / "mcap").is_dir()
        assert r["worker_niceness"] == 0  # a local instance's episodes run below nothing of the run's own
    results = json.loads((bench_dir / "results.json").read_text())
    assert results["backend"] == "rule" and results["seeds"] == [0, 1] and results["machine"]["cores"]
    assert results["test_draw"] == {"kinematic": None, "end_effector": None}  # the split in force: all dev
    assert results["command"].startswith("recent bench") and results["runs"][-1]["command"] == results["command"]
    setting = results["by_setting"]["recent|kinematic-v1"]
    assert setting["episodes"] == 2 and set(setting) >= {"sr", "gc", "go", "ei", "it", "igt"}
    assert setting["sr_ci95"] == [100.0, 100.0] and "gc_ci95" in setting
    assert results["paired"]["recent vs recent-no-insitu|kinematic-v1"]["sr_diff"] == 100.0
    assert results["engine"] == "ray" and results["workers"] >= 1 and results["model_sha256"] is None  # rule: no model
    assert "recent|UR5e|kinematic/cube_on_plate" in results["by_task"]
    assert all(r["split"] == "dev" for r in records) and set(results["by_split"]) == {
        "recent|kinematic-v1|dev",
        "recent-no-insitu|kinematic-v1|dev",
    }
    from lerobot_policy_recent.logs.readers import dataset_lengths

    lengths = dataset_lengths(bench_dir / "logs" / "dataset")  # one dataset for the whole run
    assert lengths == {r["log_episode"]: r["steps"] for r in records}


def test_in_situ_adaptation_is_what_saves_the_obstacle_episodes(bench_dir):
    """With variations on, a slab lands on the plate: RECENT sweeps it off, the ablation cannot."""
    by = {(r["method"], r["seed"]): r for r in load_records(bench_dir)}
    assert all(by[("recent", s)]["success"] for s in (0, 1))
    assert not any(by[("recent-no-insitu", s)]["success"] for s in (0, 1))
    assert all(by[("recent", s)]["ei"] >= 1 for s in (0, 1))


def test_a_restarted_run_skips_finished_episodes(bench_dir, capsys):
    before = {p: p.stat().st_mtime_ns for p in (bench_dir / "episodes").rglob("*.json")}
    assert main([*RUN, f"--out={bench_dir}"]) == 0
    assert "4 episodes (4 already done)" in capsys.readouterr().err
    assert {p: p.stat().st_mtime_ns for p in (bench_dir / "episodes").rglob("*.json")} == before


def test_a_rerun_is_compared_episode_by_episode_with_the_run_it_reproduces(bench_dir, tmp_path, capsys):
    """Seeded physics, deterministic infilling: a re-run of one episode has the same outcome, and
    a record that differs is named with the field that changed (exit status 1)."""
    rerun = tmp_path / "rerun"
    assert main([*RUN, "--method=recent", "--seeds=1", "--no-log", f"--out={rerun}"]) == 0
    capsys.readouterr()
    assert main(["bench", "compare", str(bench_dir), str(rerun)]) == 3  # 1 of 4 episodes: not "reproduced"
    text = capsys.readouterr().out
    assert "**Verdict: partial.** 1 of 1 shared episodes reproduced" in text and "(25.0 %; at least 100 %" in text
    assert "Reference episodes the re-run lacks (3):" in text and "- recent-no-insitu kinematic-v1 UR5e" in text
    assert main(["bench", "compare", str(bench_dir), str(rerun), "--min-coverage=0.25"]) == 0
    assert "**Verdict: reproduced.**" in capsys.readouterr().out

    record = next((rerun / "episodes").rglob("*.json"))
    tampered = {**json.loads(record.read_text()), "steps": 1, "success": False}
    record.write_text(json.dumps(tampered))
    assert main(["bench", "compare", str(bench_dir), str(rerun), "--min-coverage=0.25"]) == 1
    text = capsys.readouterr().out
    assert "0 of 1 shared episodes reproduced" in text
    assert "| recent | kinematic-v1 | UR5e | kinematic/cube_on_plate | 1 | success: True → False; steps:" in text

    assert main(["bench", "compare", str(bench_dir), str(tmp_path / "nowhere")]) == 2  # named, not a traceback


def test_report_renders_tables_checks_and_plots(bench_dir, tmp_path, capsys):
    assert main(["bench", "report", str(bench_dir), "--out", str(tmp_path)]) == 0
    report = (tmp_path / "report.md").read_text()
    assert "| **recent** | 100.0 ± 0.0 [100.0, 100.0] |" in report  # main table: SR ± std over seeds [95 % CI]
    assert "| recent vs recent-no-insitu | kinematic-v1 | 2 | +100.0 [+100.0, +100.0] |" in report  # paired
    assert "| paper: recent (7B) | 73.00 | 81.76 | 7.85 | 0.72 | 1.77 |" in report
    assert "| **recent-no-insitu** | 0.0 ± 0.0 [0.0, 0.0] |" in report  # ablation table
    assert "- `recent-no-insitu`: SR (%) expected lower: -100.00 ✓" in report
    # the rule backend has no LM: the paper's targets are listed with their values, never ticked
    assert "not checked against the paper's targets: the rule backend has no LM" in report
    assert "- kinematic-v1: SR" not in report  # the paper's targets are for the paper-length suites only
    assert "| episode: motion_planning |" in report  # failure categories per method (a place held up by the obstacle)
    # failures no check noticed: the ablation's episodes that ended with a subtask unmet and nothing raised
    ablation = [r for r in load_records(bench_dir) if r["method"] == "recent-no-insitu"]
    silent = sum(r["failure_category"] == "subtask_failed" for r in ablation)
    assert f"| recent-no-insitu | 2 | {silent} | {100 * silent / 2:.0f} % |" in report
    assert "No held-out test episode in these runs: every number above is a dev number." in report
    assert "![RECENT against each method](paired.png)" in report  # the paired differences, drawn
    for png in ("sr_vs_go.png", "failures_by_method.png", "paired.png"):
        assert (tmp_path / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_metrics_follow_the_papers_definitions():
    records = [
        # seed 0: one task of 2 subtasks fully done, one task of 3 subtasks with 1 done
        {"seed": 0, "success": True, "gc": 1.0, "subtasks": 2, "go": 10.0, "ei": 1, "it": 2.0, "igt_cold": 1.0},
        {"seed": 0, "success": False, "gc": 1 / 3, "subtasks": 3, "go": 30.0, "ei": 3, "it": 4.0, "igt_cold": 3.0},
        # seed 1: both tasks done
        {"seed": 1, "success": True, "gc": 1.0, "subtasks": 2, "go": 10.0, "ei": 0, "it": 0.0, "igt_cold": 1.0},
        {"seed": 1, "success": True, "gc": 1.0, "subtasks": 3, "go": 10.0, "ei": 0, "it": 0.0, "igt_cold": 1.0},
    ]
    s0 = seed_metrics(records[:2])
    assert s0["sr"] == 50.0 and s0["gc"] == pytest.approx(60.0)  # GC weights subtasks: 3 of 5
    assert s0["go"] == 20.0 and s0["ei"] == 2.0 and s0["it"] == 3.0 and s0["igt"] == 2.0
    summary = summarize(records)
    assert summary["sr"] == {"mean": 75.0, "std": 25.0}
    assert summary["gc"]["mean"] == pytest.approx(80.0) and summary["ei"] == {"mean": 1.0, "std": 1.0}


def test_a_run_can_take_only_the_held_out_split_and_records_say_which_split(monkeypatch):
    from lerobot_policy_recent.evaluation.jobs import BenchConfig
    from lerobot_policy_recent.robosuite_envs import splits

    with pytest.raises(ValueError, match="--split test: no test draw is fixed yet"):
        BenchConfig(out="/tmp/x", suites=("end_effector",), split="test").jobs()
    retired = set(splits.RETIRED_TEST_TASKS["end_effector"])
    dev = BenchConfig(out="/tmp/x", suites=("end_effector",), seeds=(3, *splits.TEST_SEEDS), split="dev").jobs()
    assert {j.task_id for j in dev} >= retired and {j.seed for j in dev} == {3, *splits.TEST_SEEDS}
    monkeypatch.setitem(splits.TEST_DRAW, "end_effector", 90210)  # a draw fixed, none of whose tasks is listed
    everything = BenchConfig(out="/tmp/x", suites=("end_effector",), seeds=(3, *splits.TEST_SEEDS)).jobs()
    assert BenchConfig(out="/tmp/x", suites=("end_effector",), seeds=(3, *splits.TEST_SEEDS), split="test").jobs() == []
    assert sorted(dev, key=str) == sorted(everything, key=str)
    with pytest.raises(ValueError, match="unknown split 'val'"):
        BenchConfig(out="/tmp/x", split="val").jobs()
    with pytest.raises(ValueError, match="they are in --suite kinematic-v1"):  # an earlier suite's task, named
        BenchConfig(out="/tmp/x", suites=("kinematic",), tasks=("cube_on_plate",)).jobs()


def test_a_run_goes_episode_by_episode_so_a_stopped_one_has_every_method_on_the_same_episodes():
    from lerobot_policy_recent.evaluation.jobs import BenchConfig

    methods = ("recent", "cap", "oracle-rule")
    jobs = BenchConfig(out="/tmp/x", suites=("end_effector",), methods=methods, seeds=(0, 1)).jobs()
    for start in range(0, len(jobs), len(methods)):  # stopped after any whole episode: all methods ran it
        episode = jobs[start : start + len(methods)]
        assert tuple(j.method for j in episode) == methods
        assert len({(j.task_id, j.target, j.seed) for j in episode}) == 1
    assert len(set(jobs)) == len(jobs)


def test_unknown_methods_and_tasks_are_named():
    assert parse_methods("all")[0] == "recent" and "cap" in parse_methods("all")
    with pytest.raises(ValueError, match="unknown method.*capp"):
        parse_methods("recent,capp")
    assert main(["bench", "--tasks=nope", "--infiller.type=rule", "--out=/tmp/never"]) == 2


@pytest.mark.slow
def test_parallel_workers_write_the_same_records_and_one_dataset(tmp_path):
    """Two workers run episodes at once; the driver alone writes their logs: one dataset for the run."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from lerobot_policy_recent.logs.layout import LogLayout
    from lerobot_policy_recent.logs.readers import read_table
    from lerobot_policy_recent.logs.verify import verify

    out = tmp_path / "parallel"
    assert main([*RUN, "--method=recent", f"--out={out}", "--workers=2", "--log-sinks=mcap,rerun,dataset"]) == 0
    records = load_records(out)
    assert len(records) == 2 and all(r["success"] for r in records)
    layout = LogLayout(out / "logs")
    assert sorted(r["log_episode"] for r in records) == layout.committed() == [0, 1]
    for r in records:  # each record names its episode in the run's logs
        row = read_table(layout.results(r["log_episode"]))[0]
        assert (row["task_id"], row["seed"], row["method"]) == (r["task_id"], r["seed"], "recent")
    dataset = LeRobotDataset("local/recent_episodes", root=layout.dataset_dir, video_backend="pyav")
    assert dataset.num_episodes == 2 and dataset.num_frames == sum(r["steps"] for r in records)
    assert verify(layout.root).ok


def test_the_headline_targets_are_checked_for_recent_and_its_fast_path():
    """The fast path renders what a check or the ontology decides: no tokens, so its GO against cap's reads as 0."""
    from lerobot_policy_recent.evaluation.report.tables import target_checks

    def record(method: str, go: float, success: bool, ei: int, it: float, patches: int | None = None) -> dict:
        r = {"method": method, "suite": "kinematic", "seed": 0, "success": success, "go": go, "ei": ei, "it": it}
        return r if patches is None else {**r, "patches": patches}

    records = [record("recent", 8.0, True, 1, 2.4), record("recent+fast-path", 0.0, True, 0, 0.0, patches=1)]
    records.append(record("cap", 200.0, False, 3, 20.0))
    lines = target_checks(records)
    assert "- kinematic: GO 8.00% (target ≤ 5.0%) ✗" in lines
    assert "- kinematic (recent+fast-path): GO 0.00% (target ≤ 5.0%) ✓" in lines
    assert "- kinematic (recent+fast-path): IT 0.00 s (target ≤ 2.0 s) ✓" in lines
    # a sanity row that cannot run on some target leaves the check standing; a crash of RECENT does not
    sanity_crash = {"method": "cap-target-example", "suite": "kinematic", "error": "ValueError: no reference"}
    assert target_checks(records, crashed=[sanity_crash]) == lines
    unchecked = target_checks(records, crashed=[{**sanity_crash, "method": "recent"}])
    assert unchecked[0].startswith("- not checked against the paper's targets: 1 episode(s) of a checked row crashed")
    assert "- kinematic: GO 8.00% (target ≤ 5.0%) (not checked)" in unchecked
    # EI counts the LM's calls; the patch the fast path rendered is named beside it, not hidden
    assert (
        "- kinematic (recent+fast-path): EI 0.00 (target ≤ 0.7) ✓ "
        "(LM calls; 1.00 run-time patches per task, 1.00 of them rendered)" in lines
    )
    assert "- kinematic: EI 1.00 (target ≤ 0.7) ✗" in lines  # older records: every patch call was in EI
    assert any(
        "(recent+fast-path): margin over cap +100.0 pp SR" in line and "GO 0 against cap's 200.0%" in line
        for line in lines
    )


def test_a_packed_run_reads_resumes_and_compares_as_the_files_did(bench_dir, tmp_path, capsys):
    import shutil

    packed = tmp_path / "packed"
    shutil.copytree(bench_dir, packed, ignore=shutil.ignore_patterns("logs"))
    assert main(["bench", "pack", str(packed)]) == 0
    assert not (packed / "episodes").exists() and (packed / "episodes.jsonl.gz").is_file()
    key = lambda r: (r["method"], r["seed"])  # noqa: E731
    assert sorted(load_records(packed), key=key) == sorted(load_records(bench_dir), key=key)
    assert main([*RUN, f"--out={packed}"]) == 0
    assert "4 episodes (4 already done)" in capsys.readouterr().err
    assert main(["bench", "compare", str(bench_dir), str(packed)]) == 0  # every episode: reproduced
    assert main(["bench", "pack", str(tmp_path / "nowhere")]) == 2


def test_a_packed_run_keeps_what_each_lm_was_asked_and_answered(bench_dir, tmp_path, capsys):
    """A reviewer reads why a program failed without the logs: prompts, answers and verdicts per episode."""
    import gzip
    import json
    import shutil

    from lerobot_policy_recent.evaluation.runner import LM_CALLS, LM_EVENTS, load_records
    from lerobot_policy_recent.scripts.cli import main

    packed = tmp_path / "with_logs"
    shutil.copytree(bench_dir, packed)
    assert main(["bench", "pack", str(packed)]) == 0
    with gzip.open(packed / LM_CALLS, "rt") as lines:
        rows = [json.loads(line) for line in lines]
    episodes = {(r["method"], r["task_id"], r["target"], r["seed"]) for r in load_records(packed)}
    assert {(r["method"], r["task_id"], r["robot"], r["seed"]) for r in rows} <= episodes
    assert {r["event"] for r in rows} <= set(LM_EVENTS) and any(r["event"] == "validation_verdict" for r in rows)
    calls = [r for r in rows if r["event"] == "infill_call"]
    assert calls and all("prompt" in r and "completion" in r for r in calls)
    assert all(r["evaluated_prompt_tokens"] <= r["prompt_tokens"] for r in calls)  # each call's cost, split
    assert all(r["prompt_seconds"] + r["generation_seconds"] <= r["seconds"] + 1e-3 for r in calls)


def test_a_committed_run_extended_without_its_logs_keeps_what_each_lm_was_asked(bench_dir, tmp_path, capsys):
    """Packed and committed without logs, then run on with another seed: the new logs are numbered
    from 0 again, yet the old episodes keep their prompts and the new ones get their own."""
    import gzip
    import shutil

    from lerobot_policy_recent.evaluation.runner import LM_CALLS, lm_call_episode

    def lm_rows(out):
        with gzip.open(out / LM_CALLS, "rt") as lines:
            return [json.loads(line) for line in lines]

    committed = tmp_path / "committed"
    shutil.copytree(bench_dir, committed)
    assert main(["bench", "pack", str(committed)]) == 0
    shutil.rmtree(committed / "logs")
    before = lm_rows(committed)
    extended = [word if not word.startswith("--seeds=") else "--seeds=0,1,42" for word in RUN]
    assert main([*extended, f"--out={committed}"]) == 0
    assert "6 episodes (4 already done)" in capsys.readouterr().err
    assert main(["bench", "pack", str(committed)]) == 0
    after = lm_rows(committed)
    assert [r for r in after if r["seed"] != 42] == before  # the old episodes' rows, untouched
    assert {lm_call_episode(r) for r in after if r["seed"] == 42} == {
        ("recent", "kinematic/cube_on_plate", "UR5e", 42),
        ("recent-no-insitu", "kinematic/cube_on_plate", "UR5e", 42),
    }


def test_unknown_targets_are_refused_before_any_episode(tmp_path, capsys):
    assert main(["bench", "--target=Kuka", "--infiller.type=rule", f"--out={tmp_path / 'x'}"]) == 2
    assert "unknown target(s) Kuka; known robots: Panda" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_a_crashed_episode_is_no_result_and_is_retried_on_request(tmp_path, capsys):
    """An unreachable LM server breaks the episode off: the run exits 1, the crash is listed and in no
    figure, no paper target is ticked, a plain rerun skips it, --retry-crashed runs it again."""
    out = tmp_path / "crash"
    one = [
        "bench",
        "--suite=kinematic-v1",
        "--tasks=cube_in_bin",
        "--target=UR5e",
        "--seeds=0",
        "--no-log",
        f"--out={out}",
    ]
    unreachable = [
        "--infiller.type=openai",
        "--infiller.base_url=http://127.0.0.1:9",
        "--infiller.model=Qwen/Qwen2.5-Coder-7B",
    ]
    assert main([*one, *unreachable]) == 1
    err = capsys.readouterr().err
    assert "1 of 1 episodes crashed" in err and "--retry_crashed" in err
    results = json.loads((out / "results.json").read_text())
    assert results["episodes"] == 0 and results["crashed"][0]["error"].startswith("RuntimeError: cannot reach")
    assert results["by_setting"] == {}
    report = (out / "report.md").read_text()
    assert "Crashed episodes (1" in report and "✓" not in report

    assert main([*one, "--infiller.type=rule"]) == 1  # a plain rerun leaves the crash as it is
    assert "1 episodes (1 already done)" in capsys.readouterr().err
    assert main([*one, "--infiller.type=rule", "--retry-crashed"]) == 0
    results = json.loads((out / "results.json").read_text())
    assert results["episodes"] == 1 and results["crashed"] == []
    report = (out / "report.md").read_text()
    assert "not checked against the paper's targets: the rule backend has no LM" in report


def test_workers_share_the_cluster_and_never_wait_for_cpus_that_do_not_exist():
    from lerobot_policy_recent.evaluation.jobs import BenchConfig
    from lerobot_policy_recent.evaluation.ray_engine import plan_workers

    def plan(**fields):
        return plan_workers(BenchConfig(out="/tmp/x", **fields), cluster_cpus=2.0, cluster_gpus=0.0)

    assert plan()["workers"] == 1 and plan()["cpus_per_worker"] == 2.0  # the protocol: 2 threads per LM
    assert plan(workers=2)["cpus_per_worker"] == 1.0
    assert plan(workers=4)["cpus_per_worker"] == 0.5  # more workers than cores: they share them
    with pytest.raises(ValueError, match="3 workers x 1 CPUs need 3 CPUs; the Ray cluster has 2"):
        plan(workers=3, cpus_per_worker=1)
    big = plan_workers(BenchConfig(out="/tmp/x"), cluster_cpus=64.0, cluster_gpus=0.0)
    assert big["workers"] == 32 and big["gpus_per_worker"] == 0.0


def test_methods_on_several_models_are_rows_of_their_own(tmp_path):
    """``--models``: every method on each model of the backend, as ``method@model`` rows that no table
    pools; the run's own model keeps the plain name. Here a loopback completions server answers
    only the 7B, so the rows must differ: recent on the 1.5B fails, recent@7B succeeds."""
    from loopback import json_server
    from test_openai_backend import ANSWERS

    from lerobot_policy_recent.evaluation.methods import settings_for
    from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
    from lerobot_policy_recent.recent_plugin.settings import RecentSettings

    small, large = "Qwen/Qwen2.5-Coder-1.5B", "Qwen/Qwen2.5-Coder-7B"

    def answer(path: str, body: dict) -> dict:
        if path == "/tokenize":
            return {"tokens": list(range(len(body["content"].split())))}
        hint = next((k for k in ANSWERS if k in body["prompt"]), None)
        text = ANSWERS[hint] if hint and body["model"] == large else ""
        return {"choices": [{"text": text}], "usage": {"completion_tokens": len(text) // 4, "prompt_tokens": 100}}

    requests: list[dict] = []
    with json_server(answer, requests) as url:
        run = ["bench", "--suite=kinematic-v1", "--tasks=cube_in_bin", "--target=UR5e", "--method=recent"]
        run += ["--seeds=0", "--variations=off", "--workers=1", "--no-log", f"--out={tmp_path}"]
        run += ["--infiller.type=openai", f"--infiller.base_url={url}", f"--infiller.model={small}"]
        assert main([*run, f"--models={small},{large}"]) == 0
    by_row = {r["method"]: r for r in load_records(tmp_path)}
    assert set(by_row) == {"recent", f"recent@{large}"}
    assert not by_row["recent"]["success"] and by_row[f"recent@{large}"]["success"]
    assert by_row[f"recent@{large}"]["model"] == large and by_row["recent"]["model"] == small
    assert {r["model"] for r in requests if r["path"] == "/v1/completions"} == {small, large}
    assert (tmp_path / "episodes" / "recent@Qwen%2FQwen2.5-Coder-7B" / "UR5e").is_dir()  # one directory per row
    results = json.loads((tmp_path / "results.json").read_text())
    assert results["runs"][0]["row_models"] == {f"recent@{large}": {"model": large, "model_sha256": None}}
    assert f"--method=recent,recent@{large}" in results["runs"][0]["command"]  # reproducible without --models
    report = (tmp_path / "report.md").read_text()
    assert "| **recent** | 0.0" in report and f"| **recent@{large}** | 100.0" in report
    assert f"| {large} | 100.0" in report  # RECENT per model, on the episodes both ran

    with pytest.raises(ValueError, match="cap-distilled runs on a model of its own"):
        parse_methods("cap-distilled@qwen2.5-coder-1.5b")
    assert parse_methods("cap,oracle-rule", ("a", "b"), "a") == ["cap", "cap@b", "oracle-rule"]  # its own: once
    assert parse_methods("recent@a,recent@b", (), "a") == ["recent", "recent@b"]  # the run's model: the plain row
    with pytest.raises(ValueError, match="already names a model"):
        parse_methods("recent@a", ("b",))
    with pytest.raises(ValueError, match="needs an LM backend"):
        settings_for("recent@qwen2.5-coder-0.5b", RecentSettings(infiller=RuleConfig()))
    assert settings_for("recent@qwen2.5-coder-0.5b", RecentSettings()).infiller.model == "qwen2.5-coder-0.5b"


def test_records_name_the_commit_that_ran_them_and_results_json_says_whether_it_is_one(bench_dir):
    results = json.loads((bench_dir / "results.json").read_text())
    ran_at = results["runs"][-1]["git_commit"]
    assert {r["commit"] for r in load_records(bench_dir)} == {ran_at}
    assert results["commits"] == {ran_at: 4}
    clean = ran_at is not None and not ran_at.endswith("+dirty")
    assert results["commit"] == (ran_at if clean else None)


def test_a_directory_of_several_commits_or_local_edits_is_no_one_commit_snapshot():
    from lerobot_policy_recent.evaluation.report.provenance import commit_line, episode_commits, single_clean_commit

    assert single_clean_commit(episode_commits([{"commit": "a" * 40}] * 3)) == "a" * 40
    assert single_clean_commit(episode_commits([{"commit": "a" * 40}, {"commit": "b" * 40}])) is None
    assert single_clean_commit(episode_commits([{"commit": "a" * 40 + "+dirty"}])) is None
    # records from before the stamp: their runs' commit where every run names the same one
    assert single_clean_commit(episode_commits([{}], [{"git_commit": "c" * 40}] * 2)) == "c" * 40
    unknown = episode_commits([{}, {"commit": "c" * 40}], [{"git_commit": "c" * 40}, {"git_commit": "d" * 40}])
    assert single_clean_commit(unknown) is None
    assert commit_line([{}, {"commit": "c" * 40}]) == (
        "code: **not one clean commit** (episodes per commit: not recorded (1), cccccccccccc (1))"
    )
    assert commit_line([{"commit": "d" * 40 + "+dirty"}]).endswith(
        ": dddddddddddd+dirty (1))"
    )  # local edits stay visible


def test_the_ceiling_row_runs_the_source_robot_on_the_targets_episodes(bench_dir, tmp_path):
    """``source``: the Panda runs its own skill on the UR5e's episode (same task, seed, variations);
    the report sets each method's SR against it on the same episodes."""
    import shutil

    out = tmp_path / "ceiling"
    shutil.copytree(bench_dir / "episodes", out / "episodes")  # RECENT's episodes, already run
    assert (
        main(
            [
                *RUN[:4],
                "--method=source",
                "--seeds=0",
                "--variations=on",
                "--infiller.type=rule",
                "--no_log",
                f"--out={out}",
            ]
        )
        == 0
    )
    ceiling = [r for r in load_records(out) if r["method"] == "source"]
    assert [(r["target"], r["robot"], r["seed"]) for r in ceiling] == [("UR5e", "Panda", 0)]
    assert ceiling[0]["success"] and ceiling[0]["generated_tokens"] == 0  # nothing to ground on the source
    report = (out / "report.md").read_text()
    assert "## Against the ceiling" in report
    assert "| recent | kinematic-v1 | UR5e | 1 | 100 % | 100 % | 1.00 |" in report
    assert "| recent-no-insitu | kinematic-v1 | UR5e | 1 | 0 % | 100 % | 0.00 |" in report
    assert "## Failures no check noticed" in report  # recent-no-insitu failed: whether anyone noticed is counted


def test_one_ceiling_run_serves_every_target_of_its_suite():
    """The source robot runs the same episode whichever target labels it: a ceiling run with
    ``--target UR5e`` sets Sawyer's episodes against it too, and an episode it did not run stays out."""
    from lerobot_policy_recent.evaluation.report.tables import ceiling_lines

    def record(method, target, seed, success):
        return {
            "method": method,
            "suite": "kinematic",
            "target": target,
            "task_id": "t",
            "seed": seed,
            "success": success,
        }

    records = [
        record("source", "UR5e", 3, True),
        record("source", "UR5e", 7, False),
        record("recent", "UR5e", 3, True),
        record("recent", "Sawyer", 3, False),
        record("recent", "Sawyer", 7, False),
        record("recent", "Sawyer", 11, True),  # no ceiling episode: not counted
    ]
    lines = ceiling_lines(records)
    assert "| recent | kinematic | Sawyer | 2 | 0 % | 50 % | 0.00 |" in lines
    assert "| recent | kinematic | UR5e | 1 | 100 % | 100 % | 1.00 |" in lines


def test_the_report_counts_the_failures_no_check_noticed():
    from lerobot_policy_recent.evaluation.report.tables import unnoticed_lines

    records = [
        {"method": "recent", "success": False, "failure_category": "subtask_failed"},
        {"method": "recent", "success": False, "failure_category": "motion_planning"},
        {"method": "recent", "success": True, "failure_category": None},
        {"method": "source", "success": False, "failure_category": "grasp_lost"},
    ]
    lines = unnoticed_lines(records)
    assert "| recent | 2 | 1 | 50 % |" in lines and "| source | 1 | 0 | 0 % |" in lines
    assert unnoticed_lines([{"method": "recent", "success": True}]) == []


def test_an_episode_refused_as_infeasible_is_counted_apart_from_the_feasible_ones():
    """A target the world drew out of reach ends with a named refusal (variations mix): the report and
    results.json keep it apart, so the feasible episodes' SR is not diluted by what no robot could do."""
    from lerobot_policy_recent.evaluation.metrics import summarize
    from lerobot_policy_recent.evaluation.report.tables import failure_table

    refusal = "refused: release target [0.330, 0.310, 0.842] lies 0.94 m from the base, beyond the arm's 0.88 m reach"
    records = [
        {"method": "source", "seed": 3, "success": True, "failure_category": None},
        {
            "method": "source",
            "seed": 3,
            "success": False,
            "failure_category": "unreachable_object",
            "failure_message": refusal,
        },
        {
            "method": "source",
            "seed": 3,
            "success": False,
            "failure_category": "unreachable_object",
            "failure_message": "unreachable: the object is not there",
        },
    ]
    summary = summarize(records)
    assert summary["refused"] == 1 and summary["sr_feasible"] == 50.0
    table = failure_table(records)
    assert "| episode: refused as infeasible (named, before the arm was sent) | 1 |" in table
    assert (
        "| episode: unreachable_object | 1 |" in table and "| *succeeded, of the episodes not refused* | 1/2 |" in table
    )
