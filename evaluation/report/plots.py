"""The report's plots (PNG): SR against GO per method, paired differences, failure categories.

matplotlib is a dependency of the optional ``bench`` extra.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from lerobot_policy_recent.evaluation.confidence import paired_comparisons
from lerobot_policy_recent.evaluation.methods import ABLATION_METHODS, METHODS, method_of, method_rank, model_of
from lerobot_policy_recent.evaluation.metrics import group, summarize
from lerobot_policy_recent.evaluation.report.paper import SUITE_ORDER
from lerobot_policy_recent.evaluation.report.tables import failure_counts, ordered_rows
from lerobot_policy_recent.recent_plugin.extras import pyplot


def _figure(size: tuple[float, float], rows: int = 1, cols: int = 1, **share):
    """A headless matplotlib figure (no display on the machines that run benchmarks); several
    panels come as a flat list of axes."""
    plt = pyplot("the report's plots")

    if rows * cols == 1:
        return plt.subplots(figsize=size)
    fig, axes = plt.subplots(rows, cols, figsize=size, squeeze=False, **share)
    return fig, list(axes.flat)


def _save(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")  # legends placed beside the axes stay in
    plt.close(fig)
    return path


MARKERS = "o^sDvP*X<>"  # one per method, so points that land on each other stay distinguishable


def plot_sr_vs_go(records: list[dict], path: Path) -> Path:
    """SR against GO, one panel per suite; each method keeps its colour and marker across panels and reports."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter

    suites = [s for s in SUITE_ORDER if any(r["suite"] == s for r in records)] or ["(none)"]
    fig, axes = _figure((4.2 * len(suites) + 2.8, 4.6), cols=len(suites), sharey=True)
    axes = axes if len(suites) > 1 else [axes]
    cmap = plt.get_cmap("tab20")  # 20 colours, and the markers shifted each round: every method its own pair
    by = group(records, lambda r: (r["method"], r["suite"]))
    models = ["", *sorted({model_of(m) for m, _ in by} - {None})]
    shown = {}
    for ax, suite in zip(axes, suites, strict=True):
        for method in ordered_rows({m for m, s in by if s == suite}):
            s = summarize(by[(method, suite)])
            # the method's own pair in every report; a row on another model shifted by a round of METHODS
            i = method_rank(method_of(method)) + len(METHODS) * models.index(model_of(method) or "")
            shown[method] = ax.errorbar(
                s["go"]["mean"],
                s["sr"]["mean"],
                xerr=s["go"]["std"],
                yerr=s["sr"]["std"],
                fmt=MARKERS[(i + i // len(MARKERS)) % len(MARKERS)],
                color=cmap(i % 20),
                markersize=8,
                markerfacecolor="none" if method_of(method) in ABLATION_METHODS else cmap(i % 20),  # ablations hollow
                capsize=3,
                alpha=0.9,
            )
        ax.set_xscale("symlog", linthresh=1.0)
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.set_xlabel("GO (%, log scale) — lower is better")
        ax.set_title(suite.replace("_", "-"))
        ax.set_ylim(-5, 105)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("SR (%) — higher is better")
    fig.legend(
        list(shown.values()), list(shown), fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5), frameon=False
    )
    fig.suptitle("Success vs. grounding overhead per method (mean ± std over seeds)")
    return _save(fig, path)


def plot_paired(records: list[dict], path: Path) -> Path | None:
    """RECENT minus each method on the episodes both ran, SR and GC in percentage points with their
    95 % paired intervals, one panel per suite: where a bar crosses 0, another draw of tasks and
    seeds could reverse the comparison. None where no method shares episodes with RECENT."""
    pairs = paired_comparisons(records)
    if not pairs:
        return None
    suites = [s for s in SUITE_ORDER if any(k.endswith(f"|{s}") for k in pairs)]
    methods = ordered_rows({k.split("|")[0].removeprefix("recent vs ") for k in pairs})
    fig, axes = _figure((5.0 * len(suites) + 2.0, 0.45 * len(methods) + 1.8), cols=len(suites), sharey=True)
    axes = axes if len(suites) > 1 else [axes]
    handles = {}
    for ax, suite in zip(axes, suites, strict=True):
        for y, method in enumerate(methods):
            p = pairs.get(f"recent vs {method}|{suite}")
            if p is None:
                continue
            for metric, offset, filled in (("sr", -0.15, True), ("gc", 0.15, False)):
                mean, (low, high) = p[f"{metric}_diff"], p[f"{metric}_diff_ci95"]
                colour = "tab:blue" if filled else "tab:orange"
                handles[metric.upper()] = ax.errorbar(
                    mean,
                    y + offset,
                    xerr=[[mean - low], [high - mean]],
                    fmt="o" if filled else "s",
                    color=colour,
                    markerfacecolor=colour if filled else "none",
                    capsize=3,
                )
            ax.text(-102, y, f"n={p['episodes']}", fontsize=7, va="center", ha="left", color="grey")
        ax.axvline(0.0, color="black", linewidth=0.8)
        ax.set_xlim(-105, 105)
        ax.set_xlabel("RECENT − method (percentage points)")
        ax.set_title(suite.replace("_", "-"))
        ax.grid(axis="x", alpha=0.3)
    axes[0].set_yticks(range(len(methods)), methods)
    axes[0].invert_yaxis()  # once: the panels share the axis; the table's order reads top down
    fig.legend(list(handles.values()), list(handles), fontsize=8, loc="upper center", ncol=2, bbox_to_anchor=(0.5, 0.0))
    fig.suptitle("RECENT against each method on the same episodes (95 % paired bootstrap intervals)")
    return _save(fig, path)


def plot_failures(records: list[dict], path: Path) -> Path:
    """Failures per method, by category and per episode (the methods ran different numbers of
    episodes): the share of episodes that failed, and the LM outputs the gate rejected."""
    import matplotlib.pyplot as plt
    import numpy as np

    counts = failure_counts(records)
    episodes = Counter(r["method"] for r in records)
    methods = ordered_rows(episodes) or ["(none)"]
    names = sorted({key.split(": ", 1)[1] for c in counts.values() for key in c})
    colour = {name: plt.get_cmap("tab20")(i % 20) for i, name in enumerate(names)}
    fig, axes = _figure((max(7.0, 0.8 * len(methods) + 3.0), 7.5), rows=2, sharex=True)
    panels = (
        ("episode", 100.0, "failed episodes (% of the method's)"),
        ("rejected", 1.0, "rejected LM outputs per episode"),
    )
    legend = {}
    for ax, (kind, scale, label) in zip(axes, panels, strict=True):
        bottom = np.zeros(len(methods))
        for name in names:
            values = np.array(
                [scale * counts.get(m, Counter())[f"{kind}: {name}"] / max(episodes[m], 1) for m in methods]
            )
            if values.any():
                legend[name] = ax.bar(methods, values, bottom=bottom, color=colour[name])
                bottom += values
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
        plt.setp(ax.get_xticklabels(), rotation=35, ha="right")
    fig.legend(
        list(legend.values()), list(legend), fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5), frameon=False
    )
    fig.suptitle("Failures per method by category (failed episodes; LM output the validation gate rejected)")
    return _save(fig, path)
