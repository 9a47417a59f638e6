"""``DIR/headline.md``: the README's results table and its caption, written from what a run recorded.

A headline is only as honest as its caption. Here every fact in it comes from the records and
``results.json``: the split, the tasks and their primitive calls, the LM-call budget per task, the
seeds, the model, backend and temperature, the machine and the commit. The README cannot state a
setting that the run did not have. The table holds the held-out test split only; dev episodes are
counted in the caption. The no-LM ``oracle-rule`` row, GO-pre beside GO, and RECENT minus each method
on the same episodes are in the table. The paper's numbers are labelled reference rows.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

from lerobot_policy_recent.evaluation.compare import run_header
from lerobot_policy_recent.evaluation.confidence import episode_key, paired_difference
from lerobot_policy_recent.evaluation.methods import ABLATION_METHODS, method_of
from lerobot_policy_recent.evaluation.metrics import (
    group,
    held_out_apart,
    record_split,
    rule_coverage,
    split_crashed,
    summarize,
)
from lerobot_policy_recent.evaluation.report.paper import PAPER_MAIN, SETTINGS
from lerobot_policy_recent.evaluation.report.provenance import commit_counts, episode_commits, single_clean_commit
from lerobot_policy_recent.evaluation.report.tables import ordered_rows
from lerobot_policy_recent.evaluation.runner import load_records
from lerobot_policy_recent.recent_plugin.agent import lm_call_limit
from lerobot_policy_recent.robosuite_envs.splits import RETIRED_TEST_TASKS
from lerobot_policy_recent.robosuite_envs.suites import get_task
from lerobot_policy_recent.skills.repository import task_calls

SPLIT = "test"  # the headline is the held-out split; dev is where things were tuned
SHORT = {"kinematic": "kin", "end_effector": "ee"}


def _sr(summary: dict, records: list[dict]) -> str:
    wins = sum(bool(r["success"]) for r in records)
    low, high = summary["sr_ci95"]
    return f"{wins} / {len(records)} [{low:.0f}, {high:.0f}]"


def _gc(summary: dict) -> str:
    low, high = summary["gc_ci95"]
    return f"{summary['gc']['mean']:.1f} [{low:.0f}, {high:.0f}]"


def _per_setting(summaries: dict[str, dict], metric: str, digits: int) -> str:
    """``2.8 / 44.7``: one metric, kinematic / end-effector (– where the method did not run)."""
    return " / ".join(f"{summaries[s][metric]['mean']:.{digits}f}" if s in summaries else "–" for s in SETTINGS)


def _delta(row: str, records: list[dict]) -> str:
    """RECENT minus ``row`` in SR (pp) on the episodes both ran, with the paired 95 % interval."""
    if row == "recent":
        return "–"
    compared = paired_difference(
        [r for r in records if r["method"] == "recent"], [r for r in records if r["method"] == row]
    )
    if compared is None:
        return "–"
    low, high = compared["sr_diff_ci95"]
    return f"{compared['sr_diff']:+.0f} [{low:+.0f}, {high:+.0f}]"


def headline_table(records: list[dict]) -> str:
    """Methods × (SR and GC per setting; ΔSR against RECENT; GO, GO-pre, EI and IT per setting)."""
    settings_cells = " | ".join(f"{s} SR [95 % CI] | {s} GC (%)" for s in SETTINGS)
    kin_ee = " / ".join(SHORT[s] for s in SETTINGS)
    lines = [
        f"| method | {settings_cells} | RECENT − method, SR (pp) | GO (%) {kin_ee} | GO-pre (%) | EI | IT (s) |",
        "|---|" + "---:|" * (2 * len(SETTINGS) + 5),
    ]
    rows = [r for r in ordered_rows({r["method"] for r in records}) if method_of(r) not in ABLATION_METHODS]
    for row in rows:
        mine = [r for r in records if r["method"] == row]
        by_setting = {s: rs for (s,), rs in group(mine, lambda r: (r["suite"],)).items()}
        summaries = {s: summarize(rs) for s, rs in by_setting.items()}
        cells = []
        for s in SETTINGS:
            cells += [_sr(summaries[s], by_setting[s]), _gc(summaries[s])] if s in summaries else ["–", "–"]
        cells += [
            _delta(row, records),
            *(_per_setting(summaries, m, d) for m, d in (("go", 1), ("go_pre", 1), ("ei", 2), ("it", 1))),
        ]
        lines.append(f"| `{row}` | " + " | ".join(cells) + " |")
    lines += [_paper_row(row) for row in rows if row in PAPER_MAIN]
    ran = {method_of(row) for row in rows}
    if ran & (PAPER_MAIN.keys() - {"recent"}):  # a comparison: every row of the paper's table shows, run here or not
        lines += [_paper_row(method, ", not run here") for method in PAPER_MAIN if method not in ran]
    return "\n".join(lines)


def _paper_row(method: str, note: str = "") -> str:
    """The paper's own numbers for ``method``, in italics: a reference, not a target met."""
    paper = PAPER_MAIN[method]
    model = "GPT-5.2-Codex" if method == "cap-llm" else "7B"
    cells = []
    for s in SETTINGS:
        cells += [f"*{paper[s][0]:.1f} %*", f"*{paper[s][1]:.1f}*"]
    pair = [" / ".join(f"{paper[s][i]:.2f}" for s in SETTINGS) for i in (2, 3, 4)]
    cells += ["–", f"*{pair[0]}*", "–", f"*{pair[1]}*", f"*{pair[2]}*"]
    return f"| *reference: the paper's `{method}` ({model}){note}* | " + " | ".join(cells) + " |"


