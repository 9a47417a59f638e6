"""Ray engine scaling: episodes/hour with 1 and 2 local workers in one run, Ray's overhead per episode,
the per-episode cost breakdown of a committed LM run, and the full grid's projected wall time.

    .venv/bin/python -m benchmarks.ray_bench [--workers 1,2] [--seeds 0,1] [--cost-tasks cube_on_plate,...]

Targets (issue "the whole evaluation grid on Ray"): 1 -> 2 workers >= 1.7x episodes/hour on the rule
backend; Ray's overhead per episode <= 2 % of the median episode's wall time. Overhead is measured
per episode as the driver's round trip (submit to result) minus the worker's own time for the same
episode (the direct call). The rule backend has no LM: episodes are simulation, grounding and
validation, so the scaling measured is the engine's and the simulator's, not an LM's.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import statistics
import tempfile
import time
from pathlib import Path

from lerobot_policy_recent.evaluation.runner import BenchConfig, machine, run_bench
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.scripts.bench_cmd import git_commit

MEASURED = Path(__file__).parent / "measured"
# The full grid of the paper's protocol (issue "whole evaluation grid"): tasks x targets x seeds x methods.
GRID = {"tasks": 32, "targets": 2, "seeds": 5, "methods": 12}
# A GPU LM server's rates for the projection (stated assumptions, not measured here): a 7B coder on
# vLLM on one data-centre GPU, batch 1.
GPU_PREFILL_TOK_S, GPU_DECODE_TOK_S = 5000.0, 80.0
# Episode wall with MCAP + Rerun + dataset on / off (benchmarks/logging_bench, BENCHMARKS.md, at c83bc15).
LOGGING_FACTOR = 0.98


def scaling(workers: list[int], seeds: tuple[int, ...], out: Path) -> list[dict]:
    rows = []
    for n in workers:
        config = BenchConfig(
            out=out / f"workers_{n}",
            suites=("kinematic-v1",),
            targets=("UR5e",),
            methods=("recent", "recent-no-insitu"),
            seeds=seeds,
            log_sinks=(),
            workers=n,
            cpus_per_worker=1,
            agent=RecentSettings(infiller=RuleConfig()),
        )
        started = time.perf_counter()
        run = run_bench(config)
        wall = time.perf_counter() - started
        episodes = len(run.ran)
        steady = wall - run.plan["start_seconds"]
        overhead = [r["ray_overhead_seconds"] for r in run.ran]
        inside = [r["worker_seconds"] for r in run.ran]
        rows.append(
            {
                "workers": n,
                "episodes": episodes,
                "wall_s": round(wall, 1),
                "start_s": run.plan["start_seconds"],
                "episodes_per_hour": round(3600 * episodes / wall, 1),
                "episodes_per_hour_started": round(3600 * episodes / steady, 1),
                "median_episode_s": round(statistics.median(inside), 3),
                "median_ray_overhead_s": round(statistics.median(overhead), 4),
                "overhead_pct_of_median_episode": round(
                    100 * statistics.median(overhead) / statistics.median(inside), 2
                ),
                "successes": sum(bool(r["success"]) for r in run.ran),
            }
        )
        print(rows[-1], flush=True)
    return rows


def costs(tasks: tuple[str, ...], out: Path) -> dict:
    """Per-episode cost of RECENT with the default LM (llama.cpp, 2 threads), one worker, logs on: what the
    worker spent per episode, split into LM prompt evaluation, LM generation and the rest (simulation,
    checks, validation, the executor, logging). Groundings are cached per worker, as in a real grid, so
    an episode pays its grounding's LM time only when it was not served from the cache."""
    from lerobot_policy_recent.recent_plugin.infillers.configs import LlamaCppConfig

    config = BenchConfig(
        out=out / "lm",
        suites=("kinematic-v1",),
        targets=("UR5e",),
        methods=("recent",),
        tasks=tasks,
        seeds=(0, 1),
        workers=1,
        agent=RecentSettings(infiller=LlamaCppConfig(n_threads=2)),
    )
    run = run_bench(config)
    runtime = json.loads((MEASURED / "llm_runtime.json").read_text())["kernels"][0]  # this host's rates
    episodes = [r for r in run.ran if not r.get("crashed")]
    worker = sum(r["worker_seconds"] for r in episodes)
    lm = sum(r["it"] + (0.0 if r["grounding_cached"] else r["igt_cold"]) for r in episodes)
    tokens = sum(r["adaptation_tokens"] + (0 if r["grounding_cached"] else r["generated_tokens"] - r["adaptation_tokens"])
                 for r in episodes)  # fmt: skip
    generation = tokens / runtime["decode_tok_s"]
    n = len(episodes)
    return {
        "slice": f"recent, kinematic {','.join(tasks)}, UR5e, seeds 0,1, llama.cpp 1.5B Q4_K_M, 2 threads",
        "episodes": n,
        "worker_s": round(worker / n, 2),  # everything the worker spent, per episode
        "lm_prompt_s": round(max(0.0, lm - generation) / n, 2),  # LM time not explained by decoding
        "lm_generation_s": round(generation / n, 2),  # generated tokens / this host's decode rate
        "sim_and_rest_s": round((worker - lm) / n, 2),  # physics, checks, validation, executor, logging
        "logging_factor": LOGGING_FACTOR,  # logging's share is within the noise (BENCHMARKS.md)
        "generated_tokens": round(tokens / n, 1),
        "prompt_tokens_est": round(max(0.0, lm - generation) * runtime["prefill_tok_s"] / n),
        "decode_tok_s": round(runtime["decode_tok_s"], 1),
        "prefill_tok_s": round(runtime["prefill_tok_s"], 1),
        "successes": sum(bool(r["success"]) for r in episodes),
    }


