"""Executor overhead per control step, and what the skill budget's meter costs.

``TaskExecutor.act`` is timed per step (in-situ checks included; steps that called an LM and
``env.step`` excluded) over dev episodes with the rule backend, so the number is the executor's
own. Run it on two commits (a worktree of the older one) to compare; the meter's unit costs
(a loop tick, a metered ``+``) are measured in isolation beside it.

    .venv/bin/python -m benchmarks.executor_bench --json benchmarks/measured/executor_bench.json
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import subprocess
import timeit

from benchmarks.grounding_bench import executor_overhead
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.settings import RecentSettings

EPISODES = (  # dev tasks on dev seeds: a short kinematic task, a paper-length one, an end-effector one
    ("cube_in_bin", "UR5e", 3),
    ("kinematic/tidy_bench", "UR5e", 3),
    ("end_effector/open_drawer", "Robotiq85", 7),
)


def meter_costs() -> dict[str, float]:
    """Nanoseconds per metered operation, against the plain operation."""
    try:
        from lerobot_policy_recent.recent_plugin.sandbox import Meter, SkillBudget
    except ImportError:  # a commit before the meter
        return {}
    meter = Meter(SkillBudget())
    meter.enter()
    n = 200_000
    xs = [0.1, 0.2, 0.3]
    return {
        "tick_ns": 1e9 * timeit.timeit(meter.tick, number=n) / n,
        "metered_add_ns": 1e9 * timeit.timeit(lambda: meter.binop("+", xs, xs), number=n) / n,
        "plain_add_ns": 1e9 * timeit.timeit(lambda: xs + xs, number=n) / n,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", default=None, help="also write the numbers here")
    args = parser.parse_args()
    agent = RecentAgent(RecentSettings(infiller=RuleConfig()))
    timings: list[float] = []
    for task_id, robot, seed in EPISODES:
        timings += executor_overhead(agent, task_id, robot, seed)
    ms = sorted(1000 * t for t in timings)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    result = {
        "commit": commit,
        "machine": f"{platform.processor() or platform.machine()}, {platform.node()}",
        "steps_timed": len(ms),
        "executor_step_median_ms": round(statistics.median(ms), 4),
        "executor_step_p95_ms": round(ms[int(0.95 * (len(ms) - 1))], 4),
        **{k: round(v, 1) for k, v in meter_costs().items()},
    }
    print(json.dumps(result, indent=2))
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(result, handle, indent=2)


if __name__ == "__main__":
    main()
