"""Logging overhead: the same episode with logging off and with MCAP + Rerun + dataset sinks on.

    .venv/bin/python -m benchmarks.logging_bench [--task kinematic/tidy_bench] [--robot UR5e] [--repeats 3]

Target (issue "recording and replay"): with all three sinks on and no cameras, episode wall time
(grounding, every step, and writing the episode's files) <= 1.10x the same episode with logging
off, measured side by side (interleaved) in one run. Also reported: the same with one 84x84
front camera logged, next to the same episode rendering that camera without logging.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import tempfile
import time

from logs.recorder import Recorder
from recent_plugin.agent import AgentSettings, RecentAgent
from recent_plugin.episode import run_episode

SETTINGS = ("off", "on", "camera, no logging", "on + camera")


def one_episode(agent: RecentAgent, task: str, robot: str, setting: str) -> tuple[float, int]:
    """Wall seconds from env creation to the last log file closed, and the episode's steps."""
    camera = "camera" in setting
    with tempfile.TemporaryDirectory() as tmp:
        started = time.perf_counter()
        recorder = Recorder(tmp) if setting.startswith("on") else None
        try:
            result = run_episode(agent, task, robot, seed=0, recorder=recorder, camera=camera)
        finally:
            if recorder is not None:
                recorder.close()
        return time.perf_counter() - started, result.steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="kinematic/tidy_bench")
    parser.add_argument("--robot", default="UR5e")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    agent = RecentAgent(AgentSettings(backend="rule"))
    for setting in SETTINGS:  # warm-up: imports, first dataset, first renderer
        one_episode(agent, args.task, args.robot, setting)
    times: dict[str, list[float]] = {s: [] for s in SETTINGS}
    steps = 0
    for _ in range(args.repeats):
        for setting in SETTINGS:  # interleaved, so drift hits every setting alike
            seconds, steps = one_episode(agent, args.task, args.robot, setting)
            times[setting].append(seconds)
    median = {s: statistics.median(t) for s, t in times.items()}
    rows = [
        ("logging off", median["off"], None),
        ("MCAP + Rerun + dataset, no camera", median["on"], median["on"] / median["off"]),
        ("84x84 camera rendered, no logging", median["camera, no logging"], None),
        (
            "MCAP + Rerun + dataset + 84x84 camera",
            median["on + camera"],
            median["on + camera"] / median["camera, no logging"],
        ),
    ]
    print(f"\n{args.task} on {args.robot}, {steps} steps, rule backend, median of {args.repeats} (interleaved)")
    print(f"{platform.processor() or platform.machine()}, Python {platform.python_version()}\n")
    print("| setting | episode wall time | ratio to the same episode without logging |")
    print("|---|---:|---:|")
    for name, seconds, ratio in rows:
        print(f"| {name} | {seconds:.2f} s | {'' if ratio is None else f'{ratio:.3f}x'} |")
    print(json.dumps({"steps": steps, "median_seconds": median}))


if __name__ == "__main__":
    main()
