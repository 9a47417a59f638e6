"""Does a re-run reproduce a committed run? Episode by episode, on the episodes both directories hold.

The simulation is seeded and llama.cpp decodes greedily, so on one kind of machine an episode's
outcome (success, GC, steps, failure category, tokens) comes out the same run after run; what
differs is wall time, with the host's speed. The comparison therefore asks for the outcome to be
identical and reports the timings (IT, cold IGT) as ratios, not as a verdict. (llama.cpp reuses
a cached prompt prefix, which has been seen to change a greedy token once in a while: a differing
episode is worth a look at its logs, not yet proof of a regression.)
"""

from __future__ import annotations

import statistics
from dataclasses import dataclass
from pathlib import Path

from lerobot_policy_recent.recent_plugin.evaluation.runner import has_records, load_records

OUTCOME = ("success", "gc", "steps", "failure_category", "go", "go_pre", "ei", "patches", "generated_tokens")
TIMINGS = ("it", "igt_cold")


def episode_key(record: dict) -> tuple:
    return record["method"], record["suite"], record["target"], record["task_id"], record["seed"]


@dataclass(frozen=True)
class EpisodeComparison:
    key: tuple
    differences: dict[str, tuple[object, object]]  # field -> (reference, re-run), outcome fields only
    timing_ratios: dict[str, float]  # re-run ÷ reference, where the reference is not 0

    @property
    def reproduced(self) -> bool:
        return not self.differences


def compare_records(reference: list[dict], rerun: list[dict]) -> list[EpisodeComparison]:
    """One comparison per episode both hold. A field one record lacks (older records have no
    "patches") is not compared."""
    ref = {episode_key(r): r for r in reference}
    out = []
    for record in rerun:
        key = episode_key(record)
        if key not in ref:
            continue
        before = ref[key]
        differences = {
            f: (before[f], record[f]) for f in OUTCOME if f in before and f in record and before[f] != record[f]
        }
        ratios = {t: float(record[t]) / float(before[t]) for t in TIMINGS if before.get(t) and t in record}
        out.append(EpisodeComparison(key, differences, ratios))
    return sorted(out, key=lambda c: tuple(map(str, c.key)))


def render_comparison(comparisons: list[EpisodeComparison], reference: Path, rerun: Path) -> str:
    """A markdown summary: how many episodes reproduced, each that did not with its differing fields,
    and the median timing ratios (the host's speed, not a verdict)."""
    if not comparisons:
        return f"No episode of {rerun} is in {reference}: nothing to compare (same methods, tasks, targets, seeds?)."
    same = sum(c.reproduced for c in comparisons)
    lines = [
        f"# {rerun} against {reference}",
        "",
        f"{same} of {len(comparisons)} shared episodes reproduced: identical {', '.join(OUTCOME)}.",
    ]
    for t in TIMINGS:
        ratios = [c.timing_ratios[t] for c in comparisons if t in c.timing_ratios]
        if ratios:
            lines.append(
                f"{t}: re-run ÷ reference, median {statistics.median(ratios):.2f}× "
                f"(range {min(ratios):.2f}–{max(ratios):.2f}×, {len(ratios)} episodes; the host's speed)"
            )
    differing = [c for c in comparisons if not c.reproduced]
    if differing:
        lines += [
            "",
            "| method | suite | target | task | seed | differs (reference → re-run) |",
            "|---|---|---|---|---|---|",
        ]
        for c in differing:
            diff = "; ".join(f"{f}: {a!r} → {b!r}" for f, (a, b) in c.differences.items())
            lines.append("| " + " | ".join(map(str, c.key)) + f" | {diff} |")
    return "\n".join(lines)


def compare_dirs(reference: Path, rerun: Path) -> tuple[list[EpisodeComparison], str]:
    for d in (reference, rerun):
        if not has_records(d):
            raise FileNotFoundError(f"{d} holds no episode records: is it a `recent bench --out` directory?")
    comparisons = compare_records(load_records(reference), load_records(rerun))
    return comparisons, render_comparison(comparisons, reference, rerun)