def projection(cost: dict, nodes: list[int], cores: int) -> list[dict]:
    """Full-grid wall time on N nodes of C cores (one 2-CPU worker per 2 cores), and with a GPU LM server."""
    episodes = GRID["tasks"] * GRID["targets"] * GRID["seeds"] * GRID["methods"]
    cpu_episode = cost["worker_s"]
    gpu_lm = cost["prompt_tokens_est"] / GPU_PREFILL_TOK_S + cost["generated_tokens"] / GPU_DECODE_TOK_S
    gpu_episode = cost["sim_and_rest_s"] + gpu_lm
    rows = []
    for n in nodes:
        workers = n * (cores // 2)
        rows.append(
            {
                "nodes": n,
                "cores": cores,
                "workers": workers,
                "episodes": episodes,
                "cpu_lm_hours": round(episodes * cpu_episode / workers / 3600, 1),
                "gpu_lm_server_hours": round(episodes * gpu_episode / workers / 3600, 1),
            }
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", default="1,2", help="worker counts to compare, in one run")
    parser.add_argument("--seeds", default="0,1", help="seeds of the slice (kinematic suite, UR5e, 2 methods)")
    parser.add_argument(
        "--cost-tasks", default="cube_on_plate,tidy_bench,plate_then_button", help="kinematic tasks of the LM slice"
    )
    parser.add_argument("--nodes", default="1,4,16", help="cluster sizes to project")
    parser.add_argument("--cores", type=int, default=16, help="cores per projected node")
    parser.add_argument("--json", default=str(MEASURED / "ray_bench.json"))
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        rows = scaling(
            [int(w) for w in args.workers.split(",")], tuple(int(s) for s in args.seeds.split(",")), Path(tmp)
        )
        cost = costs(tuple(args.cost_tasks.split(",")), Path(tmp))
    plan = projection(cost, [int(n) for n in args.nodes.split(",")], args.cores)
    base = rows[0]["episodes_per_hour"]
    print(
        "\n| workers | episodes | wall (s) | start (s) | episodes/h | ratio | episodes/h after start | median episode (s) | median Ray overhead (s) | overhead / episode |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['workers']} | {r['episodes']} | {r['wall_s']} | {r['start_s']} | {r['episodes_per_hour']} | "
            f"{r['episodes_per_hour'] / base:.2f}x | {r['episodes_per_hour_started']} | {r['median_episode_s']} | "
            f"{r['median_ray_overhead_s']} | {r['overhead_pct_of_median_episode']} % |"
        )
    print(f"\nper-episode cost ({cost['slice']}, {cost['episodes']} episodes): {cost}")
    print("\n| nodes x cores | workers | episodes | CPU LM (h) | GPU LM server (h) |\n|---|---|---|---|---|")
    for p in plan:
        print(
            f"| {p['nodes']} x {p['cores']} | {p['workers']} | {p['episodes']} | {p['cpu_lm_hours']} | {p['gpu_lm_server_hours']} |"
        )
    document = {
        "date": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "git_commit": git_commit(),
        "machine": machine(),
        "scaling": rows,
        "cost": cost,
        "grid": GRID,
        "gpu_assumption": {"prefill_tok_s": GPU_PREFILL_TOK_S, "decode_tok_s": GPU_DECODE_TOK_S},
        "projection": plan,
    }
    Path(args.json).write_text(json.dumps(document, indent=1) + "\n")
    print(f"\nwritten: {args.json}")


if __name__ == "__main__":
    main()
