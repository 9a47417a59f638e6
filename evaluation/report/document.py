"""``recent bench report``: one report.md (and its plots) from one or more run directories."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

from lerobot_policy_recent.evaluation.metrics import held_out_apart, split_crashed
from lerobot_policy_recent.evaluation.programs import program_table
from lerobot_policy_recent.evaluation.report.paper import PROGRAMS_NOTE
from lerobot_policy_recent.evaluation.report.plots import plot_failures, plot_paired, plot_sr_vs_go
from lerobot_policy_recent.evaluation.report.provenance import commit_line, crash_lines
from lerobot_policy_recent.evaluation.report.tables import (
    ablation_table,
    ceiling_lines,
    dev_apart_lines,
    failure_table,
    held_out_first,
    lm_necessity_lines,
    main_table,
    model_table,
    paired_table,
    paper_ordering_lines,
    per_target_table,
    split_results_table,
    target_checks,
    unnoticed_lines,
)
from lerobot_policy_recent.evaluation.runner import lm_call_rows, load_records


def render_report(dirs: list[Path], out: Path) -> Path:
    """Write ``out/report.md`` and its plots from the episode records of ``dirs``; return the markdown's path."""
    everything, broken = split_crashed([r for d in dirs for r in load_records(Path(d))])
    if not everything and not broken:
        raise ValueError(f"no episode records under {', '.join(str(d) for d in dirs)} (expected DIR/episodes/...)")
    records, dev = held_out_first(everything)
    out.mkdir(parents=True, exist_ok=True)
    sr_go = plot_sr_vs_go(records, out / "sr_vs_go.png")
    failures = plot_failures(records, out / "failures_by_method.png")
    paired = plot_paired(records, out / "paired.png")
    ablations, checks = ablation_table(records)
    models = sorted({f"{r.get('backend')}:{r.get('model')}" for r in everything})
    parts = [
        "# RECENT benchmark report",
        "",
        f"{len(everything)} episodes from {', '.join(str(d) for d in dirs)}; LM: {', '.join(models)}; "
        f"seeds {sorted({r['seed'] for r in everything})}; {commit_line(everything + broken)}; "
        f"rendered {dt.date.today().isoformat()}."
        + (f" Figures: the {len(records)} test-split episodes; the {len(dev)} dev ones are apart." if dev else ""),
        "Values are mean ± std over seeds (a single seed shows no std); SR and GC add in brackets a 95 % "
        "bootstrap interval over episodes (task × target × seed). The paper's rows are its own numbers (7B model, GPU, "
        "CoppeliaSim/Genesis) for orientation, not a like-for-like comparison.",
        "GO counts the tokens of repair and revise calls, as the paper's appendix defines it; the tokens "
        "generated before execution (RECENT's grounding, a baseline's first program) are GO-pre, in the "
        "per-target table, with IGT. EI counts the repair and revise calls the model answered, as the "
        'appendix\'s formula does; "patches" (per-target table) counts every run-time patch, the ones '
        "the fast path renders without the model included.",
        "",
        "## Main table (baselines and RECENT)",
        "",
        main_table(records),
        "",
        "## Held-out test split and dev, apart",
        "",
        split_results_table(everything),
        "",
        "## RECENT against each method, on the same episodes",
        "",
        paired_table(records),
        "",
        *([f"![RECENT against each method]({paired.name})", ""] if paired else []),
        *lm_necessity_lines(records),
        *ceiling_lines(records),
        *unnoticed_lines(records),
        *paper_ordering_lines(records),
        "## Headline targets",
        "",
        *(target_checks(records, crashed=broken) or ["- (no RECENT episodes in these runs)"]),
        "",
        "## Ablations (on the episodes the ablations ran)",
        "",
        ablations,
        "",
        *checks,
        "",
    ]
    models_md = model_table(records)
    if models_md:
        parts += ["## Model size (RECENT)", "", models_md, ""]
    rows = [row for d in dirs for row in lm_call_rows(Path(d))]
    programs_md = program_table(held_out_apart(rows)[0] if dev else rows)
    if programs_md:
        parts += ["## What the whole programs called", "", PROGRAMS_NOTE, "", programs_md, ""]
    parts += [
        "## Per target",
        "",
        per_target_table(records),
        "",
        "## Failure categories",
        "",
        failure_table(records),
        "",
        f"![SR vs GO]({sr_go.name})",
        "",
        f"![failures]({failures.name})",
        "",
    ]
    parts += dev_apart_lines(dev)
    parts += crash_lines(broken)
    path = out / "report.md"
    path.write_text("\n".join(parts))
    return path