def _tasks_line(records: list[dict]) -> str:
    """Each setting's tasks with their primitive calls, its targets, and which split they were run as
    (the split each record names: the one in force when it ran)."""
    parts = []
    for suite in SETTINGS:
        ids = sorted({r["task_id"] for r in records if r["suite"] == suite})
        if not ids:
            continue
        splits = sorted({record_split(r) for r in records if r["suite"] == suite})
        targets = sorted({r["target"] for r in records if r["suite"] == suite})
        described = []
        for task_id in ids:
            task = get_task(task_id)
            calls = task_calls([step.skill for step in task.plan]).primitives
            described.append(f"`{task_id.split('/', 1)[1]}` ({calls})")
        retired = set(ids) & {t for tasks in RETIRED_TEST_TASKS.values() for t in tasks}
        note = " (test when run; dev since 2026-11-28: run during development)" if retired else ""
        parts.append(
            f"{suite}: {len(ids)} {'/'.join(splits)} task{'s' if len(ids) != 1 else ''}{note}, "
            f"on {' and '.join(targets)}: {', '.join(described)}"
        )
    return "; ".join(parts)


def _budget_line(records: list[dict], max_lm_calls: int | None) -> str:
    if max_lm_calls is None:
        return "LM calls per task: not recorded"
    if not max_lm_calls:
        return "LM calls per task: no limit"
    limits = sorted({lm_call_limit(get_task(t), max_lm_calls) for t in {r["task_id"] for r in records}})
    span = f"{limits[0]}" if len(limits) == 1 else f"{limits[0]}–{limits[-1]}"
    return (
        f"LM calls per task, grounding and run time together, the same for every method: {span} "
        f"(the larger of {max_lm_calls} and two per primitive call of the task); used per episode: "
        + _used_line(records, max_lm_calls)
    )


def _used_line(records: list[dict], max_lm_calls: int) -> str:
    """What each method spent of the budget: the range and mean of its LM calls per episode, and how
    many of its episodes ended with the budget spent (a budget that never binds is stated as such)."""
    parts = []
    for (method,), rs in sorted(group(records, lambda r: (r["method"],)).items()):
        calls = [int(r.get("lm_calls") or 0) for r in rs]
        spent = sum(c >= lm_call_limit(get_task(r["task_id"]), max_lm_calls) for c, r in zip(calls, rs, strict=True))
        spread = f"{min(calls)}" if min(calls) == max(calls) else f"{min(calls)}–{max(calls)}"
        parts.append(f"`{method}` {spread} (mean {sum(calls) / len(calls):.1f}; budget spent in {spent}/{len(rs)})")
    return ", ".join(parts)


def _models_line(records: list[dict]) -> str:
    """The model of most rows, then each other model with the rows that ran on it."""
    by_model = sorted(group(records, lambda r: (r.get("backend"), r.get("model"))).items(), key=lambda kv: -len(kv[1]))
    (backend, model), _ = by_model[0]
    parts = [f"{model} via {backend}"]
    for (other_backend, other), rs in by_model[1:]:
        rows = ", ".join(f"`{m}`" for m in sorted({r["method"] for r in rs}))
        parts.append(f"{rows}: {other} via {other_backend}")
    return "; ".join(parts)


