"""SR, GC, GO, EI, IT (and IGT) as the paper's appendix defines them, mean ± std over seeds.

GO counts the tokens of repair and revise calls (the appendix's τ_adapt); the tokens generated
before execution are reported beside it as GO-pre, so neither is hidden. EI counts the repair and
revise calls made to the model (the appendix's formula); "patches" counts every run-time patch
call, the ones the fast path renders without the model included.

Within one seed: SR is the fraction of tasks whose every subtask succeeded; GC the fraction of all
subtasks achieved (weighted by each task's subtask count); GO, EI and IT are per-task means; IGT
is the median time to first executable code of a cold start. Across seeds: mean and (population)
standard deviation, as the paper reports "averaged over five runs with different random seeds".
"""

from __future__ import annotations

import statistics
from collections import defaultdict
from collections.abc import Callable, Iterable

from lerobot_policy_recent.evaluation.confidence import paired_comparisons, rate_intervals
from lerobot_policy_recent.recent_plugin.failures import is_refusal
from lerobot_policy_recent.robosuite_envs.splits import split_of

METRICS = ("sr", "gc", "go", "ei", "it", "igt", "go_pre", "patches")
LABELS = {
    "sr": "SR (%)",
    "gc": "GC (%)",
    "go": "GO (%)",
    "ei": "EI",
    "it": "IT (s)",
    "igt": "IGT (s)",
    "go_pre": "GO-pre (%)",
    "patches": "patches",
}
HIGHER_IS_BETTER = {"sr", "gc"}


def crashed(record: dict) -> bool:
    """An episode an error broke off (the LM worker died, a bug): a failure to investigate, not a result."""
    return bool(record.get("crashed")) or record.get("failure_category") == "crash"


def refused(record: dict) -> bool:
    """An episode a check refused before the arm was sent, as infeasible as sensed (a target drawn out of
    reach): a named refusal, not a silent failure, reported apart from the feasible episodes."""
    return not record.get("success") and is_refusal(record.get("failure_category"), record.get("failure_message"))


def split_crashed(records: list[dict]) -> tuple[list[dict], list[dict]]:
    """(episodes that ran to a verdict, crashed ones): only the first go into any figure."""
    return [r for r in records if not crashed(r)], [r for r in records if crashed(r)]


def seed_metrics(records: list[dict]) -> dict[str, float]:
    """The metrics of one seed's episodes (one per task)."""
    subtasks = [max(1, int(r.get("subtasks") or 1)) for r in records]
    return {
        "sr": 100.0 * statistics.fmean(bool(r["success"]) for r in records),
        "gc": 100.0
        * sum(float(r.get("gc") or 0.0) * m for r, m in zip(records, subtasks, strict=True))
        / sum(subtasks),
        "go": statistics.fmean(float(r.get("go", 0.0)) for r in records),
        "ei": statistics.fmean(float(r.get("ei", 0)) for r in records),
        "it": statistics.fmean(float(r.get("it", 0.0)) for r in records),
        "igt": statistics.median(float(r.get("igt_cold", r.get("igt", 0.0))) for r in records),
        "go_pre": statistics.fmean(float(r.get("go_pre", 0.0)) for r in records),
        # records written before patches were counted apart had every patch call in EI
        "patches": statistics.fmean(float(r.get("patches", r.get("ei", 0))) for r in records),
    }


def summarize(records: list[dict]) -> dict[str, object]:
    """Mean ± std over seeds of each metric, the episode count, and 95 % bootstrap intervals of SR and GC."""
    by_seed: dict[int, list[dict]] = defaultdict(list)
    for r in records:
        by_seed[int(r["seed"])].append(r)
    per_seed = [seed_metrics(rs) for _, rs in sorted(by_seed.items())]
    out: dict[str, object] = {"episodes": len(records), "seeds": sorted(by_seed)}
    for metric in METRICS:
        values = [m[metric] for m in per_seed]
        out[metric] = {"mean": statistics.fmean(values), "std": statistics.pstdev(values) if len(values) > 1 else 0.0}
    feasible = [r for r in records if not refused(r)]
    out["refused"] = len(records) - len(feasible)  # refused as infeasible, by name
    out["sr_feasible"] = 100.0 * statistics.fmean(bool(r["success"]) for r in feasible) if feasible else None
    return {**out, **rate_intervals(records)}


def group(records: Iterable[dict], key: Callable[[dict], tuple]) -> dict[tuple, list[dict]]:
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in records:
        groups[key(r)].append(r)
    return dict(groups)


def aggregate(records: list[dict]) -> dict[str, object]:
    """The results.json body: per method × suite (the paper's settings), × target, × task, and × split
    (dev / held-out test); and RECENT against every other method on the episodes both ran."""
    return {
        "by_setting": {
            f"{m}|{s}": summarize(rs)
            for (m, s), rs in sorted(group(records, lambda r: (r["method"], r["suite"])).items())
        },
        "by_target": {
            f"{m}|{s}|{t}": summarize(rs)
            for (m, s, t), rs in sorted(group(records, lambda r: (r["method"], r["suite"], r["target"])).items())
        },
        "by_task": {
            f"{m}|{t}|{task}": summarize(rs)
            for (m, t, task), rs in sorted(group(records, lambda r: (r["method"], r["target"], r["task_id"])).items())
        },
        "by_split": {
            f"{m}|{s}|{split}": summarize(rs)
            for (m, s, split), rs in sorted(
                group(records, lambda r: (r["method"], r["suite"], record_split(r))).items()
            )
        },
        "rule_coverage": rule_coverage(records),
        "paired": paired_comparisons(records),
    }


def rule_coverage(records: list[dict]) -> dict[str, float]:
    """Per method|suite, the mean % of spans and run-time patches the ontology or a check decided
    completely (episodes with no span at all left out)."""
    out = {}
    for (m, s), rs in sorted(group(records, lambda r: (r["method"], r["suite"])).items()):
        values = [float(r["rule_coverage"]) for r in rs if r.get("rule_coverage") is not None]
        if values:
            out[f"{m}|{s}"] = round(statistics.fmean(values), 1)
    return out


def record_split(record: dict) -> str:
    """The record's split (``dev`` or ``test``), or where a record predates the field, its task's and seed's."""
    return record.get("split") or split_of(record["task_id"], record["seed"])


def held_out_apart(records: list[dict]) -> tuple[list[dict], list[dict]]:
    """``(test, dev)``: the held-out episodes, and every other one (dev is where things were tuned, so a
    figure never pools the two)."""
    test = [r for r in records if record_split(r) == "test"]
    return test, [r for r in records if record_split(r) != "test"]


def fmt(summary: dict, metric: str) -> str:
    """``73.0 ± 3.7 [65.0, 80.0]`` — how tables show one metric: mean ± std over seeds (no std for one
    seed), and for SR and GC the 95 % bootstrap interval over episodes."""
    cell = summary.get(metric)
    if not cell:
        return "–"
    digits = 2 if metric in ("ei", "it", "igt", "patches") else 1
    text = f"{cell['mean']:.{digits}f}"
    if len(summary.get("seeds", ())) > 1:
        text += f" ± {cell['std']:.{digits}f}"
    if interval := summary.get(f"{metric}_ci95"):
        text += f" [{interval[0]:.{digits}f}, {interval[1]:.{digits}f}]"
    return text
