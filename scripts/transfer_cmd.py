"""``recent transfer``: the transfer matrix, every skill on every robot (``evaluation/transfer.py``)."""

from __future__ import annotations

import sys
from pathlib import Path

from lerobot_policy_recent.robosuite_envs.splits import DEV_SEEDS
from lerobot_policy_recent.scripts.common import add_settings_arguments, agent_from_args


def register(sub) -> None:
    parser = sub.add_parser(
        "transfer",
        help="ground every skill on every robot: by the ontology, by the LM, or refused with the reason",
        description=(
            "Ground every skill of the library on every embodiment (or those named) and write "
            "OUT/transfer.json, OUT/transfer.md (a table, the refused and invalid cells with their "
            "reasons) and OUT/transfer.png (a heatmap). Exit status 1 if a cell is a defect: refused by "
            "the ontology for a missing capability, yet validated. With --execute, every cell that grounded "
            "also runs its skill's single-subtask task on dev seeds, each variation setting, beside the skill's "
            "source robot on the same episodes (a resumable bench run on Ray in OUT/episodes/)."
        ),
    )
    parser.add_argument("--skills", default="", help="comma list of skills (default: the whole library)")
    parser.add_argument("--robots", default="", help="comma list of embodiments (default: every one)")
    parser.add_argument("--out", default="outputs/transfer", help="output directory (default: outputs/transfer)")
    parser.add_argument("--execute", action="store_true", help="run each grounded cell's single-subtask task too")
    parser.add_argument(
        "--seeds", default=",".join(map(str, DEV_SEEDS[:2])), help="with --execute: comma list of seeds (default: 3,7)"
    )
    parser.add_argument(
        "--variations", default="off,on", help="with --execute: comma list of variation settings (default: off,on)"
    )
    parser.add_argument("--workers", type=int, default=0, help="with --execute: Ray workers (default: as CPUs allow)")
    parser.add_argument("--ray_address", default=None, help="with --execute: an existing Ray cluster")
    add_settings_arguments(parser)
    parser.set_defaults(handler=_run)


def _run(args) -> int:
    from lerobot_policy_recent.descriptions.embodiments import EMBODIMENTS
    from lerobot_policy_recent.evaluation.transfer import ground_cells, write_matrix
    from lerobot_policy_recent.skills.repository import list_skills

    seeds, settings = (_seeds(args.seeds), _variation_settings(args.variations)) if args.execute else ((), ())
    agent = agent_from_args(args)
    skills = _names(args.skills, "--skills", list_skills(agent.library))
    robots = _names(args.robots, "--robots", list(EMBODIMENTS))
    total = len(skills) * len(robots)
    done = []

    def progress(cell) -> None:
        done.append(cell)
        print(f"[{len(done)}/{total}] {cell.skill} on {cell.robot}: {cell.grounding}", file=sys.stderr)

    cells = ground_cells(agent, skills, robots, on_cell=progress)
    header = {"backend": agent.infiller.name, "model": agent.infiller.model, "method": agent.settings.method.name}
    out = Path(args.out)
    more = ""
    if args.execute:
        more = _execute(args, agent, cells, skills, out, seeds, settings)
        header["execution"] = {"seeds": list(seeds), "variations": list(settings)}
    paths = write_matrix(cells, out, header, more)
    print(paths["md"].read_text(), end="")
    if args.execute:
        paths["execution_png"] = out / "transfer_execution.png"
    print(f"wrote {', '.join(str(p) for p in paths.values() if p.exists())}")
    return 1 if any(c.defect for c in cells) else 0


def _execute(
    args, agent, cells, skills: list[str], out: Path, seeds: tuple[int, ...], settings: tuple[str, ...]
) -> str:
    """Run every grounded cell's episodes (and its source robot's); the markdown of the execution columns."""
    from tqdm import tqdm

    from lerobot_policy_recent.evaluation.jobs import BenchConfig
    from lerobot_policy_recent.evaluation.transfer_execution import (
        attach,
        execution_jobs,
        pending_count,
        plot_execution,
        render_execution,
        run_execution,
        task_of,
    )
    from lerobot_policy_recent.scripts.bench_cmd import git_commit

    library = {name: agent.skill(name) for name in skills}
    tasks = task_of(library)
    sources = {name: skill.source_embodiment for name, skill in library.items()}
    jobs = execution_jobs(cells, agent.settings.method.name, seeds, tasks, sources)
    base = BenchConfig(out=out, workers=args.workers, ray_address=args.ray_address, log_sinks=(), agent=agent.settings)
    total = len(jobs) * len(settings)
    done = total - pending_count(base, jobs, settings)  # a resumed run's bar starts where it stopped
    bar = tqdm(total=total, initial=done, unit="episode", desc="transfer episodes")

    def on_record(record: dict) -> None:
        bar.set_postfix_str(
            f"{record['target']} {record['task_id'].split('/')[-1]}: {'ok' if record['success'] else 'failed'}"
        )
        bar.update(1)

    try:
        runs = run_execution(base, jobs, settings, on_record=on_record, stamp={"commit": git_commit()})
    finally:
        bar.close()
    attach(cells, runs, tasks, sources)
    plot_execution(cells, out / "transfer_execution.png")
    return render_execution(cells)


def _variation_settings(text: str) -> tuple[str, ...]:
    from lerobot_policy_recent.robosuite_envs.variations import parse_variations

    settings = _csv(text, "--variations")
    for setting in settings:
        try:
            parse_variations(setting)
        except ValueError as err:
            raise SystemExit(f"--variations: {err}") from None
    return settings


def _csv(text: str, option: str) -> tuple[str, ...]:
    values = tuple(t.strip() for t in text.split(",") if t.strip())
    if not values:
        raise SystemExit(f"{option}: give at least one value")
    return values


def _seeds(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(s) for s in _csv(text, "--seeds"))
    except ValueError:
        raise SystemExit(f"--seeds: expected a comma list of integers, got {text!r}") from None


def _names(text: str, option: str, known: list[str]) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()] or list(known)
    unknown = [n for n in names if n not in known]
    if unknown:
        raise SystemExit(f"{option}: unknown {', '.join(unknown)}; known: {', '.join(known)}")
    return names
