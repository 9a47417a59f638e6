"""The transfer matrix's execution columns: each grounded cell runs its skill's single-subtask task.

A cell that grounded (``source``, ``ontology`` or ``lm``) runs the task that exercises its skill's
subtask alone (``robosuite_envs.suites.validation_task``), on the seeds asked for, once with each
variation setting asked for (``off``, ``on``: the paper's three). The skill's source robot runs the
same episodes, so every cell is read beside the world's own ceiling. The episodes are a bench run's
(Ray, one record per episode, resumable): ``OUT/episodes/<variations>/``.

A cell's *gaps* are the episodes where the source robot succeeded and the cell's robot did not,
each with the failure the record names. They are listed one by one, never averaged away: a gap on
a validated grounding is what a reviewer reads first (the grounding may have been wrong while
validation passed). Where a check refused the episode by name as infeasible for the robot (a
target nearer its base than its hand gets, beyond its reach), it is a *refusal*, listed apart with
its reason: the cell is at par on the others, and a cell whose every such episode was refused
counts as refused at run time, not at par.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from lerobot_policy_recent.evaluation.jobs import BenchConfig, Job
from lerobot_policy_recent.evaluation.metrics import refused
from lerobot_policy_recent.evaluation.transfer import PAR, Cell, Execution, grid_lines
from lerobot_policy_recent.recent_plugin.extras import pyplot
from lerobot_policy_recent.robosuite_envs.suites import validation_task

EXECUTED = ("source", "ontology", "lm")  # the groundings that run; refused and invalid ones do not
SUITE = "subtask"  # a cell's episodes: the single-subtask task of its skill


def task_of(skills: dict[str, object]) -> dict[str, str]:
    """Skill name → the task id of its subtask's single-subtask task."""
    return {name: validation_task(skill.subtask).task_id for name, skill in skills.items()}


def execution_jobs(
    cells: list[Cell], method: str, seeds: tuple[int, ...], tasks: dict[str, str], sources: dict[str, str]
) -> list[Job]:
    """The episodes of every cell that grounded, and of each such skill's source robot (once)."""
    pairs = {(c.skill, c.robot) for c in cells if c.grounding in EXECUTED}
    pairs |= {(skill, sources[skill]) for skill, _ in pairs}
    return [
        Job(method, SUITE, tasks[skill], robot, seed)
        for skill, robot in sorted(pairs, key=lambda p: (list(tasks).index(p[0]), p[1]))
        for seed in seeds
    ]


def pending_count(base: BenchConfig, jobs: list[Job], variations: tuple[str, ...]) -> int:
    """How many of the episodes a resumed run still has to run (the others have records)."""
    from lerobot_policy_recent.evaluation.runner import pending

    return sum(len(pending(_setting(base, jobs, setting))[1]) for setting in variations)


def _setting(base: BenchConfig, jobs: list[Job], setting: str) -> BenchConfig:
    return replace(base, out=base.out / "episodes" / setting, suites=(), extra=tuple(jobs), variations=setting)


def run_execution(
    base: BenchConfig, jobs: list[Job], variations: tuple[str, ...], on_record=None, stamp: dict | None = None
) -> dict:
    """Run ``jobs`` once per variation setting, each into ``base.out/episodes/<setting>``; the records
    of each setting (``stamp`` goes into every record run now: the commit the code came from)."""
    from lerobot_policy_recent.evaluation.runner import run_bench

    runs = {}
    for setting in variations:
        runs[setting] = run_bench(_setting(base, jobs, setting), on_record=on_record, stamp=stamp).records
    return runs


def attach(cells: list[Cell], runs: dict[str, list[dict]], tasks: dict[str, str], sources: dict[str, str]) -> None:
    """Fill each executed cell's ``execution``: per setting, its successes beside its source's."""
    for setting, records in runs.items():
        by_episode = {(r["task_id"], r["target"], r["seed"]): r for r in records}
        for cell in cells:
            mine = [r for (t, robot, _), r in by_episode.items() if t == tasks[cell.skill] and robot == cell.robot]
            if cell.grounding not in EXECUTED or not mine:
                continue
            run = Execution(setting)
            for record in sorted(mine, key=lambda r: r["seed"]):
                source = by_episode.get((record["task_id"], sources[cell.skill], record["seed"]))
                run.episodes += 1
                run.successes += bool(record["success"])
                run.source_successes += bool(source and source["success"])
                if source and source["success"] and not record["success"]:
                    into = run.refusals if refused(record) else run.gaps
                    into.append(f"seed {record['seed']}: {_failure(record)}")
            cell.execution[setting] = run


def _failure(record: dict) -> str:
    if record.get("crashed"):
        return f"crash: {record['crashed']}"
    message = record.get("failure_message") or "the subtask's predicate never held"
    return f"[{record.get('failure_category') or 'failed'}] {message}"


def summary(cells: list[Cell]) -> dict[str, int]:
    """Executed cells off the source; those at par with the source in every setting on the episodes
    they did not refuse; those that refused every episode the source succeeded on; gaps and refusals."""
    executed = [c for c in cells if c.execution and c.grounding != "source"]
    refused_all = [c for c in executed if refused_in_execution(c)]
    return {
        "executed": len(executed),
        "at_par": sum(all(run.at_par for run in c.execution.values()) for c in executed if c not in refused_all),
        "refused": len(refused_all),
        "gaps": sum(len(run.gaps) for c in executed for run in c.execution.values()),
        "refusals": sum(len(run.refusals) for c in executed for run in c.execution.values()),
    }


