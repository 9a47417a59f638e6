"""Grounding in a new process with the on-disk store: the first process grounds, the next ones read back.

    .venv/bin/python -m benchmarks.grounding_cache_bench [--task kinematic/tidy_bench] [--robot UR5e] [--processes 3]

Target (issue "grounding at the paper's latency"): IGT for a task whose skills were grounded in an
earlier process <= 50 ms. Each process loads the default LM (not timed), then grounds every skill
of the task's plan; the time is that grounding, as the agent's IGT measures it.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

CHILD = """
import json, sys, time
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.robosuite_envs.suites import get_task
agent = RecentAgent()
task = get_task(sys.argv[1])
started = time.perf_counter()
hits = [agent.ground(step.skill, sys.argv[2], task)[1] for step in task.plan]
print(json.dumps({"seconds": time.perf_counter() - started, "hits": hits}))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="kinematic/tidy_bench")
    parser.add_argument("--robot", default="UR5e")
    parser.add_argument("--processes", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as store:
        env = {**os.environ, "RECENT_GROUNDING_CACHE": store}
        print("| process | skills | served from disk | grounding (s) |\n|---:|---:|---:|---:|")
        for n in range(1, args.processes + 1):
            out = subprocess.run(
                [sys.executable, "-c", CHILD, args.task, args.robot],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            )
            row = json.loads(out.stdout.strip().splitlines()[-1])
            print(f"| {n} | {len(row['hits'])} | {sum(row['hits'])} | {row['seconds']:.3f} |")


if __name__ == "__main__":
    main()
