"""``recent bench``: the paper's evaluation on our suites; ``recent bench report``: its tables and plots;
``recent bench compare``: whether a re-run reproduced a committed run."""

from __future__ import annotations

import datetime as dt
import json
import shlex
import sys
from collections import Counter
from pathlib import Path

from lerobot_policy_recent.evaluation.methods import METHODS, model_of, parse_methods
from lerobot_policy_recent.evaluation.runner import PACKED
from lerobot_policy_recent.robosuite_envs.splits import TEST_DRAW
from lerobot_policy_recent.robosuite_envs.suites import SEEDS, SUITES


def register(sub) -> None:
    parser = sub.add_parser(
        "bench",
        help="run RECENT, its ablations and baselines on the task suites (resumable); `bench report` renders tables",
        description="Run every (method, task, target, seed) episode of a suite into DIR (finished episodes are "
        "skipped on restart), then write DIR/results.json and DIR/report.md.",
    )
    parser.add_argument("--suite", default="kinematic", help=f"comma list of {', '.join(SUITES)} (default: kinematic)")
    parser.add_argument(
        "--target", default="", help="comma list of robots (default: the suite's: UR5e,Sawyer | Robotiq85,Suction)"
    )
    parser.add_argument(
        "--method", default="recent", help=f"comma list, or all: {', '.join(METHODS)} (default: recent)"
    )
    parser.add_argument(
        "--models",
        default="",
        help="comma list of models of the --infiller backend (known names or .gguf paths): every method runs on "
        "each, as rows `method@model` of every table (the --infiller.model's rows keep their plain names; a method "
        "with a model of its own, such as cap-distilled, runs once); default: --infiller.model alone. "
        "`--method=recent@MODEL` names one such row",
    )
    parser.add_argument("--seeds", default=",".join(map(str, SEEDS)), help="comma list (default: the paper's five)")
    parser.add_argument("--tasks", default="", help="comma list of task names within the suite (default: all)")
    parser.add_argument(
        "--variations",
        default="mix",
        help="mix (default: every variation, each episode drawing each variation with its stated share, seeded), "
        "on (the paper's three), off, all, or a comma list",
    )
    parser.add_argument("--out", default="outputs/bench", help="run directory (default: outputs/bench)")
    parser.add_argument(
        "--workers",
        type=int,
        default=0,
        help="Ray workers, each with its own LM (default: as many as the cluster's CPUs hold at --cpus_per_worker). "
        "Timings such as IT and IGT are the targets' only with 1 worker on 2 threads per 2 cores: workers compete "
        "for a machine's CPU",
    )
    parser.add_argument(
        "--cpus_per_worker",
        type=float,
        default=None,
        help="CPUs a worker reserves, and its LM's threads unless --infiller.n_threads is set "
        "(default: 2, or the cluster's CPUs shared by --workers)",
    )
    parser.add_argument(
        "--gpus_per_worker",
        type=float,
        default=None,
        help="GPUs a worker reserves (default: 1 for --infiller.type=transformers on a cluster with GPUs, else 0)",
    )
    parser.add_argument(
        "--ray_address",
        default=None,
        help="an existing Ray cluster, e.g. 10.0.0.5:6379 (default: $RAY_ADDRESS, else a local Ray instance)",
    )
    parser.add_argument(
        "--retry_crashed",
        action="store_true",
        help="run again the episodes an error broke off (their records say 'crash'); otherwise a rerun skips them",
    )
    parser.add_argument(
        "--split",
        choices=("all", "dev", "test"),
        default="all",
        help="run only the dev episodes, or only the held-out test ones (test tasks on the paper's seeds; "
        "`recent envs list` marks them); the report shows each split apart either way",
    )
    parser.add_argument("--no_log", action="store_true", help="no logs (MCAP, Rerun, the run's LeRobotDataset)")
    parser.add_argument("--log_sinks", default="mcap,rerun,dataset", help="sinks of the run's logs in DIR/logs")
    from lerobot_policy_recent.scripts.common import add_settings_arguments

    add_settings_arguments(parser, with_method=False)
    parser.set_defaults(handler=_run)
    sub_bench = parser.add_subparsers(dest="bench_command", metavar="{report,headline,compare,pack}")
    report = sub_bench.add_parser("report", help="tables (markdown) and plots (PNG) from one or more run directories")
    report.add_argument("dirs", nargs="+", help="run directories written by `recent bench`")
    report.add_argument(
        "--out", dest="report_out", default=None, help="where report.md and the PNGs go (default: the first DIR)"
    )
    report.set_defaults(handler=_report)
    headline = sub_bench.add_parser(
        "headline",
        help="DIR/headline.md: the README's results table, test split only, with a caption written from the records",
        description="The caption states what the records say was run: split, tasks with their primitive calls, the "
        "LM-call budget per task, seeds, model, backend, temperature, machine, engine, commit and dates. A "
        "directory whose episodes ran at several commits, or with local edits, says so in the caption.",
    )
    headline.add_argument("dir", help="a `recent bench --out` directory (packed or not)")
    headline.set_defaults(handler=_headline)
    compare = sub_bench.add_parser(
        "compare",
        help="whether RERUN reproduced REFERENCE, episode by episode (exit 1 if an outcome or the model differs, "
        "3 if it covers too little of REFERENCE)",
        description="Compare the episodes two run directories share: success, GC, steps, failure category, "
        "GO and tokens must be identical (the simulation and the LM's sampling are seeded); IT and IGT are reported "
        "as ratios (the host's speed). The reference's episodes the re-run lacks are listed, and the two "
        "results.json are compared: another model sha256 or backend is another experiment; another commit or "
        "settings tree is flagged. Exit status: 0 reproduced; 1 an outcome differs or the model differs; "
        "3 every shared episode is identical but the re-run covers less than --min_coverage of the reference.",
    )
    compare.add_argument("reference", help="the run to reproduce, e.g. results/snapshot")
    compare.add_argument("rerun", help="a `recent bench --out` directory re-running some of its episodes")
    compare.add_argument(
        "--min_coverage",
        type=float,
        default=1.0,
        help="fraction of the reference's episodes the re-run must hold to be called reproduced (default: 1.0); "
        "state it when you report a sliced re-run",
    )
    compare.set_defaults(handler=_compare)
    pack = sub_bench.add_parser(
        "pack",
        help="put a finished run's per-episode records into one compressed file (how results/ commits runs)",
        description=f"Write DIR/{PACKED} from DIR/episodes/ and remove the per-episode files; report, compare "
        "and resume read either form. Where the run kept logs, also write DIR/lm_calls.jsonl.gz: every prompt, "
        "answer, verdict and patch with its episode, for review. The logs (DIR/logs) are not touched: they "
        "belong in a dataset.",
    )
    pack.add_argument("dir", help="a `recent bench --out` directory")
    pack.set_defaults(handler=_pack)