def _pairing(episodes: dict[tuple, list[dict]], crashed: list[dict]) -> str:
    """Whether every method ran the same episodes, and where not, which lack how many (and whether
    those crashed: a method that cannot run on a target says so in its crash)."""
    keys = {method: set(map(episode_key, rs)) for (method,), rs in episodes.items()}
    every = set().union(*keys.values())
    missing = {method: len(every - mine) for method, mine in keys.items() if every - mine}
    if not missing:
        return "every method on the same episodes"
    broken = {(r["method"], episode_key(r)) for r in crashed}
    lacking = []
    for method, count in sorted(missing.items()):
        why = sum((method, key) in broken for key in every - keys[method])
        lacking.append(f"`{method}` {count}" + (f", {why} of them crashed (report.md says why)" if why else ""))
    return (
        "every method on the same episodes except where one lacks some ("
        + "; ".join(lacking)
        + "): RECENT − method uses the shared ones"
    )


def headline_caption(
    records: list[dict], header: dict, runs: list[dict], dev_episodes: int, crashed: list[dict] = ()
) -> str:
    """Split, tasks, calls per task, seeds, model, backend, decoding, machine, commit and dates, as recorded."""
    config = header.get("config") or {}
    machine = header.get("machine") or {}
    commits = episode_commits(records, runs)
    commit = single_clean_commit(commits)
    if commit:
        code = f"every episode ran at commit `{commit[:7]}`, clean"
    else:
        code = f"NOT one clean commit: {commit_counts(commits, digits=7)}"
    dates = sorted(str(run.get("date", ""))[:10] for run in runs if run.get("date"))
    when = dates[0] if dates and dates[0] == dates[-1] else (f"{dates[0]} to {dates[-1]}" if dates else "undated")
    episodes = group(records, lambda r: (r["method"],))
    counts = sorted({len(v) for v in episodes.values()})
    per_method = f"{counts[0]}" if len(counts) == 1 else f"{counts[0]} to {counts[-1]}"
    pairing = _pairing(episodes, crashed)
    temperature = config.get("temperature")
    decoding = "greedy" if temperature == 0 else f"seeded sampling at temperature {temperature}"
    return " ".join(
        [
            f"Caption: the held-out **{SPLIT}** split; {_tasks_line(records)} (primitive calls in brackets).",
            f"{per_method} episode{'s' if counts[-1] > 1 else ''} per method, {pairing};",
            f"seeds {sorted({r['seed'] for r in records})}; variations {header.get('variations', 'unrecorded')}.",
            f"{_budget_line(records, config.get('max_lm_calls'))}.",
            f"Model: {_models_line(records)}; {decoding}, the same for every method.",
            f"Machine: {machine.get('cpu', 'unrecorded')}, {machine.get('cores', '?')} cores;",
            f"engine {header.get('engine', 'unrecorded')}, {header.get('workers', '?')} worker(s) of",
            f"{header.get('cpus_per_worker', '?')} CPUs and {header.get('gpus_per_worker', '?')} GPUs; {code}; {when}.",
            "SR is successes / episodes with a 95 % bootstrap interval over episodes (task × target × seed);",
            "GC is subtasks achieved, weighted by subtasks; RECENT − method is paired on the same episodes.",
            "GO, GO-pre, EI and IT are means per episode, kinematic / end-effector.",
            "The paper's rows are its own numbers (a 7B on a GPU, its own suites and simulators), for reference only.",
            f"Crashed episodes are in no cell (see report.md). Dev-split episodes in the same directory: {dev_episodes},"
            " reported in report.md, not here.",
        ]
    )


def render_headline(directory: Path) -> Path:
    """Write ``directory/headline.md`` from its records and ``results.json``; return its path."""
    ran, broken = split_crashed(load_records(directory))
    records, dev_records = held_out_apart(ran)
    if not records:
        raise ValueError(f"{directory}: no {SPLIT}-split episodes to make a headline of")
    header = run_header(directory)
    runs = header.get("runs") or []
    dev = len(dev_records)
    coverage = [
        f"{key.split('|')[1]} {value:.1f} %"
        for key, value in rule_coverage(records).items()
        if key.startswith("recent|")
    ]
    text = "\n".join(
        [
            f"<!-- written by `recent bench headline {directory}` on {dt.date.today().isoformat()}; do not edit -->",
            "",
            headline_table(records),
            "",
            headline_caption(records, header, runs, dev, held_out_apart(broken)[0]),
            ""
            if not coverage
            else f"\nRECENT's rule coverage (spans and run-time patches the ontology or a check decided without "
            f"the LM) on these episodes: {', '.join(coverage)}.",
            "",
        ]
    )
    path = directory / "headline.md"
    path.write_text(text)
    return path
