"""Where a paper-length episode's time goes, per method: simulation, controllers, checks, grounding, the LM.

    .venv/bin/python -m benchmarks.episode_profile_bench [--task kinematic/assembly_panel] [--robot UR5e]
        [--seed 3] [--methods recent+fast-path,recent,cap] [--json FILE]

Issue 59 asks for the cost per episode to be halved without changing outcomes; this says what there is
to cut. Each method runs the same dev episode (variations on) once under ``cProfile``; the profiler's
own-time per function is summed by the layer its file belongs to (a built-in's, such as MuJoCo's step
or a socket's receive, and numpy's by the layers that called them). The LM decodes in a worker process, so its share
here is the time this process waits for it; the episode record splits that into prompt evaluation and
generation. Profiling slows the Python parts, not the LM or MuJoCo's C code, so the
shares are indicative, not a timing.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import platform
import pstats
import time
from pathlib import Path

import lerobot_policy_recent.robosuite_envs.runtime  # noqa: F401  (MuJoCo GL backend before robosuite loads)
from lerobot_policy_recent.evaluation import methods as _methods  # noqa: F401  (registers the baselines)
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.recent_plugin.infillers import make_infiller
from lerobot_policy_recent.recent_plugin.infillers.configs import LlamaCppConfig
from lerobot_policy_recent.recent_plugin.methods import method_named
from lerobot_policy_recent.recent_plugin.settings import RecentSettings

# the layer a file belongs to, by the first of these path fragments it contains (order matters)
LAYERS = (
    ("the LM (waiting on its worker)", ("/infillers/", "llama_cpp", "multiprocessing/connection")),
    ("simulation (robosuite, MuJoCo)", ("/robosuite/", "/mujoco/")),
    ("in-situ checks", ("/insitu/",)),
    ("controllers and motion planning", ("/primitives/",)),
    ("observation and env wrapper", ("/robosuite_envs/",)),
    ("grounding (ontology, units, validation)", ("/ontology/", "/grounding/", "/refactoring/", "pyoxigraph")),
    ("executor and sandbox", ("/recent_plugin/",)),
    ("logging", ("/logs/",)),
)
OTHER = "other (numpy, Python, imports)"


def layer(filename: str) -> str:
    for name, fragments in LAYERS:
        if any(fragment in filename for fragment in fragments):
            return name
    return OTHER


def attribute(stats: dict, function: tuple, seconds: float, depth: int = 6) -> dict[str, float]:
    """``seconds`` of ``function``'s own time by layer: its file's, or, for a function of no layer (a
    built-in such as MuJoCo's step or a socket's receive, numpy), its callers' in proportion to the
    time each call took, up to ``depth`` callers up."""
    name = layer(function[0])
    callers = stats[function][4] if function in stats else {}
    if name != OTHER or depth == 0 or not callers:
        return {name: seconds}
    total = sum(timing[2] for timing in callers.values()) or 1.0
    shares: dict[str, float] = {}
    for caller, timing in callers.items():
        for part, value in attribute(stats, caller, seconds * timing[2] / total, depth - 1).items():
            shares[part] = shares.get(part, 0.0) + value
    return shares


def profile(agent: RecentAgent, task_id: str, robot: str, seed: int) -> dict:
    """Run one episode under cProfile: its record's times and the profile's own-time per layer."""
    profiler = cProfile.Profile()
    started = time.perf_counter()
    profiler.enable()
    result = run_episode(agent, task_id, robot, seed=seed, variations="on")
    profiler.disable()
    wall = time.perf_counter() - started
    stats = pstats.Stats(profiler).stats
    by_layer: dict[str, float] = {}
    for function, (_, _, own, _, _) in stats.items():
        for name, seconds in attribute(stats, function, own).items():
            by_layer[name] = by_layer.get(name, 0.0) + seconds
    total = sum(by_layer.values()) or 1.0
    record = result.to_record()
    return {
        "success": record["success"],
        "steps": record["steps"],
        "wall_s": round(wall, 2),
        "lm_calls": record["lm_calls"],
        "generated_tokens": record["generated_tokens"],
        "lm_seconds": round(record["lm_seconds"], 2),
        "lm_prompt_s": round(record["igt_prompt_s"] + record["it_prompt_s"], 2),
        "lm_generation_s": round(record["igt_generation_s"] + record["it_generation_s"], 2),
        "share": {name: round(own / total, 3) for name, own in sorted(by_layer.items(), key=lambda kv: -kv[1])},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", default="kinematic/assembly_panel", help="a paper-length dev task")
    parser.add_argument("--robot", default="UR5e")
    parser.add_argument("--seed", type=int, default=3, help="a dev seed")
    parser.add_argument("--methods", default="recent+fast-path,recent,cap")
    parser.add_argument("--model", default="qwen2.5-coder-1.5b")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--json", default=None, help="also write the numbers here")
    args = parser.parse_args()

    infiller = make_infiller("llamacpp", args.model, n_threads=args.threads)
    runs = {}
    for name in args.methods.split(","):
        settings = RecentSettings(
            infiller=LlamaCppConfig(model=args.model, n_threads=args.threads), method=method_named(name)
        )
        runs[name] = profile(RecentAgent(settings, infiller=infiller), args.task, args.robot, args.seed)
        run = runs[name]
        print(
            f"{name}: {'success' if run['success'] else 'failure'}, {run['steps']} steps, {run['wall_s']} s "
            f"({run['lm_calls']} infill calls, rendered ones included; {run['generated_tokens']} tokens generated, LM {run['lm_seconds']} s: prompt "
            f"{run['lm_prompt_s']} s, generation {run['lm_generation_s']} s)"
        )
        for part, share in run["share"].items():
            print(f"    {share:6.1%}  {part}")
    numbers = {
        "machine": f"{platform.node()} ({platform.processor() or platform.machine()})",
        "task": args.task,
        "robot": args.robot,
        "seed": args.seed,
        "model": args.model,
        "threads": args.threads,
        "methods": runs,
    }
    print(json.dumps(numbers, indent=2))
    if args.json:
        Path(args.json).write_text(json.dumps(numbers, indent=2) + "\n")


if __name__ == "__main__":
    main()