def _csv(text: str) -> tuple[str, ...]:
    return tuple(t.strip() for t in text.split(",") if t.strip())


def _run(args) -> int:
    from tqdm import tqdm

    from lerobot_policy_recent.evaluation.metrics import crashed
    from lerobot_policy_recent.evaluation.report.document import render_report
    from lerobot_policy_recent.evaluation.report.provenance import results_document
    from lerobot_policy_recent.evaluation.runner import (
        BenchConfig,
        load_records,
        machine,
        pending,
        run_bench,
        write_json,
    )
    from lerobot_policy_recent.recent_plugin.models import model_sha256
    from lerobot_policy_recent.scripts.common import settings_from_args

    suites = _csv(args.suite)
    unknown = [s for s in suites if s not in SUITES]
    if unknown:
        raise ValueError(f"unknown suite(s) {', '.join(unknown)}; choose from {', '.join(SUITES)}")
    settings = settings_from_args(args)
    config = BenchConfig(
        out=Path(args.out),
        suites=suites,
        targets=_csv(args.target),
        methods=tuple(parse_methods(args.method, _csv(args.models), getattr(settings.infiller, "model", None))),
        seeds=tuple(int(s) for s in _csv(args.seeds)),
        tasks=_csv(args.tasks),
        variations=args.variations,
        workers=args.workers,
        cpus_per_worker=args.cpus_per_worker,
        gpus_per_worker=args.gpus_per_worker,
        ray_address=args.ray_address,
        log_sinks=() if args.no_log else _csv(args.log_sinks),
        agent=settings,
        retry_crashed=args.retry_crashed,
        split=args.split,
    )
    jobs, todo = pending(config)
    commit = git_commit()  # the code the workers load now, whatever the checkout holds when the run ends
    print(f"{len(jobs)} episodes ({len(jobs) - len(todo)} already done) -> {config.out}", file=sys.stderr)
    bar = tqdm(total=len(jobs), initial=len(jobs) - len(todo), unit="episode", desc="bench")
    counts = Counter()

    def show(last: str) -> None:
        tally = ", ".join(f"{counts[k]} {k}" for k in ("ok", "failed", "crashed", "retried") if counts[k])
        bar.set_postfix_str(f"{tally} | {last}")

    def on_record(record: dict) -> None:
        counts["crashed" if crashed(record) else "ok" if record["success"] else "failed"] += 1
        show(f"{record['method']} {record['task_id'].split('/')[-1]} {record['target']}: "
             f"{'ok' if record['success'] else record.get('failure_category') or 'fail'}")  # fmt: skip
        bar.update(1)

    def on_retry(job, reason: str) -> None:
        counts["retried"] += 1
        show(f"{reason}: {job.method} {job.task_id.split('/')[-1]} {job.target} queued again")

    try:
        run = run_bench(config, on_record=on_record, on_retry=on_retry, stamp={"commit": commit})
    finally:
        bar.close()
    header = {
        "command": command_line(config),
        "date": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "git_commit": commit,
        "config": run_settings(config),
        "backend": settings.infiller.backend,
        "model": getattr(settings.infiller, "model", ""),
        "model_sha256": model_sha256(settings.infiller.model) if hasattr(settings.infiller, "model") else None,
        **_row_models(config.methods),
        "max_retries": settings.max_retries,
        "machine": machine(),
        **run.plan,  # engine, address, workers and the resources each reserved
        "suites": list(config.suites),
        "targets": list(config.targets) or "per suite",
        "methods": list(config.methods),
        "seeds": list(config.seeds),
        "tasks": list(config.tasks) or "all",
        "variations": config.variations,
        "split": config.split,
        "test_draw": dict(TEST_DRAW),  # the test draw's seeds in force (None: no test draw, every episode dev)
    }
    results = config.out / "results.json"
    runs = json.loads(results.read_text()).get("runs", []) if results.exists() else []
    records = load_records(config.out)  # every episode in DIR: runs with other settings share it
    runs = [*runs, header]
    write_json(results, {**results_document(records, header, runs), "runs": runs})
    report = render_report([config.out], config.out)
    print(f"{len(records)} episodes; results: {config.out / 'results.json'}; report: {report}")
    broken = [r for r in run.records if crashed(r)]  # the grid asked for is not done while any crashed
    if broken:  # what was asked was not done: say which, and how to finish it
        for r in broken:
            print(
                f"crashed: {r['method']} {r['task_id']} on {r['target']} seed {r['seed']}: {r.get('crashed')}",
                file=sys.stderr,
            )
        print(
            f"{len(broken)} of {len(run.records)} episodes crashed (in no aggregate); "
            "fix the cause, then rerun the same command with --retry_crashed",
            file=sys.stderr,
        )
        return 1
    return 0


