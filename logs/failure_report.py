"""``recent failures report``: group every failure of one or more runs by the paper's taxonomy.

Three kinds of failure are counted, each under its category (:class:`FailureCategory`): spans the
validator rejected before anything ran, segments that failed while running (repaired or not),
and episodes that failed (their first failure's category; ``subtask_failed`` when the plan ran
to its end without achieving the task, ``timeout`` at the step limit).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from lerobot_policy_recent.logs.layout import LogLayout, log_roots
from lerobot_policy_recent.logs.readers import read_table
from lerobot_policy_recent.recent_plugin.extras import pyplot
from lerobot_policy_recent.recent_plugin.failures import FailureCategory

KINDS = ("rejected spans", "failed segments", "failed episodes")


@dataclass
class FailureTable:
    counts: dict[str, Counter] = field(default_factory=lambda: {k: Counter() for k in KINDS})
    episodes: int = 0

    def categories(self) -> list[str]:
        seen = set().union(*(c.keys() for c in self.counts.values()))
        order = [c.value for c in FailureCategory]
        return sorted(seen, key=lambda c: (order.index(c) if c in order else len(order), c))

    def markdown(self) -> str:
        lines = ["| category | " + " | ".join(KINDS) + " |", "|---|" + "---:|" * len(KINDS)]
        for category in self.categories():
            lines.append(f"| {category} | " + " | ".join(str(self.counts[k][category]) for k in KINDS) + " |")
        lines.append("| **total** | " + " | ".join(str(sum(self.counts[k].values())) for k in KINDS) + " |")
        return "\n".join(lines)


def failure_table(roots: list[str | Path]) -> FailureTable:
    table = FailureTable()
    for root in log_roots(roots):
        layout = LogLayout(root)
        for episode in layout.committed():
            table.episodes += 1
            result = read_table(layout.results(episode))[0]
            if result["success"] is False and result["failure_category"]:
                table.counts["failed episodes"][result["failure_category"]] += 1
            events = read_table(layout.events(episode)) if layout.events(episode).exists() else []
            for row in events:
                if row["event"] == "validation_verdict" and row["category"] and row["kind"] != "skill":
                    table.counts["rejected spans"][row["category"]] += 1
                elif row["event"] == "segment_failed":
                    table.counts["failed segments"][row["category"]] += 1
    return table


def plot_failures(table: FailureTable, path: Path) -> Path:
    """A grouped bar chart: one group per category, one bar per kind of failure."""
    plt = pyplot("the failure plot")
    import numpy as np

    categories = table.categories() or ["(none)"]
    x = np.arange(len(categories))
    width = 0.8 / len(KINDS)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.1 * len(categories) + 2), 4))
    for i, kind in enumerate(KINDS):
        ax.bar(x + (i - 1) * width, [table.counts[kind][c] for c in categories], width, label=kind)
    ax.set_xticks(x, [c.replace("_", " ") for c in categories], rotation=30, ha="right")
    ax.set_ylabel("count")
    ax.set_title(f"Failures by category ({table.episodes} episodes)")
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
