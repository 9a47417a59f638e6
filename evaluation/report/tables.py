"""The report's markdown tables in the paper's layout, and the lines that read them (targets, paired comparisons).

Rows are methods, columns SR/GC/GO/EI/IT per setting, with the paper's own numbers beside ours for
orientation (a 7B model on a GPU in CoppeliaSim and Genesis there; our suites in robosuite here).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from lerobot_policy_recent.evaluation.confidence import episode_key, paired_comparisons, paired_difference
from lerobot_policy_recent.evaluation.methods import (
    ABLATION_METHODS,
    EXPECTED,
    ONTOLOGY_METHODS,
    method_of,
    method_rank,
    model_of,
)
from lerobot_policy_recent.evaluation.metrics import (
    LABELS,
    fmt,
    group,
    held_out_apart,
    record_split,
    refused,
    rule_coverage,
    summarize,
)
from lerobot_policy_recent.evaluation.report.paper import (
    ABLATION_METRICS,
    CAP_GO_FACTOR,
    CAP_SR_MARGIN,
    CHECKED_ROWS,
    EI_CEILING,
    HEADLINE_METHODS,
    IT_CEILING,
    MAIN_METRICS,
    PAPER_ABLATION,
    PAPER_MAIN,
    SUITE_ORDER,
    TARGETS,
)


def _rank(row: str) -> tuple[int, str, str]:
    """Where a grid row sorts: its method's place in METHODS, then its model (the run's own first);
    a row whose method is no longer registered (records kept from before it was retired) comes last."""
    return method_rank(method_of(row)), method_of(row), model_of(row) or ""


def ordered_rows(rows) -> list[str]:
    """Grid rows in table order: by family, then model; rows of retired methods after them, so a
    committed run's table recomputes from its records whatever was renamed since."""
    return sorted(set(rows), key=_rank)