def _row_models(rows) -> dict:
    """``row_models``: the model and its sha256 of each ``method@model`` row (nothing where none names one)."""
    from lerobot_policy_recent.recent_plugin.models import model_sha256

    named = {row: model_of(row) for row in rows if model_of(row) is not None}
    return (
        {"row_models": {row: {"model": m, "model_sha256": model_sha256(m)} for row, m in named.items()}}
        if named
        else {}
    )


def git_commit() -> str | None:
    """The commit the run's code came from (None outside a git checkout), with ``+dirty`` for local edits."""
    import subprocess

    root = Path(__file__).resolve().parents[1]
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, check=True)
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"], cwd=root, capture_output=True, text=True
        )
    except (OSError, subprocess.CalledProcessError):
        return None
    return commit.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")


def run_settings(config) -> dict:
    """The resolved settings tree of a run, without ``method`` (the run's methods are listed by name)."""
    return {key: value for key, value in config.agent.to_dict().items() if key != "method"}


def command_line(config) -> str:
    """The ``recent bench`` command that reproduces ``config`` (what results.json records): every setting, resolved."""
    from lerobot_policy_recent.recent_plugin.settings import settings_flags

    words = ["recent", "bench", f"--suite={','.join(config.suites)}", f"--method={','.join(config.methods)}"]
    words += [f"--seeds={','.join(map(str, config.seeds))}", f"--variations={config.variations}"]
    words += [f"--target={','.join(config.targets)}"] if config.targets else []
    words += [f"--tasks={','.join(config.tasks)}"] if config.tasks else []
    words += [f"--split={config.split}"] if config.split != "all" else []
    words += settings_flags(run_settings(config))
    words += [f"--workers={config.workers}"] if config.workers else []
    words += [f"--cpus_per_worker={config.cpus_per_worker:g}"] if config.cpus_per_worker is not None else []
    words += [f"--gpus_per_worker={config.gpus_per_worker:g}"] if config.gpus_per_worker is not None else []
    words += [f"--out={config.out}"]
    words += [f"--log_sinks={','.join(config.log_sinks)}"] if config.log_sinks else ["--no_log"]
    return shlex.join(words)


def _report(args) -> int:
    from lerobot_policy_recent.evaluation.report.document import render_report

    dirs = [Path(d) for d in args.dirs]
    path = render_report(dirs, Path(args.report_out) if args.report_out else dirs[0])
    print(path.read_text())
    print(f"written: {path} (+ sr_vs_go.png, failures_by_method.png, and paired.png where methods share episodes)")
    return 0


def _headline(args) -> int:
    from lerobot_policy_recent.evaluation.headline import render_headline

    path = render_headline(Path(args.dir))
    print(path.read_text())
    print(f"written: {path}")
    return 0


def _pack(args) -> int:
    from lerobot_policy_recent.evaluation.runner import LM_CALLS, has_records, pack_lm_calls, pack_records

    out = Path(args.dir)
    if not has_records(out):
        raise FileNotFoundError(f"{out} holds no episode records: is it a `recent bench --out` directory?")
    count = pack_records(out)
    print(f"{count} episode records -> {out / PACKED}")
    calls = pack_lm_calls(out)
    if calls:
        print(f"{calls} prompts, answers, verdicts and patches from its logs -> {out / LM_CALLS}")
    return 0


def _compare(args) -> int:
    from lerobot_policy_recent.evaluation.compare import compare_dirs

    if not 0.0 < args.min_coverage <= 1.0:
        raise ValueError(f"--min_coverage must be in (0, 1], got {args.min_coverage}")
    run, text = compare_dirs(Path(args.reference), Path(args.rerun), args.min_coverage)
    print(text)
    return {"reproduced": 0, "partial": 3}.get(run.verdict, 1)
