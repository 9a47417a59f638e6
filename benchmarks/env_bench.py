"""Env benchmark: our env's steps/s next to bare robosuite Lift, reset time, primitive controller cost.

    .venv/bin/python -m benchmarks.env_bench [--robot Panda] [--steps 200] [--rounds 15] [--resets 20]

Targets (issue "robosuite world"): steps/s without cameras within 20% of bare robosuite Lift with
the same robot and controller, measured in the same run; reset <= 0.5 s; primitive controller
cost per step <= 0.2 ms median. The execution issue adds: within 20% of Lift on the longest task's
scene (``--scene``). The three envs take turns, block by block, and each ratio is the median of
the rounds' ratios: on a shared host the load changes within minutes, so rates taken apart, or a
ratio of medians, measure the host as much as the env (BENCHMARKS.md, "Env").
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time

import numpy as np

import lerobot_policy_recent.robosuite_envs.runtime  # noqa: F401  (MuJoCo GL backend before robosuite loads)
from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
from lerobot_policy_recent.robosuite_envs.observation import Observation
from lerobot_policy_recent.robosuite_envs.primitives.control import move_to
from lerobot_policy_recent.robosuite_envs.primitives.session import CONTROL_FREQ, RobotSession

HOLD = np.zeros(7)


def steps_per_second(step, n: int) -> float:
    started = time.perf_counter()
    for _ in range(n):
        step(HOLD)
    return n / (time.perf_counter() - started)


def bare_lift(robot: str):
    import robosuite
    from robosuite.controllers import load_composite_controller_config

    return robosuite.make(
        "Lift",
        robots=robot,
        controller_configs=load_composite_controller_config(controller="BASIC", robot=robot),
        has_renderer=False,
        has_offscreen_renderer=False,
        use_camera_obs=False,
        ignore_done=True,
        control_freq=CONTROL_FREQ,
        horizon=10**9,
    )


def controller_cost(samples: int) -> list[float]:
    """Wall time of one step of a closed-loop primitive (observation in, action out), no simulator."""
    obs = Observation(np.zeros(3), np.array([0.0, 1.0, 0.0, 0.0]), 0.0, {})
    session = RobotSession("Panda", obs)
    steps = move_to(session, [0.5, 0.0, 1.0], timeout_s=samples / CONTROL_FREQ + 1)
    times = []
    for _ in range(samples):
        started = time.perf_counter()
        next(steps)
        times.append(time.perf_counter() - started)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robot", default="Panda")
    parser.add_argument("--task", default="cube_in_bin", help="compared with Lift (one cube + a bin: like for like)")
    parser.add_argument(
        "--scene", default="kinematic/plate_clear_switch", help="a full suite scene (default: the longest task's)"
    )
    parser.add_argument("--steps", type=int, default=200, help="steps per block")
    parser.add_argument("--rounds", type=int, default=15, help="blocks of each env, taken in turn")
    parser.add_argument("--resets", type=int, default=20)
    parser.add_argument("--json", help="also write the results here")
    args = parser.parse_args()

    ours = RecentEnv(task=args.task, robot=args.robot, render_mode="none", max_episode_steps=10**9)
    ours.reset(seed=0)
    lift = bare_lift(ours.embodiment.robot)
    lift.reset()
    scene = RecentEnv(task=args.scene, robot=args.robot, render_mode="none", max_episode_steps=10**9)
    scene.reset(seed=0)
    stepping = {"ours": ours.step, "lift": lift.step, "scene": scene.step}
    rates: dict[str, list[float]] = {name: [] for name in stepping}
    for _ in range(args.rounds):  # in turn, so that all three see the same machine load
        for name, step in stepping.items():
            rates[name].append(steps_per_second(step, args.steps))
    scene.close()

    def ratio_to_lift(name: str) -> float:
        return statistics.median(a / b for a, b in zip(rates[name], rates["lift"], strict=True))

    resets = []
    for seed in range(args.resets):
        started = time.perf_counter()
        ours.reset(seed=seed)
        resets.append(time.perf_counter() - started)
    cost = controller_cost(2000)
    ours.close()
    lift.close()

    results = {
        "machine": f"{platform.processor() or platform.machine()}, {platform.system()}",
        "date": time.strftime("%Y-%m-%d"),
        "robot": args.robot,
        "task": args.task,
        "ours_steps_per_s": statistics.median(rates["ours"]),
        "lift_steps_per_s": statistics.median(rates["lift"]),
        "ours_over_lift": ratio_to_lift("ours"),
        "scene": args.scene,
        "scene_steps_per_s": statistics.median(rates["scene"]),
        "scene_over_lift": ratio_to_lift("scene"),
        "reset_median_s": statistics.median(resets),
        "reset_max_s": max(resets),
        "controller_median_ms": statistics.median(cost) * 1000,
        "controller_p95_ms": float(np.percentile(cost, 95)) * 1000,
    }
    print(f"env benchmark — {results['machine']} — {results['date']} — {args.robot}, {args.task}")
    print("| measure | value | target |")
    print("|---|---|---|")
    blocks = f"median of {args.rounds} x {args.steps}"
    print(f"| our env, steps/s (no cameras, {blocks}) | {results['ours_steps_per_s']:.0f} | — |")
    print(f"| bare robosuite Lift, same robot and controller | {results['lift_steps_per_s']:.0f} | — |")
    print(f"| ratio ours / Lift (median of the rounds') | {results['ours_over_lift']:.2f} | >= 0.80 |")
    print(f"| {args.scene} (a full suite scene: more bodies to simulate) | {results['scene_steps_per_s']:.0f} | — |")
    print(f"| ratio {args.scene} / Lift (median of the rounds') | {results['scene_over_lift']:.2f} | >= 0.80 |")
    print(
        f"| reset, median of {args.resets} (max) | {results['reset_median_s'] * 1000:.0f} ms ({results['reset_max_s'] * 1000:.0f} ms) | <= 500 ms |"
    )
    print(
        f"| primitive controller per step, median (p95) | {results['controller_median_ms']:.3f} ms ({results['controller_p95_ms']:.3f} ms) | <= 0.2 ms |"
    )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(results, fh, indent=2)


if __name__ == "__main__":
    main()
