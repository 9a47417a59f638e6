"""What outside tools open: per-episode MCAP and Rerun file sizes, chunk counts and load times.

    .venv/bin/python -m benchmarks.log_files_bench [--task kinematic/tidy_bench] [--episodes 3]

Runs dev episodes (rule backend, dev seeds) into one log directory with every sink on, then per
episode: the MCAP's size, chunk count and the time ``mcap``'s indexed reader takes to read every
message; the ``.rrd``'s size, chunk count (``rerun rrd stats``) and the time Rerun's own reader takes
to decode it. Run it on two commits (a worktree of the older one) to compare.
"""

from __future__ import annotations

import argparse
import json
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from lerobot_policy_recent.logs.layout import LogLayout
from lerobot_policy_recent.logs.recorder import Recorder
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.settings import RecentSettings

DEV_SEEDS = (3, 7, 11)


def mcap_figures(path: Path) -> dict:
    from mcap.reader import make_reader

    started = time.perf_counter()
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        messages = sum(1 for _ in reader.iter_messages())
        summary = reader.get_summary()
    read_ms = 1000 * (time.perf_counter() - started)
    stats = summary.statistics
    window = stats.message_end_time - (stats.message_end_time - stats.message_start_time) // 10
    started = time.perf_counter()
    with open(path, "rb") as stream:  # what a viewer does when the user jumps to the end: the last tenth
        last = sum(1 for _ in make_reader(stream).iter_messages(starting_at=window))
    return {
        "mcap_kib": path.stat().st_size / 1024,
        "mcap_chunks": len(summary.chunk_indexes),
        "mcap_messages": messages,
        "mcap_read_ms": read_ms,
        "mcap_last_tenth_ms": 1000 * (time.perf_counter() - started),
        "mcap_last_tenth_messages": last,
    }


def rrd_figures(path: Path, rerun: str) -> dict:
    from rerun.chunk import RrdReader

    started = time.perf_counter()
    rows = sum(chunk.num_rows for chunk in RrdReader(str(path)).stream().collect().stream())
    seconds = time.perf_counter() - started
    stats = subprocess.run([rerun, "rrd", "stats", str(path)], capture_output=True, text=True).stdout
    chunks = re.search(r"num_chunks = (\d+)", stats)
    return {
        "rrd_kib": path.stat().st_size / 1024,
        "rrd_chunks": int(chunks.group(1)) if chunks else None,
        "rrd_rows": rows,
        "rrd_read_ms": 1000 * seconds,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", default="kinematic/tidy_bench")
    parser.add_argument("--robot", default="UR5e")
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    agent = RecentAgent(RecentSettings(infiller=RuleConfig()))
    rerun = str(Path(sys.executable).with_name("rerun"))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        with Recorder(tmp) as recorder:
            steps = [
                run_episode(agent, args.task, args.robot, seed=seed, recorder=recorder).steps
                for seed in DEV_SEEDS[: args.episodes]
            ]
        layout = LogLayout(Path(tmp))
        for episode in layout.committed():
            rows.append({**mcap_figures(layout.mcap(episode)), **rrd_figures(layout.rrd(episode), rerun)})
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    result = {
        "commit": commit,
        "machine": platform.processor() or platform.machine(),
        "task": args.task,
        "robot": args.robot,
        "steps_mean": statistics.mean(steps),
        **{key: round(statistics.median(r[key] for r in rows), 2) for key in rows[0] if rows[0][key] is not None},
    }
    print(json.dumps(result, indent=2))
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
