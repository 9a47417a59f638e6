"""LM runtime benchmark: the portable llama.cpp build against other builds, side by side, and the worker's cost.

    .venv/bin/python -m benchmarks.llm_runtime_bench [--compare native=/tmp/native-site] [--variants all] \\
        [--rounds 5] [--threads 2] [--json benchmarks/measured/llm_runtime.json]

Kernels: every configuration runs in its own LM worker process (the one the agent uses), all of
them loaded at once and measured in interleaved rounds, so a slower moment of the machine falls on
each alike. A configuration is this project's build with the CPU kernels it selects at run time
(``auto``), one of its variants forced (``--variants``), or another llama-cpp-python installation
(``--compare NAME=DIR``: a directory that ``pip install --target`` filled, e.g. a ``-march=native``
build). Prompt evaluation (tokens/s over a ~400-token skill prompt, cold cache) and generation
(tokens/s, greedy, prompt cached) are medians over the rounds.

Worker: what running the model in a child process costs against running it in this process: load
time (to the first answer), the round trip of a tiny call, and one real FIM span, warm.

Target (issue "portable LM runtime"): the portable build within 10 % of the fastest build that runs
correctly on the same machine, on both figures.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

from lerobot_policy_recent.recent_plugin.infillers.llama_runtime import VARIANT_ENV, cpu_description, variant_libraries
from lerobot_policy_recent.recent_plugin.models import ensure_model

SPEED_PROMPT = Path(__file__).parents[1].joinpath("skills", "library", "put_in_bin.py").read_text() * 3


def start_worker(model: str, threads: int, *, variant: str | None = None, site: str | None = None):
    """An LM worker on ``variant`` of the portable build, or on the llama_cpp installed in ``site``."""
    from lerobot_policy_recent.recent_plugin.infillers.llama_worker import LlamaWorker

    started = time.perf_counter()
    worker = LlamaWorker(model, n_threads=threads, env={VARIANT_ENV: variant} if variant else None, site=site)
    return worker, time.perf_counter() - started


def kernels(model: str, threads: int, variants: list[str], compare: dict[str, str], rounds: int) -> list[dict]:
    configs = [("portable (auto)", None, None)] + [(f"portable ({v})", v, None) for v in variants]
    configs += [(name, None, site) for name, site in compare.items()]
    workers = {}
    for name, variant, site in configs:
        workers[name], _ = start_worker(model, threads, variant=variant, site=site)
    samples: dict[str, dict[str, list[float]]] = {name: {"prefill": [], "decode": []} for name in workers}
    try:
        for r in range(rounds):
            for name, worker in workers.items():
                speed = worker.speed(SPEED_PROMPT, repeats=1)
                samples[name]["prefill"].append(speed["prefill_tok_s"])
                samples[name]["decode"].append(speed["decode_tok_s"])
            print(f"round {r + 1}/{rounds} done", flush=True)
        rows = []
        for name, worker in workers.items():
            info = worker.info()
            rows.append(
                {
                    "build": name,
                    "kernels": info["cpu_kernels"],
                    "wheel": info["wheel"],
                    "prompt_tokens": len(worker.tokenize(SPEED_PROMPT)),
                    "prefill_tok_s": statistics.median(samples[name]["prefill"]),
                    "decode_tok_s": statistics.median(samples[name]["decode"]),
                    "prefill_samples": samples[name]["prefill"],
                    "decode_samples": samples[name]["decode"],
                }
            )
        return rows
    finally:
        for worker in workers.values():
            worker.close()


def worker_cost(model: str, threads: int, calls: int = 200) -> dict[str, float]:
    """In-process against worker: load to first answer, a tiny call's round trip, a warm FIM span."""
    from lerobot_policy_recent.recent_plugin.infillers.fim_formats import FORMATS
    from lerobot_policy_recent.recent_plugin.infillers.llama_check import PREFIX, SUFFIX
    from lerobot_policy_recent.recent_plugin.infillers.llama_session import LlamaSession

    qwen = FORMATS["qwen2.5-coder"]
    span = qwen.render(PREFIX, SUFFIX)
    numbers = {}
    worker, numbers["worker_load_s"] = start_worker(model, threads)
    try:
        numbers["worker_call_us"] = _median_us(lambda: worker.tokenize("x"), calls)
        worker.generate(span, max_tokens=8, stops=("\n",))  # warm: the prompt is cached from here on
        numbers["worker_span_ms"] = 1000 * _median_s(lambda: worker.generate(span, max_tokens=8, stops=("\n",)), 5)
    finally:
        worker.close()
    started = time.perf_counter()
    session = LlamaSession(model, n_threads=threads)
    session.tokenize("x")
    numbers["in_process_load_s"] = time.perf_counter() - started
    numbers["in_process_call_us"] = _median_us(lambda: session.tokenize("x"), calls)
    session.generate(span, max_tokens=8, stops=("\n",))
    numbers["in_process_span_ms"] = 1000 * _median_s(lambda: session.generate(span, max_tokens=8, stops=("\n",)), 5)
    return numbers


def _median_s(fn, n: int) -> float:
    times = []
    for _ in range(n):
        started = time.perf_counter()
        fn()
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def _median_us(fn, n: int) -> float:
    return 1e6 * _median_s(fn, n)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="qwen2.5-coder-1.5b")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument(
        "--variants", default="", help="also force these variants of the portable build (comma-separated, or 'all')"
    )
    parser.add_argument(
        "--compare", action="append", default=[], metavar="NAME=DIR", help="another llama-cpp-python installation"
    )
    parser.add_argument("--json", default=None, help="also write the numbers here")
    args = parser.parse_args()

    model = str(ensure_model(args.model))
    compare = dict(item.rsplit("=", 1) for item in args.compare)
    variants = [v for v in args.variants.split(",") if v]
    if variants == ["all"]:
        variants = sorted(variant_libraries())
    rows = kernels(model, args.threads, variants, compare, args.rounds)
    best = {key: max(r[key] for r in rows) for key in ("prefill_tok_s", "decode_tok_s")}
    print(f"\nCPU: {cpu_description()}; {args.threads} threads; model {Path(model).name}; {args.rounds} rounds")
    print(f"{'build':<28} {'kernels':<16} {'prompt tok/s':>13} {'vs best':>8} {'gen tok/s':>10} {'vs best':>8}")
    for r in rows:
        print(
            f"{r['build']:<28} {r['kernels']:<16} {r['prefill_tok_s']:>13.1f} {r['prefill_tok_s'] / best['prefill_tok_s'] - 1:>+8.1%}"
            f" {r['decode_tok_s']:>10.1f} {r['decode_tok_s'] / best['decode_tok_s'] - 1:>+8.1%}"
        )
    cost = worker_cost(model, args.threads)
    print("\nworker process against in-process:")
    print(f"  load to first answer  {cost['worker_load_s']:.2f} s vs {cost['in_process_load_s']:.2f} s")
    print(f"  tiny call round trip  {cost['worker_call_us']:.0f} µs vs {cost['in_process_call_us']:.0f} µs")
    print(f"  FIM span, warm        {cost['worker_span_ms']:.1f} ms vs {cost['in_process_span_ms']:.1f} ms")
    if args.json:
        numbers = {"cpu": cpu_description(), "threads": args.threads, "model": Path(model).name, "rounds": args.rounds}
        Path(args.json).write_text(json.dumps({**numbers, "kernels": rows, "worker": cost}, indent=2) + "\n")


if __name__ == "__main__":
    main()