def refused_in_execution(cell: Cell) -> bool:
    """Every episode the source succeeded on, this robot refused by name (none left to be at par on)."""
    runs = cell.execution.values()
    return any(run.refusals for run in runs) and not any(run.feasible_source_successes for run in runs)


def per_robot_lines(cells: list[Cell], settings: list[str]) -> list[str]:
    """Per robot and setting: its cells' successes beside the source robots' on the same episodes."""
    lines = [
        "| robot | variations | cells | successes | the source's, same episodes | refused as infeasible | cells at par |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for robot in dict.fromkeys(c.robot for c in cells):
        ran = [c for c in cells if c.robot == robot and c.grounding != "source" and c.execution]
        for setting in settings:
            runs = [(c.execution[setting], refused_in_execution(c)) for c in ran if setting in c.execution]
            if not runs:
                continue
            episodes = sum(r.episodes for r, _ in runs)
            lines.append(
                f"| {robot} | {setting} | {len(runs)} | {sum(r.successes for r, _ in runs)}/{episodes} | "
                f"{sum(r.source_successes for r, _ in runs)}/{episodes} | {sum(len(r.refusals) for r, _ in runs)} | "
                f"{sum(r.at_par and not whole for r, whole in runs)} |"
            )
    return lines


def render_execution(cells: list[Cell]) -> str:
    """Per cell, successes per setting (``off`` / ``on``), the source's own in its column; then every gap."""
    settings = list(dict.fromkeys(s for c in cells for s in c.execution))
    if not settings:
        return ""
    counts = summary(cells)

    def text(cell: Cell) -> str:
        if not cell.execution:
            return ""
        runs = " / ".join(cell.execution[s].render() if s in cell.execution else "" for s in settings)
        return runs + ("*" if cell.grounding == "source" else "")

    lines = [
        "",
        *per_robot_lines(cells, settings),
        "",
        f"Execution: successes per setting ({' / '.join(settings)}), the skill's single-subtask task; "
        f"{counts['executed']} cells ran off their source robot, {counts['at_par']} of them at "
        f"≥ {PAR:.0%} of the source's successes on the same episodes in every setting (on those not refused), "
        f"{counts['refused']} refused at run time in every episode the source succeeded on; "
        f"{counts['gaps']} episodes where the source succeeded and the cell did not, and {counts['refusals']} "
        "where a check refused it by name as infeasible for the robot (both listed below). "
        "`*` marks the source robot.",
        "",
        *grid_lines(cells, text),
    ]
    runs = [(c, run) for c in cells for run in c.execution.values()]
    lines += _listed(
        "| skill | robot | variations | grounding | where the source succeeded |",
        [
            f"| `{c.skill}` | {c.robot} | {r.variations} | {c.grounding} | {'; '.join(r.gaps)} |"
            for c, r in runs
            if r.gaps
        ],
    )
    lines += _listed(
        "| skill | robot | variations | refused as infeasible, where the source succeeded |",
        [f"| `{c.skill}` | {c.robot} | {r.variations} | {'; '.join(r.refusals)} |" for c, r in runs if r.refusals],
    )
    return "\n".join(lines) + "\n"


def _listed(header: str, rows: list[str]) -> list[str]:
    """A markdown table of ``rows`` under ``header``, after a blank line; nothing without rows."""
    return ["", header, "|" + "---|" * (header.count("|") - 1), *rows] if rows else []


def plot_execution(cells: list[Cell], path: Path) -> Path | None:
    """Each executed cell's successes as a share of its source's on the same episodes (the last setting)."""
    settings = list(dict.fromkeys(s for c in cells for s in c.execution))
    if not settings:
        return None
    plt = pyplot("the transfer heatmap")
    setting = settings[-1]
    skills = list(dict.fromkeys(c.skill for c in cells))
    robots = list(dict.fromkeys(c.robot for c in cells))
    grid = [[float("nan")] * len(robots) for _ in skills]
    for c in cells:
        run = c.execution.get(setting)
        if run is not None and run.source_successes:
            grid[skills.index(c.skill)][robots.index(c.robot)] = min(run.successes / run.source_successes, 1.0)
    fig, ax = plt.subplots(figsize=(1.5 + 0.55 * len(robots), 1.2 + 0.32 * len(skills)))
    colours = plt.get_cmap("RdYlGn").copy()
    colours.set_bad("#d9d9d9")
    image = ax.imshow(grid, cmap=colours, vmin=0.0, vmax=1.0, aspect="auto")
    for c in cells:
        run = c.execution.get(setting)
        if run is not None:
            ax.text(robots.index(c.robot), skills.index(c.skill), run.render(), ha="center", va="center", fontsize=6)
    ax.set_xticks(range(len(robots)), robots, rotation=45, ha="right")
    ax.set_yticks(range(len(skills)), skills)
    fig.colorbar(image, ax=ax, label="successes ÷ the source robot's (same episodes)")
    ax.set_title(
        f"Execution of each grounded cell, variations {setting} (grey: not run, or the source never succeeded)"
    )
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path
