"""``recent envs``: the simulated world — embodiments, primitives, subtasks, suites, variations."""

from __future__ import annotations

import json
import statistics
import sys

from tqdm import tqdm

from lerobot_policy_recent.descriptions.apis import api_spec_path
from lerobot_policy_recent.descriptions.embodiments import EMBODIMENTS, get_embodiment
from lerobot_policy_recent.robosuite_envs.primitives import api_functions
from lerobot_policy_recent.robosuite_envs.splits import no_test_split, split_of, split_table
from lerobot_policy_recent.robosuite_envs.subtasks import SUBTASKS, get_subtask
from lerobot_policy_recent.robosuite_envs.suites import SEEDS, SUITES, get_task
from lerobot_policy_recent.robosuite_envs.variations import ON, VARIATIONS
from lerobot_policy_recent.scripts.common import DEST, add_settings_arguments
from lerobot_policy_recent.skills.repository import task_calls


def register(sub) -> None:
    parser = sub.add_parser("envs", help="embodiments, subtasks, task suites and variations of the robosuite world")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    listing = actions.add_parser("list", help="what the world offers")
    listing.add_argument("--json", action="store_true", help="one JSON object (counts and names)")
    listing.set_defaults(handler=_list)
    show = actions.add_parser("show", help="instruction, plan and objects of one task, e.g. kinematic/tidy_bench")
    show.add_argument("task")
    show.add_argument("--json", action="store_true")
    show.set_defaults(handler=_show)
    embodiment = actions.add_parser(
        "show-embodiment", help="one robot's calibration: arm, gripper and tracking as the controllers use them"
    )
    embodiment.add_argument("name", help="an embodiment (recent envs list)")
    embodiment.add_argument("--refresh", action="store_true", help="measure again, even if a calibration is cached")
    embodiment.add_argument("--json", action="store_true")
    embodiment.set_defaults(handler=_show_embodiment)
    compose = actions.add_parser(
        "compose",
        help="draw new tasks: seeded compositions of subtasks on the suites' scenes (the same seed, the same draw)",
    )
    compose.add_argument("--seed", type=int, required=True, help="the draw seed")
    compose.add_argument("--family", choices=("kinematic", "end_effector"), default="kinematic")
    compose.add_argument("--count", type=int, default=6, help="tasks in the draw (default: 6)")
    compose.add_argument("--json", action="store_true")
    compose.add_argument(
        "--out", default=None, help="write the draw to this JSON file; RECENT_TASKS=FILE makes its tasks runnable"
    )
    compose.add_argument(
        "--check",
        type=int,
        default=None,
        metavar="SEED",
        help="run each drawn task once on its source robot (rule backend, variations off) on this dev seed",
    )
    compose.set_defaults(handler=_compose)
    check = actions.add_parser(
        "check", help="run the canonical set on robots and on the Panda reference; exit 1 if one falls short"
    )
    check.add_argument("names", help="comma list of embodiments")
    check.add_argument("--seeds", default=",".join(map(str, SEEDS)), help="comma list (default: the paper's five)")
    check.add_argument("--tasks", default=None, help="comma list of canonical task ids (default: all five)")
    check.add_argument(
        "--out", default=None, help="run directory (default: outputs/check/<names>-<backend>); resumable"
    )
    check.add_argument("--workers", type=int, default=0, help="Ray workers (default: as many as the CPUs hold)")
    add_settings_arguments(check, with_method=False)
    # Motion first: the rule backend grounds these tasks completely, so what fails is the arm.
    check.set_defaults(handler=_check, **{DEST + "infiller.type": "rule"})


def _list(args) -> int:
    apis = {e.api for e in EMBODIMENTS.values()}
    summary = {
        "embodiments": list(EMBODIMENTS),
        "primitives": sum(len(api_functions(api)) for api in apis),
        "subtasks": len(SUBTASKS),
        "suites": {name: len(tasks) for name, tasks in SUITES.items()},
        "variations": list(VARIATIONS),
        "calls_per_task": {name: call_stats(tasks) for name, tasks in SUITES.items()},
        "split": split_table(),
    }
    if args.json:
        print(json.dumps(summary, indent=2))
        return 0
    print("Embodiments:")
    width = max(map(len, EMBODIMENTS))
    for e in EMBODIMENTS.values():
        print(f"  {e.name:<{width}} {len(api_functions(e.api)):>2} primitives  {e.description}")
    print(f"\nSubtasks ({len(SUBTASKS)}):")
    for s in SUBTASKS.values():
        print(f"  {s.name:<18} {s.family:<12} {s.category:<27} {s.description}")
    for name, tasks in SUITES.items():
        stats = summary["calls_per_task"][name]
        print(
            f"\nSuite {name} ({len(tasks)} tasks; primitive calls per task: mean {stats['mean']}, max {stats['max']}; "
            f"subtasks per task: mean {stats['subtasks_mean']}):"
        )
        for t in tasks:
            calls = task_calls([s.skill for s in t.plan]).primitives
            held_out = " [test]" if split_of(t.task_id, SEEDS[0]) == "test" else ""
            print(f"  {t.task_id:<32} {len(t.plan)} subtask(s) {calls:>3} calls{held_out}  {t.instruction}")
    seeds = summary["split"]["seeds"]
    why = no_test_split()
    held = f"[test] tasks on seeds {seeds['test']} are held out" if why is None else why
    print(f"\nSplit: {held}; dev seeds {seeds['dev']} (docs/benchmark.md)")
    print("\nVariations (--variations on = " + ", ".join(ON) + "):")
    for name, text in VARIATIONS.items():
        print(f"  {name:<18} {text}")
    return 0


