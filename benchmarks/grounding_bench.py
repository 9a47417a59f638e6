"""Grounding benchmark: IGT, IT, GO, per-step executor overhead, LM speed and memory with the real GGUF.

    .venv/bin/python -m benchmarks.grounding_bench [--model qwen2.5-coder-1.5b] [--threads 2] [--seeds 0,1,2] [--fast-path]

Targets (issue "grounding core", 2 CPU threads, Qwen2.5-Coder-1.5B Q4 via llama.cpp): executor
overhead per control step (no LM call, no env.step) <= 1 ms median; IGT <= 2.0 s median per task;
IT <= 2.0 s mean per task; GO <= 5 % kinematic and <= 3 % end-effector; RSS with the model <= 3 GiB.

IGT is measured cold (the grounding cache emptied before each task, the model loaded), and warm
(served from the cache). IT and GO come from whole episodes with the paper's variations on.
``--fast-path`` measures the same behind the fast path (what the ontology or a check decides
completely is rendered; the LM writes the rest).
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from pathlib import Path

import lerobot_policy_recent.robosuite_envs.runtime  # noqa: F401  (MuJoCo GL backend before robosuite loads)
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.recent_plugin.executor import TaskExecutor
from lerobot_policy_recent.recent_plugin.infillers import make_infiller
from lerobot_policy_recent.recent_plugin.infillers.configs import LlamaCppConfig, RuleConfig
from lerobot_policy_recent.recent_plugin.methods import method_named
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
from lerobot_policy_recent.robosuite_envs.observation import Observation

SPEED_PROMPT = Path(__file__).parents[1].joinpath("skills", "library", "put_in_bin.py").read_text() * 3  # ~400 tokens

# (task, target) pairs: the kinematic setting on UR5e, the end-effector setting on both grippers
TASKS = (
    ("kinematic/cube_in_bin", "UR5e"),
    ("kinematic/cube_on_plate", "UR5e"),
    ("kinematic/press_button", "UR5e"),
    ("kinematic/tidy_bench", "UR5e"),
    ("end_effector/open_drawer", "Robotiq85"),
    ("end_effector/cube_into_drawer", "Suction"),
    ("end_effector/build_tower", "Suction"),
)
SETTING = {"UR5e": "kinematic", "Sawyer": "kinematic", "Robotiq85": "end_effector", "Suction": "end_effector"}


def rss_mib(pid: int | str = "self") -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def igt(agent: RecentAgent, task_id: str, robot: str, *, cold: bool) -> tuple[float, int, int]:
    """Seconds to the first executable code for ``task_id``; and the generated and skill tokens."""
    if cold:
        agent._cache.clear()
    env = RecentEnv(task=task_id, robot=robot)
    try:
        raw, _ = env.reset(seed=0)
        obs = Observation.decode(raw["agent_pos"], raw["environment_state"], env.spec_task.object_names())
        _, report = agent.start_episode(task_id, robot, obs)
    finally:
        env.close()
    return (
        report.igt_seconds,
        sum(s.generated_tokens for s in report.skills),
        sum(s.skill_tokens for s in report.skills),
    )


def executor_overhead(agent: RecentAgent, task_id: str, robot: str, seed: int) -> list[float]:
    """Wall time of ``TaskExecutor.act`` per control step (in-situ checks included, LM calls excluded)."""
    timings: list[float] = []
    original = TaskExecutor.act

    def timed(self, obs):
        calls_before = len(self.adapter.calls) if self.adapter is not None else 0
        started = time.perf_counter()
        action = original(self, obs)
        elapsed = time.perf_counter() - started
        if self.adapter is None or len(self.adapter.calls) == calls_before:  # steps that called the LM are IT
            timings.append(elapsed)
        return action

    TaskExecutor.act = timed
    try:
        run_episode(agent, task_id, robot, seed=seed, variations="on")
    finally:
        TaskExecutor.act = original
    return timings


def lm_speed(infiller, repeats: int = 3) -> dict[str, float]:
    """Prompt evaluation and generation speed of the llama.cpp model on a skill-sized prompt."""
    return infiller.lm.speed(SPEED_PROMPT, repeats=repeats)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="qwen2.5-coder-1.5b")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--seeds", default="0,1,2", help="episode seeds for IT and GO (variations on)")
    parser.add_argument("--json", default=None, help="also write the numbers here")
    parser.add_argument("--fast-path", action="store_true", help="render fully decided spans and patches (no LM)")
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]

    rss_before = rss_mib()
    started = time.perf_counter()
    infiller = make_infiller("llamacpp", args.model, n_threads=args.threads)
    load_s = time.perf_counter() - started
    settings = RecentSettings(
        infiller=LlamaCppConfig(model=args.model, n_threads=args.threads),
        method=method_named("recent+fast-path" if args.fast_path else "recent"),
    )
    agent = RecentAgent(settings, infiller=infiller)
    rule_agent = RecentAgent(RecentSettings(infiller=RuleConfig()), ontology=agent.ontology)

    cold, warm, go_pre = [], [], {"kinematic": [], "end_effector": []}
    for task_id, robot in TASKS:
        seconds, generated, skill_tokens = igt(agent, task_id, robot, cold=True)
        cold.append(seconds)
        go_pre[SETTING[robot]].append(100.0 * generated / max(1, skill_tokens))
        warm.append(igt(agent, task_id, robot, cold=False)[0])
        print(
            f"IGT {task_id} on {robot}: cold {seconds:.2f} s, warm {warm[-1] * 1000:.1f} ms, GO before execution {go_pre[SETTING[robot]][-1]:.1f}%"
        )

    episodes = []
    for task_id, robot in TASKS:
        for seed in seeds:
            result = run_episode(agent, task_id, robot, seed=seed, variations="on")
            episodes.append((SETTING[robot], result))
            print(
                f"episode {task_id} on {robot} seed {seed}: success={result.success} GO {result.go:.1f}% (before execution {result.go_pre:.1f}%) EI {result.ei} ({result.patches} patches) IT {result.it:.2f} s"
            )
    overhead = []
    for task_id, robot in TASKS[:4]:
        overhead += executor_overhead(rule_agent, task_id, robot, seed=0)
    overhead_ms = sorted(1000 * t for t in overhead)

    speed = lm_speed(infiller)
    numbers = {
        "machine": {"cpu": platform.processor() or platform.machine(), "python": platform.python_version()},
        "model": infiller.model,
        "threads": args.threads,
        "fast_path": args.fast_path,
        "load_s": load_s,
        # this process plus the LM worker that holds the model, after every episode
        "rss_mib_end": rss_mib() + rss_mib(infiller.lm.pid),
        "cpu_kernels": infiller.info().get("cpu_kernels"),
        "rss_mib_before_model": rss_before,
        "igt_cold_median_s": statistics.median(cold),
        "igt_cold_max_s": max(cold),
        "igt_warm_median_ms": 1000 * statistics.median(warm),
        # tokens of the cold grounding ÷ skill tokens (the paper's GO counts repair + revise only)
        "go_pre_ground_kinematic": statistics.fmean(go_pre["kinematic"]),
        "go_pre_ground_end_effector": statistics.fmean(go_pre["end_effector"]),
        **{
            f"{key}_{setting}": value
            for setting in ("kinematic", "end_effector")
            for key, value in _episode_numbers([r for s, r in episodes if s == setting]).items()
        },
        "executor_step_median_ms": statistics.median(overhead_ms),
        "executor_step_p95_ms": overhead_ms[int(0.95 * (len(overhead_ms) - 1))],
        "executor_steps_timed": len(overhead_ms),
        **speed,
    }
    print(json.dumps(numbers, indent=2))
    if args.json:
        Path(args.json).write_text(json.dumps(numbers, indent=2))


def _episode_numbers(results) -> dict[str, float]:
    if not results:
        return {}
    return {
        "sr": 100.0 * statistics.fmean(bool(r.success) for r in results),
        "go_episode": statistics.fmean(r.go for r in results),  # the paper's GO: repair + revise tokens
        "go_pre_episode": statistics.fmean(r.go_pre for r in results),
        "ei": statistics.fmean(r.ei for r in results),  # repair + revise calls the LM answered
        "patches": statistics.fmean(r.patches for r in results),  # EI plus the fast path's rendered patches
        "it_mean_s": statistics.fmean(r.it for r in results),
        "it_per_call_s": statistics.fmean(c.seconds for r in results for c in r.interruptions())
        if any(r.interruptions() for r in results)
        else 0.0,
    }


if __name__ == "__main__":
    main()