def main_table(records: list[dict]) -> str:
    settings = [s for s in SUITE_ORDER if any(r["suite"] == s for r in records)]
    by = {k: summarize(v) for k, v in group(records, lambda r: (r["method"], r["suite"])).items()}
    head = "| method | " + " | ".join(f"{s}: {LABELS[m]}" for s in settings for m in MAIN_METRICS) + " |"
    lines = [head, "|---|" + "---:|" * (len(settings) * len(MAIN_METRICS))]
    methods = [m for m in ordered_rows({r["method"] for r in records}) if method_of(m) not in ABLATION_METHODS]
    for method in methods:
        cells = [fmt(by[(method, s)], m) if (method, s) in by else "–" for s in settings for m in MAIN_METRICS]
        lines.append(f"| **{method}** | " + " | ".join(cells) + " |")
    for method in methods:
        if method in PAPER_MAIN:
            cells = [f"{v:.2f}" for s in settings for v in PAPER_MAIN[method][s.removesuffix("-v1")]]
            model = "GPT-5.2-Codex" if method == "cap-llm" else "7B"
            lines.append(f"| paper: {method} ({model}) | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def ablation_table(records: list[dict]) -> tuple[str, list[str]]:
    """The ablation table over the episodes the ablations ran, and one line per ablation on the expected direction.

    RECENT's row counts only the (suite, target, task, seed) episodes some ablation also ran, so
    every row of the table answers the same question.
    """
    ran = {episode_key(r) for r in records if r["method"] in ABLATION_METHODS}
    records = [
        r for r in records if r["method"] in ABLATION_METHODS or (r["method"] == "recent" and episode_key(r) in ran)
    ]
    by = {k[0]: summarize(v) for k, v in group(records, lambda r: (r["method"],)).items()}
    methods = [m for m in ordered_rows(by) if m == "recent" or m in ABLATION_METHODS]
    lines = ["| method | " + " | ".join(LABELS[m] for m in ABLATION_METRICS) + " | paper (SR / GO / EI / IT) |"]
    lines.append("|---|" + "---:|" * len(ABLATION_METRICS) + "---|")
    for method in methods:
        paper = " / ".join(f"{v:.2f}" for v in PAPER_ABLATION.get(method, ()))
        lines.append(
            f"| **{method}** | " + " | ".join(fmt(by[method], m) for m in ABLATION_METRICS) + f" | {paper or '–'} |"
        )
    checks = []
    if "recent" in by:
        base = by["recent"]
        for method in methods:
            if method == "recent":
                continue
            parts = []
            for metric, sign in EXPECTED.get(method, {}).items():
                delta = by[method][metric]["mean"] - base[metric]["mean"]
                holds = delta * sign > 0 or (metric == "sr" and delta == 0 and base["sr"]["mean"] == 0)
                word = "higher" if sign > 0 else "lower"
                parts.append(f"{LABELS[metric]} expected {word}: {delta:+.2f} {'✓' if holds else '✗'}")
            note = _why_not(method, by[method], base)
            checks.append(f"- `{method}`: " + "; ".join(parts) + (f" — {note}" if note else ""))
    return "\n".join(lines), checks


def _why_not(method: str, ablated: dict, base: dict) -> str:
    """Where an ablation cannot differ on our suites, say why instead of leaving a bare ✗."""
    if method == "recent-no-offline-validation":
        return (
            "every skill in the repository passed Validate(skill, Panda), so serving unvalidated skills serves "
            "the same code; the ablation only differs with a library that holds unvalidated skills"
        )
    if ablated["sr"]["mean"] == 0 and ablated["ei"]["mean"] == 0 and {"ei", "go"} & set(EXPECTED.get(method, {})):
        return (
            "no program it produced passed validation, so nothing ran that could be interrupted "
            "(and GO counts only the repair and revise calls of a run)"
        )
    if method == "recent-no-insitu" and ablated["ei"]["mean"] == base["ei"]["mean"] == 0:
        return "no run-time check fired in these episodes (variations off, or none landed on a guarded statement)"
    return ""


def target_checks(records: list[dict], crashed: Sequence[dict] = ()) -> list[str]:
    """The benchmark issue's headline targets for RECENT (and its fast path, where it ran), each
    with the measured value and ✓/✗.

    None is ticked for the rule backend (no LM: the paper's targets measure one) or where an episode of
    a checked row (RECENT, its fast path, or cap for the margin) crashed: what it would have scored is
    unknown, so the values are listed, marked "not checked". Crashes of other rows (a sanity row that
    cannot run on some target) leave the check standing.
    """
    backends = {r.get("backend") for r in records if r.get("method") in HEADLINE_METHODS}
    crashes = sum(r.get("method") in CHECKED_ROWS for r in crashed)
    why = f"{crashes} episode(s) of a checked row crashed" if crashes else ""
    if not why and backends == {"rule"}:
        why = "the rule backend has no LM"
    lines = [f"- not checked against the paper's targets: {why}; the values stand as measured"] if why else []

    def mark(ok: bool) -> str:
        return "(not checked)" if why else "✓" if ok else "✗"

    by = {k: summarize(v) for k, v in group(records, lambda r: (r["method"], r["suite"])).items()}
    for method in HEADLINE_METHODS:
        for setting, target in TARGETS.items():
            ours = by.get((method, setting))
            if ours is None:
                continue
            label = setting if method == "recent" else f"{setting} ({method})"
            sr, go, ei, it = (ours[m]["mean"] for m in ("sr", "go", "ei", "it"))
            lines.append(f"- {label}: SR {sr:.1f}% (target ≥ {target['sr']}%) {mark(sr >= target['sr'])}")
            lines.append(f"- {label}: GO {go:.2f}% (target ≤ {target['go']}%) {mark(go <= target['go'])}")
            patches = ours["patches"]["mean"]
            rendered = f" (LM calls; {patches:.2f} run-time patches per task, {patches - ei:.2f} of them rendered)"
            lines.append(
                f"- {label}: EI {ei:.2f} (target ≤ {EI_CEILING}) {mark(ei <= EI_CEILING)}"
                + (rendered if patches > ei else "")
            )
            lines.append(f"- {label}: IT {it:.2f} s (target ≤ {IT_CEILING} s) {mark(it <= IT_CEILING)}")
            cap = by.get(("cap", setting))
            if cap is not None:
                margin = sr - cap["sr"]["mean"]
                factor = cap["go"]["mean"] / go if go > 0 else float("inf")
                lower = f"{factor:.1f}× lower" if go > 0 else f"0 against cap's {cap['go']['mean']:.1f}%"
                lines.append(
                    f"- {label}: margin over cap {margin:+.1f} pp SR (target ≥ +{CAP_SR_MARGIN:.0f}) "
                    f"{mark(margin >= CAP_SR_MARGIN)}, GO {lower} (target ≥ {CAP_GO_FACTOR:.0f}× lower) "
                    f"{mark(factor >= CAP_GO_FACTOR)}"
                )
    return lines


def model_table(records: list[dict]) -> str | None:
    """RECENT per model (the model-size ablation) on the episodes every model ran, when the runs used several."""
    ours = [r for r in records if method_of(r["method"]) == "recent" and r.get("model")]  # recent@model rows too
    models = sorted({r["model"] for r in ours})
    if len(models) < 2:
        return None
    common = set.intersection(*({episode_key(r) for r in ours if r["model"] == m} for m in models))
    ours = [r for r in ours if episode_key(r) in common]  # every row on the same episodes
    lines = ["| model | " + " | ".join(LABELS[m] for m in ABLATION_METRICS) + " |", "|---|" + "---:|" * 4]
    for model in models:
        summary = summarize([r for r in ours if r["model"] == model])
        lines.append(f"| {model} | " + " | ".join(fmt(summary, m) for m in ABLATION_METRICS) + " |")
    return "\n".join(lines)


def failure_counts(records: list[dict]) -> dict[str, Counter]:
    """Per method: failed episodes by category, plus rejected spans (LM output the gate refused)."""
    counts: dict[str, Counter] = {}
    for r in records:
        c = counts.setdefault(r["method"], Counter())
        if refused(r):
            c["episode: refused as infeasible (named, before the arm was sent)"] += 1
        elif not r["success"] and r.get("failure_category"):
            c[f"episode: {r['failure_category']}"] += 1
        for category, n in (r.get("rejected") or {}).items():
            c[f"rejected: {category}"] += n
    return counts


def failure_table(records: list[dict]) -> str:
    counts = failure_counts(records)
    categories = sorted({k for c in counts.values() for k in c})
    if not categories:
        return "No failures."
    methods = ordered_rows(counts)
    episodes = Counter(r["method"] for r in records)
    lines = ["| category | " + " | ".join(methods) + " |", "|---|" + "---:|" * len(methods)]
    lines.append("| *episodes run* | " + " | ".join(f"*{episodes[m]}*" for m in methods) + " |")
    for category in categories:
        lines.append(f"| {category} | " + " | ".join(str(counts[m][category]) for m in methods) + " |")
    feasible = {m: [r for r in records if r["method"] == m and not refused(r)] for m in methods}
    if any(len(feasible[m]) < episodes[m] for m in methods):
        cells = [f"{sum(r['success'] for r in rs)}/{len(rs)}" if rs else "–" for rs in feasible.values()]
        lines.append("| *succeeded, of the episodes not refused* | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def held_out_first(records: list[dict]) -> tuple[list[dict], list[dict]]:
    """The episodes the report's figures are drawn from, and the dev episodes kept apart.

    Where a run holds test-split episodes, every figure is theirs alone: pooling dev in would mix two
    task sets in one row (RECENT on test and dev, a baseline on test only). A run with no test
    episode is reported whole."""
    test, dev = held_out_apart(records)
    return (test, dev) if test else (records, [])


def dev_apart_lines(dev: list[dict]) -> list[str]:
    """The dev episodes of a run that also holds test ones: per target and failures, in a section of their own."""
    if not dev:
        return []
    return [
        f"## Dev split, apart ({len(dev)} episodes)",
        "",
        "Every figure above is the held-out test split's. The dev episodes of this run (where checks and "
        "hints may be tuned) are here, never pooled with it.",
        "",
        per_target_table(dev),
        "",
        failure_table(dev),
        "",
    ]


def paired_table(records: list[dict]) -> str:
    """RECENT minus each method on the episodes both ran: a difference whose interval excludes 0 is one
    another draw of tasks and seeds would be unlikely to reverse."""
    pairs = paired_comparisons(records)
    if not pairs:
        return "(no method shares episodes with RECENT in these runs)"
    lines = ["| comparison | suite | shared episodes | ΔSR (pp) [95 % CI] | ΔGC (pp) [95 % CI] |"]
    lines.append("|---|---|---:|---:|---:|")
    for key, p in pairs.items():
        name, suite = key.split("|")
        sr, gc = p["sr_diff_ci95"], p["gc_diff_ci95"]
        lines.append(
            f"| {name} | {suite} | {p['episodes']} | {p['sr_diff']:+.1f} [{sr[0]:+.1f}, {sr[1]:+.1f}] | "
            f"{p['gc_diff']:+.1f} [{gc[0]:+.1f}, {gc[1]:+.1f}] |"
        )
    return "\n".join(lines)


def split_results_table(records: list[dict]) -> str:
    """SR and GC per method and suite on the held-out test episodes and on dev, side by side: only the
    test columns are a result; dev is where fixes were made (``docs/benchmark.md``)."""
    by = {k: summarize(v) for k, v in group(records, lambda r: (r["method"], r["suite"], record_split(r))).items()}
    lines = ["| method | suite | test episodes | test SR | test GC | dev episodes | dev SR | dev GC |"]
    lines.append("|---|---|---:|---:|---:|---:|---:|---:|")
    for method, suite in sorted({(m, s) for m, s, _ in by}, key=lambda k: (_rank(k[0]), k[1])):
        cells = []
        for split in ("test", "dev"):
            summary = by.get((method, suite, split))
            cells += [str(summary["episodes"]), fmt(summary, "sr"), fmt(summary, "gc")] if summary else ["0", "–", "–"]
        lines.append(f"| {method} | {suite} | " + " | ".join(cells) + " |")
    if not any(split == "test" for _, _, split in by):
        lines.append("\nNo held-out test episode in these runs: every number above is a dev number.")
    return "\n".join(lines)


def paper_ordering_lines(records: list[dict]) -> list[str]:
    """The methods ordered against each other as the paper's Table 1 orders them, per setting and per
    SR and GC: every pair the two orderings rank the other way round (an inversion, to be explained),
    and the pairs our episodes cannot tell apart (tied here, apart in the paper)."""
    lines = []
    for suite in [s for s in SUITE_ORDER if any(r["suite"] == s for r in records)]:
        setting = suite.removesuffix("-v1")
        ours = {
            m: summarize(rs)
            for (m, s), rs in group(records, lambda r: (r["method"], r["suite"])).items()
            if s == suite and m in PAPER_MAIN
        }
        methods = ordered_rows(ours)
        if len(methods) < 2:
            continue
        lines.append(f"- **{suite}** ({len(methods)} of the paper's rows ran):")
        for index, metric in enumerate(("sr", "gc")):
            inverted, tied, agree = [], [], 0
            for i, a in enumerate(methods):
                for b in methods[i + 1 :]:
                    paper = PAPER_MAIN[a][setting][index] - PAPER_MAIN[b][setting][index]
                    here = ours[a][metric]["mean"] - ours[b][metric]["mean"]
                    hi, lo = (a, b) if paper > 0 else (b, a)
                    if abs(here) < 1e-9:
                        tied.append((hi, lo))
                    elif (paper > 0) == (here > 0):
                        agree += 1
                    else:
                        inverted.append(f"{hi} > {lo} in the paper, {lo} > {hi} here")
            lines.append(
                f"  - {LABELS[metric]}: {agree} pairs ordered as in the paper, {len(inverted)} inverted"
                + (f" ({'; '.join(inverted)})" if inverted else "")
                + f", {len(tied)} tied here"
                + (f" ({_tied(tied)})" if tied else "")
            )
    if not lines:
        return []
    return ["## Against the paper's ordering (Table 1)", "", *lines, ""]


def _tied(pairs: list[tuple[str, str]]) -> str:
    """A few tied pairs one by one (as the paper orders them); many, as the methods they are among."""
    if len(pairs) <= 4:
        return ", ".join(f"{hi} > {lo}" for hi, lo in pairs)
    return "among " + ", ".join(ordered_rows({m for pair in pairs for m in pair}))


def lm_necessity_lines(records: list[dict]) -> list[str]:
    """What the LM adds, the two figures every run reports: **rule coverage** (the share of spans and
    run-time patches the ontology or a check decided completely) and **LM necessity** (RECENT's SR
    minus the no-LM ``oracle-rule`` SR on the same episodes, per suite; where it is zero, the suite
    does not test the LM, and the report says so)."""
    coverage = {k: v for k, v in rule_coverage(records).items() if method_of(k.split("|")[0]) in ONTOLOGY_METHODS}
    pairs = {
        k.split("|")[1]: p for k, p in paired_comparisons(records).items() if k.startswith("recent vs oracle-rule|")
    }
    if not coverage and not pairs:
        return []
    lines = ["## What the LM adds", ""]
    for key, value in coverage.items():
        method, suite = key.split("|")
        lines.append(
            f"- rule coverage, {method} on {suite}: {value:.1f} % of spans and run-time patches decided without an LM"
        )
    for suite in sorted({r["suite"] for r in records if r["method"] == "recent"}):
        p = pairs.get(suite)
        if p is None:
            lines.append(f"- LM necessity on {suite}: not measured (run `oracle-rule` on the same episodes)")
            continue
        low, high = p["sr_diff_ci95"]
        verdict = (
            "the suite does not test the LM: the ontology's rendering alone does as well"
            if p["sr_diff"] <= 0
            else "the LM adds success here"
            + ("" if low > 0 else ", but the interval includes 0: another draw could erase it")
        )
        lines.append(
            f"- LM necessity on **{suite}**: {p['sr_diff']:+.1f} pp SR [{low:+.1f}, {high:+.1f}] over "
            f"{p['episodes']} shared episodes; {verdict}."
        )
        lines += _lm_necessity_per_target(records, suite)
    return [*lines, ""]


def _lm_necessity_per_target(records: list[dict], suite: str) -> list[str]:
    """Where a suite's targets differ (one API the ontology decides, one it cannot), what the LM
    adds on each: a tie can mean the rendering alone succeeds, or that neither does."""
    by_target = group([r for r in records if r["suite"] == suite], lambda r: r["target"])
    if len(by_target) < 2:
        return []
    lines = []
    for target, rs in sorted(by_target.items()):
        compared = paired_difference(
            [r for r in rs if r["method"] == "recent"], [r for r in rs if r["method"] == "oracle-rule"]
        )
        if compared is None:
            continue
        shared = {episode_key(r) for r in rs if r["method"] == "recent"}
        rule = [r for r in rs if r["method"] == "oracle-rule" and episode_key(r) in shared]
        rule_sr = 100.0 * sum(bool(r["success"]) for r in rule) / len(rule)
        recent_sr = rule_sr + compared["sr_diff"]
        if compared["sr_diff"] > 0:
            verdict = "the LM adds success"
        elif compared["sr_diff"] < 0:
            verdict = "the LM loses success the rendering alone had"
        elif rule_sr == 100.0:
            verdict = "the rendering alone succeeds on every episode: no test of the LM"
        elif recent_sr == 0.0:
            verdict = "neither succeeds: what the rendering leaves open, the LM did not get right"
        else:
            verdict = "the LM adds nothing over the rendering"
        lines.append(
            f"  - {target}: RECENT {recent_sr:.0f} % SR, oracle-rule {rule_sr:.0f} %, GC "
            f"{compared['gc_diff']:+.1f} pp over {compared['episodes']} episodes; {verdict}"
        )
    return lines


CEILING = "source"  # the sanity row whose success is the ceiling (evaluation/ablations.py: Source)


def ceiling_lines(records: list[dict]) -> list[str]:
    """Each method's SR as a share of the ceiling's (``source``: the task's source robot on its own
    reference skills) on the episodes both ran, per suite and target: how much of what the world
    allows the grounding keeps, and how much of a target's failure is the world's. The source robot
    runs the same episode whichever target labels it, so one ceiling run (``--target UR5e``) serves
    every target of its suite, and a report of several runs (``recent bench report A B``) sets
    each target's episodes against it."""
    ceiling = {_source_episode(r): r for r in records if r["method"] == CEILING}
    if not ceiling:
        return []
    lines = [
        "## Against the ceiling (the source robot on its own skills, same episodes)",
        "",
        "| method | suite | target | episodes | SR | ceiling SR | ÷ ceiling |",
        "|---|---|---|---:|---:|---:|---:|",
    ]
    rows = group([r for r in records if r["method"] != CEILING and _source_episode(r) in ceiling], _ceiling_key)
    for (method, suite, target), rs in sorted(rows.items(), key=lambda kv: (_rank(kv[0][0]), kv[0][1:])):
        sr = 100.0 * sum(bool(r["success"]) for r in rs) / len(rs)
        top = 100.0 * sum(bool(ceiling[_source_episode(r)]["success"]) for r in rs) / len(rs)
        share = f"{sr / top:.2f}" if top else "–"
        lines.append(f"| {method} | {suite} | {target} | {len(rs)} | {sr:.0f} % | {top:.0f} % | {share} |")
    return [*lines, ""]


def _source_episode(record: dict) -> tuple:
    """What the source robot's episode depends on: suite, task and seed, not the target's name."""
    return record["suite"], record["task_id"], record["seed"]


UNNOTICED = "subtask_failed"  # the plan ran to its end, no step failed, and a subtask's predicate does not hold


def unnoticed_lines(records: list[dict]) -> list[str]:
    """Per method, how many failed episodes no check noticed: every step ran, and the task still
    failed. The record then names no step, so such a failure is unexplained; the target is none."""
    failed = group([r for r in records if not r["success"]], lambda r: r["method"])
    if not failed:
        return []
    lines = [
        "## Failures no check noticed",
        "",
        "Every step ran and no check fired, but a subtask's predicate does not hold at the end "
        f"(`{UNNOTICED}`): the record names no step, the effect or what was sensed.",
        "",
        "| method | failed episodes | noticed by nobody | share |",
        "|---|---:|---:|---:|",
    ]
    for method, rs in sorted(failed.items(), key=lambda kv: _rank(kv[0])):
        silent = sum(r.get("failure_category") == UNNOTICED for r in rs)
        lines.append(f"| {method} | {len(rs)} | {silent} | {100.0 * silent / len(rs):.0f} % |")
    return [*lines, ""]


def _ceiling_key(record: dict) -> tuple[str, str, str]:
    return record["method"], record["suite"], record["target"]


def per_target_table(records: list[dict]) -> str:
    by = {k: summarize(v) for k, v in group(records, lambda r: (r["method"], r["target"])).items()}
    metrics = (*MAIN_METRICS, "patches", "go_pre", "igt")
    lines = ["| method | target | episodes | " + " | ".join(LABELS[m] for m in metrics) + " |"]
    lines.append("|---|---|---:|" + "---:|" * len(metrics))
    for (method, target), s in sorted(by.items(), key=lambda kv: (_rank(kv[0][0]), kv[0][1])):
        cells = " | ".join(fmt(s, m) for m in metrics)
        lines.append(f"| {method} | {target} | {s['episodes']} | {cells} |")
    return "\n".join(lines)
