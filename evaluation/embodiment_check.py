"""``recent envs check``: does a robot do what the Panda does? The canonical set, side by side.

Five single-subtask tasks cover the motions every skill is made of (grasp and lift, carry and
release into a container and onto a surface, push along the table, press down). The robot under
test and the Panda reference run them on the same seeds, with the paper's variations on, through
the same benchmark engine as ``recent bench``. A robot passes when its success is at least
``REFERENCE_SHARE`` of the Panda's; its failure categories say whether what failed was the arm
(``cannot_track``, ``grasp_lost``, ``timeout``) or the grounding (the ``hallucinated_*`` ones).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from lerobot_policy_recent.descriptions.embodiments import SOURCE_EMBODIMENT, get_embodiment
from lerobot_policy_recent.evaluation.jobs import BenchConfig
from lerobot_policy_recent.evaluation.metrics import crashed
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.robosuite_envs.suites import SEEDS

CANONICAL_TASKS = (
    "kinematic/lift_cube",
    "kinematic/cube_in_bin",
    "kinematic/cube_on_plate",
    "kinematic/push_cube",
    "kinematic/press_button",
)
REFERENCE_SHARE = 0.8  # a robot passes with at least this share of the reference's successes


def check_config(
    robots: tuple[str, ...],
    out: Path,
    settings: RecentSettings,
    *,
    seeds: tuple[int, ...] = SEEDS,
    tasks: tuple[str, ...] = CANONICAL_TASKS,
    workers: int = 0,
) -> BenchConfig:
    """The benchmark slice of a check: RECENT on the canonical tasks, for the robots and the reference."""
    for robot in robots:
        get_embodiment(robot)  # an unknown name stops here, listing the known ones
    targets = tuple(dict.fromkeys((SOURCE_EMBODIMENT, *robots)))
    return BenchConfig(
        out=out,
        suites=("kinematic-v1",),  # the canonical tasks are single subtasks of the earlier suite
        targets=targets,
        methods=("recent",),
        seeds=seeds,
        tasks=tasks,
        variations="on",
        workers=workers,
        log_sinks=(),
        agent=settings,
    )


@dataclass
class ArmCheck:
    """One robot's canonical set against the reference's, task by task."""

    robot: str
    reference: str
    tasks: tuple[str, ...]
    wins: Counter = field(default_factory=Counter)  # (robot, task) -> successes
    runs: Counter = field(default_factory=Counter)  # (robot, task) -> episodes
    failures: Counter = field(default_factory=Counter)  # the robot's failure categories
    crashes: int = 0

    def share(self) -> float:
        """The robot's successes as a share of the reference's (1.0 where the reference has none)."""
        reference = sum(self.wins[self.reference, t] for t in self.tasks)
        return sum(self.wins[self.robot, t] for t in self.tasks) / reference if reference else 1.0

    @property
    def passed(self) -> bool:
        return not self.crashes and self.share() >= REFERENCE_SHARE

    def rows(self) -> list[tuple[str, str, str]]:
        """(task, robot's successes, reference's successes), then the totals."""
        cell = lambda robot, tasks: (  # noqa: E731
            f"{sum(self.wins[robot, t] for t in tasks)}/{sum(self.runs[robot, t] for t in tasks)}"
        )
        rows = [(t.split("/")[-1], cell(self.robot, [t]), cell(self.reference, [t])) for t in self.tasks]
        return [*rows, ("all", cell(self.robot, self.tasks), cell(self.reference, self.tasks))]


def summarize(records: list[dict], robot: str, tasks: tuple[str, ...] = CANONICAL_TASKS) -> ArmCheck:
    check = ArmCheck(robot, SOURCE_EMBODIMENT, tasks)
    for r in records:
        if r["task_id"] not in tasks or r["target"] not in (robot, SOURCE_EMBODIMENT):
            continue
        if crashed(r):
            check.crashes += r["target"] == robot
            continue
        check.runs[r["target"], r["task_id"]] += 1
        check.wins[r["target"], r["task_id"]] += int(bool(r["success"]))
        if r["target"] == robot and not r["success"]:
            check.failures[r.get("failure_category") or "subtask_failed"] += 1
    return check


def markdown(checks: list[ArmCheck]) -> str:
    """One table: a column per robot (successes / episodes), the reference last, the verdict below."""
    if not checks:
        return ""
    reference = checks[0].reference
    header = ["task", *(c.robot for c in checks), f"{reference} (reference)"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for i, (task, _robot, ref) in enumerate(checks[0].rows()):
        lines.append("| " + " | ".join([task, *(c.rows()[i][1] for c in checks), ref]) + " |")
    lines.append("| share of reference | " + " | ".join(f"{c.share():.0%}" for c in checks) + " | 100% |")
    verdicts = []
    for c in checks:
        failed = ", ".join(f"{k} {v}" for k, v in c.failures.most_common()) or "none"
        status = "PASS" if c.passed else "FAIL"
        crashes = f"; {c.crashes} crashed" if c.crashes else ""
        verdicts.append(
            f"- {c.robot}: {status} (needs {REFERENCE_SHARE:.0%} of {reference}'s); failures: {failed}{crashes}"
        )
    return "\n".join([*lines, "", *verdicts])
