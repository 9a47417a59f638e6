"""``recent logs verify``, ``recent failures report``, ``recent replay``, ``recent upload``: the logs of runs."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from lerobot_policy_recent.logs.recorder import SINKS

DEFAULT_LOG_DIR = "outputs/recent_logs"


def add_log_arguments(parser: argparse.ArgumentParser) -> None:
    """``--log_dir`` / ``--no_log`` / ``--log_sinks`` / ``--camera`` for commands that run episodes."""
    group = parser.add_argument_group("logging (MCAP, Rerun, LeRobotDataset)")
    group.add_argument(
        "--log_dir", default=DEFAULT_LOG_DIR, help=f"where episodes are logged (default: {DEFAULT_LOG_DIR})"
    )
    group.add_argument("--no_log", action="store_true", help="log nothing")
    group.add_argument("--log_sinks", default=",".join(SINKS), help=f"comma list of sinks (default: {','.join(SINKS)})")
    group.add_argument("--camera", action="store_true", help="also log an 84x84 front camera")


def recorder_from_args(args: argparse.Namespace):
    if args.no_log:
        return None
    from lerobot_policy_recent.logs.recorder import Recorder

    return Recorder(args.log_dir, [s.strip() for s in args.log_sinks.split(",") if s.strip()])


def register(sub) -> None:
    logs = sub.add_parser("logs", help="check and salvage logged runs").add_subparsers(
        dest="logs_command", required=True
    )
    verify = logs.add_parser("verify", help="every file readable, counts consistent across MCAP, Rerun and dataset")
    verify.add_argument("dir", help="a log directory (e.g. outputs/recent_logs)")
    verify.add_argument("--recover", action="store_true", help="salvage MCAP/Rerun files of interrupted episodes")
    verify.add_argument("--json", action="store_true", help="print one JSON object")
    verify.set_defaults(handler=_verify)

    failures = sub.add_parser("failures", help="failure categories of logged runs").add_subparsers(
        dest="failures_command", required=True
    )
    report = failures.add_parser("report", help="print the failure table and write a bar chart")
    report.add_argument("dirs", nargs="+", help="log directories, or directories holding them (a bench run's DIR/logs)")
    report.add_argument("--out", default=None, help="PNG path (default: DIR/failures.png of the first DIR)")
    report.set_defaults(handler=_failures)

    replay = sub.add_parser(
        "replay", help="open an episode in the Rerun viewer, or rebuild its recording from the dataset or its MCAP"
    )
    replay.add_argument("path", help="an .rrd or .mcap file, or a log directory (with --episode)")
    replay.add_argument("--episode", type=int, default=None, help="episode index in a log directory")
    replay.add_argument(
        "--out",
        default=None,
        help="write the rebuilt .rrd here (from a log directory, default DIR/replay/episode_N.rrd; from an .mcap, required)",
    )
    replay.add_argument("--no_viewer", action="store_true", help="only write the recording")
    replay.set_defaults(handler=_replay)

    upload = sub.add_parser("upload", help="push a log directory's datasets to the Hugging Face Hub")
    upload.add_argument("dir", help="a log directory")
    upload.add_argument("--repo_id", required=True, help="ORG/NAME of the dataset repository")
    upload.add_argument("--private", action="store_true", help="create the repository private")
    upload.add_argument("--with_recordings", action="store_true", help="also upload the MCAP and Rerun files")
    upload.add_argument(
        "--dry_run", action="store_true", help="check everything and list what would be pushed; push nothing"
    )
    upload.set_defaults(handler=_upload)


def _verify(args) -> int:
    from lerobot_policy_recent.logs.verify import recover, verify

    recovered = recover(args.dir) if args.recover else []
    report = verify(args.dir)
    if args.json:
        print(
            json.dumps(
                {
                    "ok": report.ok,
                    "episodes": [
                        {"episode": e.episode, "steps": e.steps, "events": e.events, "problems": e.problems}
                        for e in report.episodes
                    ],
                    "problems": report.problems,
                    "salvaged": [dataclasses.asdict(s) for s in recovered],
                },
                indent=2,
            )
        )
        return 0 if report.ok else 1
    for salvaged in recovered:
        print(f"recovered {salvaged}")
    if args.recover and not recovered:
        print("nothing to recover: no interrupted episode in this directory")
    for e in report.episodes:
        mark = "ok " if e.ok else "BAD"
        steps = ", ".join(f"{k} {v}" for k, v in e.steps.items())
        events = ", ".join(f"{k} {v}" for k, v in e.events.items())
        print(f"{mark} episode {e.episode}: steps [{steps}]  events [{events}]")
        for problem in e.problems:
            print(f"    {problem}")
    for line in report.recovered:
        print(f"    {line}")
    for problem in report.problems:
        print(f"problem: {problem}")
    print(f"{len(report.episodes)} episode(s) in {report.root}: {'all consistent' if report.ok else 'problems found'}")
    return 0 if report.ok else 1


def _failures(args) -> int:
    from lerobot_policy_recent.logs.failure_report import failure_table, plot_failures

    missing = [d for d in args.dirs if not Path(d).is_dir()]
    if missing:
        raise FileNotFoundError(f"no such log directory: {', '.join(missing)}")
    table = failure_table(args.dirs)
    if not table.episodes:
        raise ValueError(f"no logged episodes under {', '.join(args.dirs)} (a log directory holds results/)")
    print(table.markdown())
    out = Path(args.out) if args.out else Path(args.dirs[0]) / "failures.png"
    print(f"\n{table.episodes} episode(s); bar chart: {plot_failures(table, out)}")
    return 0


def _replay(args) -> int:
    from lerobot_policy_recent.logs.replay import ViewerError, default_output, open_viewer, replay_episode, replay_mcap

    path = Path(args.path)
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist")
    if path.is_dir():
        if args.episode is None:
            raise ValueError(f"{path} is a log directory: choose an episode with --episode N")
        path = replay_episode(path, args.episode, Path(args.out) if args.out else default_output(path, args.episode))
        print(f"wrote {path}")
    elif args.episode is not None:
        raise ValueError(f"--episode chooses an episode of a log directory; {path} is one episode's file")
    elif path.suffix == ".mcap" and args.out:
        from lerobot_policy_recent.logs.readers import read_mcap

        contents = read_mcap(path)
        path = replay_mcap(path, Path(args.out))
        print(f"wrote {path}")
        if not contents.complete:
            print(
                f"warning: {args.path} was cut short (it has no summary or footer: a crash, or a partial copy); "
                f"the recording holds what was written before the cut, {contents.steps} steps and "
                f"{len(contents.events)} events, and whatever came after it is lost",
                file=sys.stderr,
            )
    elif args.out:
        raise ValueError(
            f"{path} is a Rerun recording already: --out rebuilds one from an episode's MCAP "
            f"(recent replay FILE.mcap --out FILE.rrd) or from a log directory "
            f"(recent replay DIR --episode N --out FILE.rrd); open this one with `recent replay {path}`"
        )
    elif args.no_viewer:
        raise ValueError(
            f"nothing to do: --no_viewer opens no viewer and no --out was given to write a recording from {path}"
        )
    if not args.no_viewer:
        try:
            open_viewer(path)
        except ViewerError as error:
            raise RuntimeError(str(error)) from None
        print(f"opened {path} in the Rerun viewer")
    return 0


def _upload(args) -> int:
    from lerobot_policy_recent.logs.upload import check_repo_id, upload, upload_plan

    if args.dry_run:
        check_repo_id(args.repo_id)
        for folder, into in upload_plan(args.dir, recordings=args.with_recordings):
            files = sum(1 for p in folder.rglob("*") if p.is_file())
            print(f"would push {folder} ({files} files) to {args.repo_id}:{into or '/'}")
        print(f"would write the dataset card README.md; nothing was pushed (dataset repo {args.repo_id})")
        return 0
    url = upload(args.dir, args.repo_id, private=args.private, recordings=args.with_recordings)
    print(f"uploaded {args.dir} to {url}", file=sys.stdout)
    return 0
