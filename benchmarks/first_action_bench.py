"""Time to a first action with the product's default method, for (skill, robot) pairs never grounded before.

    .venv/bin/python -m benchmarks.first_action_bench [--skills S,..] [--robots R,..] [--threads 2]

Target (issue "the transfer matrix"): where the ontology decides every span, the time from asking
for a skill on a robot to the first control action, grounding included, <= 1 s on 2 CPU threads.
The LM spans' figure is reported beside it. Per pair: the skill's single-subtask task is reset
(not timed), then the agent grounds the plan (no grounding cache) and builds the executor, and
the executor computes its first action. The LM (the default GGUF) is loaded once before (not
timed: "1.5B Q4_K_M load" in BENCHMARKS.md); each robot's calibration is read from its cache.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skills", default="put_in_bin,press_button,wipe_area,open_drawer,stack_tower,insert_peg")
    parser.add_argument("--robots", default="")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    os.environ["RECENT_GROUNDING_CACHE"] = "off"  # every pair is grounded for the first time

    from lerobot_policy_recent.descriptions.embodiments import EMBODIMENTS
    from lerobot_policy_recent.recent_plugin.agent import RecentAgent
    from lerobot_policy_recent.recent_plugin.infillers.configs import LlamaCppConfig
    from lerobot_policy_recent.recent_plugin.settings import RecentSettings
    from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
    from lerobot_policy_recent.robosuite_envs.suites import validation_task

    agent = RecentAgent(RecentSettings(infiller=LlamaCppConfig(n_threads=args.threads)))  # the product default
    robots = [r for r in args.robots.split(",") if r] or list(EMBODIMENTS)
    rows: dict[str, list[float]] = {"ontology": [], "lm": []}
    print("| skill | robot | grounded by | first action (s) |\n|---|---|---|---:|")
    for name in args.skills.split(","):
        skill = agent.skill(name)
        task = validation_task(skill.subtask).task_id
        for robot in robots:
            if robot == skill.source_embodiment:
                continue
            env = RecentEnv(task=task, robot=robot, render_mode="none")
            try:
                env.reset(seed=3)
                obs = env._env.observe()
                started = time.perf_counter()
                executor, report = agent.start_episode(task, robot, obs)
                if not all(g.valid for g in report.skills):
                    print(f"| `{name}` | {robot} | not grounded | – |")
                    continue
                executor.act(obs)
                seconds = time.perf_counter() - started
            finally:
                env.close()
            by = "lm" if any(not c.rendered for g in report.skills for c in g.calls) else "ontology"
            rows[by].append(seconds)
            print(f"| `{name}` | {robot} | {by} | {seconds:.3f} |")
    for by, values in rows.items():
        if values:
            print(f"\n{by}: {len(values)} pairs, median {statistics.median(values):.3f} s, max {max(values):.3f} s")


if __name__ == "__main__":
    main()