def call_stats(tasks) -> dict:
    """Primitive calls per task as the paper counts them (literal loops unrolled, position reads left
    out, which are reported beside), and subtasks per task."""
    counts = [task_calls([s.skill for s in t.plan]) for t in tasks]
    calls = [c.primitives for c in counts]
    return {
        "mean": round(statistics.mean(calls), 2),
        "max": max(calls),
        "mean_with_position_reads": round(statistics.mean(c.primitives + c.position_reads for c in counts), 2),
        "subtasks_mean": round(statistics.mean(len(t.plan) for t in tasks), 2),
    }


def _show(args) -> int:
    task = get_task(args.task)
    record = {
        "task": task.task_id,
        "suite": task.suite,
        "instruction": task.instruction,
        "max_steps": task.max_steps,
        "plan": [
            {"subtask": s.subtask, "family": get_subtask(s.subtask).family, "skill": s.skill, "args": s.args}
            for s in task.plan
        ],
        "objects": [
            {"name": o.name, "kind": o.kind, "xy": list(o.xy), "jitter": o.xy_jitter, "size": list(o.size)}
            for o in task.objects
        ],
    }
    if args.json:
        print(json.dumps(record, indent=2))
        return 0
    print(f"{task.task_id}: {task.instruction}\n\nPlan:")
    for i, s in enumerate(record["plan"], 1):
        print(f"  {i}. {s['subtask']:<18} skill {s['skill']}({', '.join(f'{k}={v}' for k, v in s['args'].items())})")
    print("\nObjects:")
    for o in record["objects"]:
        size = " x ".join(f"{v:.3f}" for v in o["size"])
        print(
            f"  {o['name']:<10} {o['kind']:<11} at ({o['xy'][0]:+.2f}, {o['xy'][1]:+.2f}) ±{o['jitter']:.3f} m  {size} m"
        )
    return 0


def _show_embodiment(args) -> int:
    from lerobot_policy_recent.robosuite_envs.calibrate import cache_path, calibration

    embodiment = get_embodiment(args.name)
    measured = calibration(args.name, refresh=args.refresh)
    if args.json:
        print(measured.to_json())
        return 0
    print("\n".join(measured.lines()))
    print(f"primitive API     {api_spec_path(embodiment.api)}")
    print(f"cached at         {cache_path(embodiment)}")
    return 0


def _check(args) -> int:
    from pathlib import Path

    from lerobot_policy_recent.evaluation.embodiment_check import (
        CANONICAL_TASKS,
        check_config,
        markdown,
        summarize,
    )
    from lerobot_policy_recent.evaluation.runner import load_records, pending, run_bench
    from lerobot_policy_recent.robosuite_envs.calibrate import calibration
    from lerobot_policy_recent.scripts.common import settings_from_args

    robots = tuple(n.strip() for n in args.names.split(",") if n.strip())
    tasks = tuple(t.strip() for t in args.tasks.split(",")) if args.tasks else CANONICAL_TASKS
    unknown = sorted(set(tasks) - set(CANONICAL_TASKS))
    if unknown:
        raise ValueError(f"not in the canonical set: {', '.join(unknown)}; choose from {', '.join(CANONICAL_TASKS)}")
    settings = settings_from_args(args)
    backend = settings.infiller.backend
    out = Path(args.out or f"outputs/check/{'_'.join(robots)}-{backend}")
    other = sorted({r.get("backend") or backend for r in load_records(out)} - {backend})
    if other:  # a resumed check must not count another backend's episodes as its own
        raise ValueError(f"{out} holds a check with the {', '.join(other)} backend; give another --out")
    config = check_config(
        robots,
        out,
        settings,
        seeds=tuple(int(s) for s in args.seeds.split(",")),
        tasks=tasks,
        workers=args.workers,
    )
    for robot in robots:  # calibrate first: a robot the controllers cannot use fails here, before any episode
        measured = calibration(robot)
        print(f"{robot}: calibrated ({measured.tracking_error_m * 1000:.1f} mm tracking error, "
              f"close {measured.close_time_s:.2f} s)", file=sys.stderr)  # fmt: skip
    jobs, todo = pending(config)
    with tqdm(total=len(jobs), initial=len(jobs) - len(todo), unit="episode", desc="check") as bar:
        run_bench(config, on_record=lambda _r: bar.update(1))
    checks = [summarize(load_records(out), robot, tasks) for robot in robots]
    print(markdown(checks))
    print(f"\nrecords: {out}/episodes (rerun the same command to finish an interrupted check)")
    return 0 if all(c.passed for c in checks) else 1


