"""Does a re-run reproduce a committed run? Episode by episode, on the episodes both directories hold,
and only if it covers enough of the reference and ran the same model.

The simulation is seeded and llama.cpp decodes greedily, so on one kind of machine an episode's
outcome (success, GC, steps, failure category, tokens) comes out the same run after run; what
differs is wall time, with the host's speed. The comparison therefore asks for the outcome to be
identical and reports the timings (IT, cold IGT) as ratios, not as a verdict. (llama.cpp reuses
a cached prompt prefix, which has been seen to change a greedy token once in a while: a differing
episode is worth a look at its logs, not yet proof of a regression.)

A comparison cannot pass by accident: the reference's episodes the re-run lacks are listed, and
below ``min_coverage`` (the fraction of the reference re-run) the verdict is "partial", never
"reproduced". The two runs' ``results.json`` are compared too: a different model (its sha256) or
backend makes the verdict "different setup"; a different commit or settings tree is flagged.
"""

from __future__ import annotations

import json
import statistics
from dataclasses import dataclass, field
from pathlib import Path

from lerobot_policy_recent.evaluation.runner import has_records, load_records

OUTCOME = (
    "success",
    "gc",
    "steps",
    "failure_category",
    "failure_message",
    "go",
    "go_pre",
    "ei",
    "patches",
    "generated_tokens",
)
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


SAME_MODEL = ("backend", "model", "model_sha256")  # a difference here makes it another experiment
# a difference here is worth knowing, not a failure (and so is any in the settings tree, ``config``);
# ``commit`` is the one clean commit of all a directory's episodes, ``git_commit`` its last run's
FLAGGED = ("git_commit", "commit")
LISTED = 50  # missing episodes listed one by one; the rest are counted


@dataclass
class RunComparison:
    """Two runs compared: their shared episodes, what the re-run lacks, and how their setups differ."""

    episodes: list[EpisodeComparison]
    missing: list[tuple]  # reference episodes the re-run does not hold
    reference_episodes: int
    min_coverage: float
    setup: dict[str, tuple[object, object]] = field(default_factory=dict)  # field -> (reference, re-run)

    @property
    def coverage(self) -> float:
        return len(self.episodes) / self.reference_episodes if self.reference_episodes else 0.0

    @property
    def verdict(self) -> str:
        if not self.episodes:
            return "nothing compared"
        if any(f in self.setup for f in SAME_MODEL):
            return "different setup"
        if not all(c.reproduced for c in self.episodes):
            return "outcome differs"
        return "reproduced" if self.coverage >= self.min_coverage else "partial"


def run_header(directory: Path) -> dict:
    """The last ``recent bench`` command's header in ``directory/results.json`` (empty when there is none)."""
    path = directory / "results.json"
    if not path.is_file():
        return {}
    document = json.loads(path.read_text())
    return {**document, **(document.get("runs") or [{}])[-1]}


def _flat(tree: object, prefix: str = "") -> dict[str, object]:
    if not isinstance(tree, dict):
        return {prefix: tree}
    return {k: v for key, sub in tree.items() for k, v in _flat(sub, f"{prefix}.{key}" if prefix else key).items()}


def setup_differences(reference: dict, rerun: dict) -> dict[str, tuple[object, object]]:
    """Model, backend, commit and settings that differ between two run headers (a field one lacks is
    named as missing, so an old reference without a config dump is flagged, not silently equal)."""
    out: dict[str, tuple[object, object]] = {}
    for f in (*SAME_MODEL, *FLAGGED):
        if reference.get(f) != rerun.get(f):
            out[f] = (reference.get(f, "(not recorded)"), rerun.get(f, "(not recorded)"))
    before, after = _flat(reference.get("config") or {}), _flat(rerun.get("config") or {})
    if not before or not after:
        out["config"] = ("(not recorded)" if not before else "recorded", "(not recorded)" if not after else "recorded")
    else:
        for key in sorted(set(before) | set(after)):
            if before.get(key) != after.get(key):
                out[f"config.{key}"] = (before.get(key), after.get(key))
    return out


def render_comparison(run: RunComparison, reference: Path, rerun: Path) -> str:
    """A markdown summary: the verdict, how many episodes reproduced, each that did not with its differing
    fields, the reference's episodes the re-run lacks, setup differences, and the median timing ratios
    (the host's speed, not a verdict)."""
    comparisons = run.episodes
    if not comparisons:
        return f"No episode of {rerun} is in {reference}: nothing to compare (same methods, tasks, targets, seeds?)."
    same = sum(c.reproduced for c in comparisons)
    lines = [
        f"# {rerun} against {reference}",
        "",
        f"**Verdict: {run.verdict}.** {same} of {len(comparisons)} shared episodes reproduced: identical "
        f"{', '.join(OUTCOME)}. The re-run covers {len(comparisons)} of {run.reference_episodes} reference "
        f"episodes ({100 * run.coverage:.1f} %; at least {100 * run.min_coverage:.0f} % is needed to call it "
        "reproduced, --min_coverage).",
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
    if run.setup:
        lines += ["", "Setup differences (reference → re-run):", ""]
        for f, (a, b) in run.setup.items():
            kind = "different model: not the same experiment" if f in SAME_MODEL else "flagged"
            lines.append(f"- {f}: {a!r} → {b!r} ({kind})")
    if run.missing:
        lines += ["", f"Reference episodes the re-run lacks ({len(run.missing)}):", ""]
        lines += ["- " + " ".join(map(str, key)) for key in run.missing[:LISTED]]
        if len(run.missing) > LISTED:
            lines.append(f"- … and {len(run.missing) - LISTED} more")
    return "\n".join(lines)


def compare_dirs(reference: Path, rerun: Path, min_coverage: float = 1.0) -> tuple[RunComparison, str]:
    for d in (reference, rerun):
        if not has_records(d):
            raise FileNotFoundError(f"{d} holds no episode records: is it a `recent bench --out` directory?")
    before, after = load_records(reference), load_records(rerun)
    comparisons = compare_records(before, after)
    held = {episode_key(r) for r in after}
    missing = sorted((episode_key(r) for r in before if episode_key(r) not in held), key=lambda k: tuple(map(str, k)))
    setup = setup_differences(run_header(reference), run_header(rerun)) if comparisons else {}
    run = RunComparison(comparisons, missing, len(before), min_coverage, setup)
    return run, render_comparison(run, reference, rerun)
