"""Logging overhead: the same episode with logging off and with MCAP + Rerun + dataset sinks on.

    .venv/bin/python -m benchmarks.logging_bench [--task kinematic/cube_on_plate] [--robot UR5e] [--episodes 4]

Target (issue "recording and replay"): with all three sinks on and no cameras, episode wall time
<= 1.10x the same episodes with logging off, measured side by side (interleaved) in one run. Each
setting is one run of N episodes into one log directory, timed from the first episode's start to
the last file closed. Also reported: the same with one 84x84 front camera logged, next to a run
that renders that camera and logs nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time

from lerobot_policy_recent.logs.recorder import SINKS, Recorder
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.settings import RecentSettings

SETTINGS = {  # name -> (sinks or None for no recorder, camera)
    "logging off": (None, False),
    "MCAP + Rerun + dataset": (SINKS, False),
    "84x84 camera rendered, no sinks": ((), True),
    "MCAP + Rerun + dataset + 84x84 camera": (SINKS, True),
}
BASELINE = {
    "MCAP + Rerun + dataset": "logging off",
    "MCAP + Rerun + dataset + 84x84 camera": "84x84 camera rendered, no sinks",
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="kinematic/cube_on_plate")
    parser.add_argument("--robot", default="UR5e")
    parser.add_argument("--episodes", type=int, default=4, help="episodes per setting (one run each)")
    args = parser.parse_args()
    agent = RecentAgent(RecentSettings(infiller=RuleConfig()))
    run_episode(agent, args.task, args.robot, seed=0)  # warm-up: imports, first env
    with tempfile.TemporaryDirectory() as tmp:
        recorders = {
            name: None if sinks is None else Recorder(f"{tmp}/{i}", sinks)
            for i, (name, (sinks, _)) in enumerate(SETTINGS.items())
        }
        seconds = dict.fromkeys(SETTINGS, 0.0)
        steps = 0
        names = list(SETTINGS)
        for episode in range(args.episodes):
            order = names[episode % len(names) :] + names[: episode % len(names)]  # rotated: no setting always first
            for name in order:  # interleaved: drift hits every setting alike
                camera = SETTINGS[name][1]
                started = time.perf_counter()
                result = run_episode(
                    agent, args.task, args.robot, seed=episode, recorder=recorders[name], camera=camera
                )
                seconds[name] += time.perf_counter() - started
                steps += result.steps if name == "logging off" else 0
        for name, recorder in recorders.items():  # the writes still queued count too
            if recorder is not None:
                started = time.perf_counter()
                recorder.close()
                seconds[name] += time.perf_counter() - started
    per_episode = {name: total / args.episodes for name, total in seconds.items()}
    print(
        f"\n{args.task} on {args.robot}, {args.episodes} episodes per setting (seeds 0..{args.episodes - 1}, "
        f"{steps / args.episodes:.0f} steps on average), rule backend, settings interleaved in rotating order"
    )
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}\n")
    print("| setting | wall time per episode (incl. final flush) | ratio to the same run without sinks |")
    print("|---|---:|---:|")
    for name, value in per_episode.items():
        base = BASELINE.get(name)
        ratio = f"{value / per_episode[base]:.3f}x" if base else ""
        print(f"| {name} | {value:.2f} s | {ratio} |")
    print(json.dumps({"episodes": args.episodes, "seconds_per_episode": per_episode}))


if __name__ == "__main__":
    main()