def _compose(args) -> int:
    """Print a draw: each task's plan, its primitive calls and subtask categories, then the draw's figures."""
    from lerobot_policy_recent.robosuite_envs.compose import PAPER_CALLS, draw
    from lerobot_policy_recent.robosuite_envs.subtasks import SUBTASKS

    def calls(spec) -> int:
        return task_calls([s.skill for s in spec.plan]).primitives

    try:
        tasks = draw(args.family, args.seed, args.count, calls)
    except ValueError as err:
        raise SystemExit(f"recent envs compose: {err}") from None
    rows = [
        {
            "task_id": t.task_id,
            "instruction": t.instruction,
            "plan": [{"subtask": s.subtask, **s.args} for s in t.plan],
            "calls": calls(t),
            "categories": sorted({SUBTASKS[s.subtask].category for s in t.plan}),
        }
        for t in tasks
    ]
    mean_calls = sum(r["calls"] for r in rows) / len(rows)
    if args.out:
        from pathlib import Path

        from lerobot_policy_recent.robosuite_envs.compose import draw_document

        Path(args.out).write_text(json.dumps(draw_document(args.family, args.seed, tasks), indent=1) + "\n")
        print(f"wrote {args.out} (run its tasks with RECENT_TASKS={args.out})", file=sys.stderr)
    if args.check is not None:
        for row, outcome in zip(rows, _check_draw(tasks, args.check), strict=True):
            row["check"] = outcome
    if args.json:
        print(json.dumps({"family": args.family, "seed": args.seed, "mean_calls": mean_calls, "tasks": rows}, indent=2))
        return 0 if all(row.get("check", "ok") == "ok" for row in rows) else 1
    for row in rows:
        plan = ", ".join(
            f"{p['subtask']}({', '.join(str(v) for k, v in p.items() if k != 'subtask')})" for p in row["plan"]
        )
        checked = f"  [{row['check']}]" if "check" in row else ""
        print(f"{row['task_id']:<28} {row['calls']:>3} calls  {plan}{checked}")
    where = f"checked on seed {args.check}" if args.check is not None else "not checked in simulation"
    print(
        f"\n{len(rows)} {args.family} task(s), draw seed {args.seed}: mean {mean_calls:.1f} primitive calls per task "
        f"(the paper: {PAPER_CALLS[args.family]}); {where}"
    )
    return 0 if all(row.get("check", "ok") == "ok" for row in rows) else 1


def _check_draw(tasks, seed: int) -> list[str]:
    """Each task once on its source robot, the rule backend, variations off: "ok" or why it failed."""
    import os
    import tempfile
    from pathlib import Path

    from lerobot_policy_recent.recent_plugin.agent import RecentAgent
    from lerobot_policy_recent.recent_plugin.episode import run_episode
    from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
    from lerobot_policy_recent.recent_plugin.settings import RecentSettings
    from lerobot_policy_recent.robosuite_envs.compose import draw_document
    from lerobot_policy_recent.robosuite_envs.suites import TASKS_ENV
    from lerobot_policy_recent.robosuite_envs.suites import tasks as registry

    family = tasks[0].suite
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "draw.json"
        path.write_text(json.dumps(draw_document(family, 0, tasks)))
        previous = os.environ.get(TASKS_ENV)
        os.environ[TASKS_ENV] = os.pathsep.join(filter(None, [previous, str(path)]))
        registry.cache_clear()
        try:
            agent = RecentAgent(RecentSettings(infiller=RuleConfig()))
            outcomes = []
            for spec in tqdm(tasks, desc="checking", unit="task", file=sys.stderr):
                result = run_episode(agent, spec.task_id, agent.source_robot(spec.task_id), seed=seed, variations="off")
                failure = result.failures[0].message if result.failures else result.unmet or "failed"
                outcomes.append("ok" if result.success else failure)
            return outcomes
        finally:
            if previous is None:
                os.environ.pop(TASKS_ENV, None)
            else:
                os.environ[TASKS_ENV] = previous
            registry.cache_clear()
