"""Bootstrap intervals and paired comparisons, and a comparison of two runs that cannot pass by accident."""

from __future__ import annotations

import pytest

from lerobot_policy_recent.evaluation.compare import RunComparison, setup_differences
from lerobot_policy_recent.evaluation.confidence import paired_difference, rate_intervals
from lerobot_policy_recent.evaluation.metrics import fmt, summarize


def episodes(method: str, successes: list[bool], subtasks: int = 1) -> list[dict]:
    return [
        {
            "method": method,
            "suite": "kinematic",
            "target": "UR5e",
            "task_id": f"t{i}",
            "seed": 0,
            "success": ok,
            "gc": 1.0 if ok else 0.0,
            "subtasks": subtasks,
        }  # fmt: skip
        for i, ok in enumerate(successes)
    ]


def test_intervals_hold_the_rate_and_narrow_with_more_episodes():
    few = rate_intervals(episodes("recent", [True, False] * 5))
    many = rate_intervals(episodes("recent", [True, False] * 200))
    assert few["sr_ci95"][0] < 50.0 < few["sr_ci95"][1]
    assert many["sr_ci95"][1] - many["sr_ci95"][0] < few["sr_ci95"][1] - few["sr_ci95"][0]
    assert rate_intervals(episodes("recent", [True] * 4)) == {"sr_ci95": [100.0, 100.0], "gc_ci95": [100.0, 100.0]}
    assert rate_intervals(episodes("recent", [True, False] * 5)) == few  # seeded: the same every time


def test_a_paired_difference_is_taken_on_shared_episodes_only():
    recent = episodes("recent", [True] * 10)
    cap = episodes("cap", [True] * 5 + [False] * 5)[:8]  # cap ran 8 of the 10 episodes
    paired = paired_difference(recent, cap)
    assert paired["episodes"] == 8 and paired["sr_diff"] == pytest.approx(37.5)
    assert paired["sr_diff_ci95"][0] > 0  # every shared episode favours RECENT or ties: the interval excludes 0
    assert paired_difference(recent, []) is None


def test_one_seed_shows_no_std_and_the_interval_is_in_brackets():
    summary = summarize(episodes("recent", [True, True, False, True]))
    assert fmt(summary, "sr").startswith("75.0 [") and "±" not in fmt(summary, "sr")


def test_another_model_is_another_experiment_and_a_small_slice_is_only_partial():
    reference = {"backend": "llamacpp", "model": "qwen2.5-coder-1.5b", "model_sha256": "aa", "git_commit": "c1",
                 "config": {"infiller": {"type": "llamacpp", "n_threads": 2}, "max_retries": 3}}  # fmt: skip
    rerun = {**reference, "model_sha256": "bb", "git_commit": "c2",
             "config": {"infiller": {"type": "llamacpp", "n_threads": 4}, "max_retries": 3}}  # fmt: skip
    differences = setup_differences(reference, rerun)
    assert differences == {
        "model_sha256": ("aa", "bb"),
        "git_commit": ("c1", "c2"),
        "config.infiller.n_threads": (2, 4),
    }
    assert setup_differences({"backend": "llamacpp"}, rerun)["config"] == ("(not recorded)", "recorded")

    from lerobot_policy_recent.evaluation.compare import EpisodeComparison

    same = [EpisodeComparison(("recent",), {}, {})]
    assert RunComparison(same, [], 1, 1.0, differences).verdict == "different setup"
    assert RunComparison(same, [("cap",)] * 9, 10, 0.5).verdict == "partial"
    assert RunComparison(same, [], 1, 1.0, {"git_commit": ("c1", "c2")}).verdict == "reproduced"
    differs = [EpisodeComparison(("recent",), {"success": (True, False)}, {})]
    assert RunComparison(differs, [], 1, 1.0).verdict == "outcome differs"


def test_lm_necessity_says_when_a_suite_does_not_test_the_lm():
    from lerobot_policy_recent.evaluation.report.tables import lm_necessity_lines

    same = lm_necessity_lines(episodes("recent", [True] * 6) + episodes("oracle-rule", [True] * 6))
    assert any("**kinematic**: +0.0 pp SR" in line and "does not test the LM" in line for line in same)
    needed = lm_necessity_lines(episodes("recent", [True] * 20) + episodes("oracle-rule", [False] * 20))
    assert any("+100.0 pp SR [+100.0, +100.0]" in line and "the LM adds success" in line for line in needed)
    # two targets, one the rendering decides and one it cannot: a tie means different things on each
    decided = episodes("recent", [True] * 4) + episodes("oracle-rule", [True] * 4)
    open_ = [
        {**r, "target": "UR5eScript"} for r in episodes("recent", [False] * 4) + episodes("oracle-rule", [False] * 4)
    ]
    per_target = lm_necessity_lines(decided + open_)
    assert "  - UR5e: RECENT 100 % SR, oracle-rule 100 %, GC +0.0 pp over 4 episodes; the rendering alone succeeds" in (
        "\n".join(per_target)
    )
    assert any(line.startswith("  - UR5eScript: RECENT 0 % SR") and "neither succeeds" in line for line in per_target)
    covered = [{**r, "rule_coverage": 75.0} for r in episodes("recent", [True] * 3)]
    lines = lm_necessity_lines(covered)  # no oracle-rule row: coverage, and necessity not measured
    assert "- rule coverage, recent on kinematic: 75.0 % of spans and run-time patches decided without an LM" in lines
    assert any("LM necessity on kinematic: not measured" in line for line in lines)


def test_the_report_orders_the_methods_against_the_papers_table_and_names_each_inversion():
    from lerobot_policy_recent.evaluation.report.tables import paper_ordering_lines

    # the paper: repair (42 % SR) > progprompt (31.5 %) > cap (17 %), on kinematic
    ran = (
        episodes("cap", [True, True, False, False])
        + episodes("progprompt", [True, False, False, False])
        + episodes("repair", [False] * 4)
        + episodes("oracle-rule", [True] * 4)  # no paper row: not ordered
    )
    lines = paper_ordering_lines(ran)
    assert lines[0] == "## Against the paper's ordering (Table 1)"
    assert "- **kinematic** (3 of the paper's rows ran):" in lines
    sr = next(line for line in lines if line.startswith("  - SR (%)"))
    assert sr.startswith("  - SR (%): 0 pairs ordered as in the paper, 3 inverted")
    assert "repair > cap in the paper, cap > repair here" in sr and "0 tied here" in sr
    tied = paper_ordering_lines(episodes("cap", [False] * 2) + episodes("repair", [False] * 2))
    assert "1 tied here (repair > cap)" in "\n".join(tied)
    assert paper_ordering_lines(episodes("recent", [True])) == []  # one row: nothing to order


def test_rule_coverage_is_reported_for_the_methods_that_ground_through_the_ontology_only():
    from lerobot_policy_recent.evaluation.report.tables import lm_necessity_lines

    ran = [{**r, "rule_coverage": 0.0} for r in episodes("cap", [False] * 2)]
    ran += [{**r, "rule_coverage": 90.0} for r in episodes("oracle-rule", [True] * 2)]
    lines = lm_necessity_lines(ran)
    assert any(line.startswith("- rule coverage, oracle-rule on kinematic: 90.0 %") for line in lines)
    assert not any("rule coverage, cap " in line for line in lines)  # a baseline's program has no ontology span
    assert lm_necessity_lines([{**r, "rule_coverage": 0.0} for r in episodes("cap", [False])]) == []
