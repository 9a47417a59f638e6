"""What the LM's threads and a second LM buy on this host (issue 59, cost per episode).

    .venv/bin/python -m benchmarks.lm_threads_bench [--calls results/baselines_budget/repair_lm_261308c/lm_calls.jsonl.gz] \\
        [--n 6] [--max_tokens 96] [--json benchmarks/measured/lm_threads.json]

Replays the first ``--n`` prompts an episode sent (an ``lm_calls.jsonl.gz`` of a bench run: exactly the
text sent) through the product's LM worker in three settings: one worker with 1 thread, one with 2,
and two 1-thread workers side by side, each replaying the same prompts at once. Every call starts from
a cold prompt state and samples at temperature 0.2 with a fixed seed, so each setting does the same
work. Reports each setting's wall for its calls, the pair's throughput against one worker, and whether
every setting wrote the same text (threads must not change answers).

Why: a second Ray worker on one host only pays if two LMs decoding at once do not slow each other
down; on a host whose decoding is bound by what its cores share, it halves the LM-bound episodes
per hour instead, and the cost must come down through fewer tokens.
"""

from __future__ import annotations

import argparse
import gzip
import json
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from lerobot_policy_recent.recent_plugin.infillers.llama_runtime import cpu_description
from lerobot_policy_recent.recent_plugin.infillers.llama_worker import LlamaWorker
from lerobot_policy_recent.recent_plugin.models.fetch import ensure_model

ROOT = Path(__file__).resolve().parents[1]
CALLS = ROOT / "results" / "baselines_budget" / "repair_lm_261308c" / "lm_calls.jsonl.gz"
SEED = 7
TEMPERATURE = 0.2


def recorded_prompts(path: Path, n: int) -> list[str]:
    """The first ``n`` prompts of a run's LM-call log, as sent (its other records are the calls' outcomes)."""
    with gzip.open(path, "rt") as lines:
        prompts = [record["prompt"] for record in map(json.loads, lines) if "prompt" in record]
    if len(prompts) < n:
        raise SystemExit(f"{path}: {len(prompts)} recorded prompts, fewer than --n {n}")
    return prompts[:n]


def replay(worker: LlamaWorker, prompts: list[str], max_tokens: int) -> tuple[float, list[str]]:
    """Wall seconds for the prompts, one after the other from a cold prompt state, and the texts."""
    texts = []
    started = time.perf_counter()
    for prompt in prompts:
        worker.forget_prompt_states()
        decoded = worker.generate(prompt, max_tokens=max_tokens, stops=(), temperature=TEMPERATURE, seed=SEED)
        texts.append(decoded.text)
    return time.perf_counter() - started, texts


def measure(model: str, prompts: list[str], max_tokens: int) -> dict:
    rows, answers = [], {}
    for threads in (1, 2):
        setting = f"one LM, {threads} thread(s)"
        worker = LlamaWorker(model, n_threads=threads)
        try:
            replay(worker, prompts[:1], 8)  # loaded and warm: the load is not what is measured
            wall, answers[setting] = replay(worker, prompts, max_tokens)
        finally:
            worker.close()
        rows.append({"setting": setting, "calls": len(prompts), "wall_s": round(wall, 1)})
        print(f"{setting}: {wall:.1f} s for {len(prompts)} calls", flush=True)
    pair = [LlamaWorker(model, n_threads=1) for _ in range(2)]
    try:
        for worker in pair:
            replay(worker, prompts[:1], 8)
        with ThreadPoolExecutor(max_workers=2) as pool:
            started = time.perf_counter()
            runs = list(pool.map(lambda w: replay(w, prompts, max_tokens), pair))
            wall = time.perf_counter() - started
    finally:
        for worker in pair:
            worker.close()
    for i, (_, texts) in enumerate(runs):
        answers[f"two LMs side by side, #{i + 1}"] = texts
    alone = rows[0]["wall_s"]
    rows.append(
        {
            "setting": "two LMs side by side, 1 thread each",
            "calls": 2 * len(prompts),
            "wall_s": round(wall, 1),
            "throughput_vs_one": round(2 * alone / wall, 2),
        }
    )
    print(f"two LMs side by side: {wall:.1f} s for {2 * len(prompts)} calls ({2 * alone / wall:.2f}x one)", flush=True)
    reference = next(iter(answers.values()))
    return {"rows": rows, "same_answers": all(texts == reference for texts in answers.values())}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="qwen2.5-coder-1.5b")
    parser.add_argument("--calls", type=Path, default=CALLS, help="an lm_calls.jsonl.gz whose prompts are replayed")
    parser.add_argument("--n", type=int, default=6, help="how many of its prompts")
    parser.add_argument("--max_tokens", type=int, default=96)
    parser.add_argument("--json", default=None, help="also write the numbers here")
    args = parser.parse_args()

    model = str(ensure_model(args.model))
    prompts = recorded_prompts(args.calls, args.n)
    result = measure(model, prompts, args.max_tokens)
    print(f"\nCPU: {cpu_description()}; model {Path(model).name}; {args.n} prompts from {args.calls}")
    for row in result["rows"]:
        extra = f"  ({row['throughput_vs_one']:.2f}x the throughput of one)" if "throughput_vs_one" in row else ""
        print(f"{row['setting']:<40} {row['wall_s']:>8.1f} s for {row['calls']} calls{extra}")
    print(f"every setting wrote the same text: {result['same_answers']}")
    if args.json:
        calls = args.calls.resolve()
        shown = calls.relative_to(ROOT) if calls.is_relative_to(ROOT) else calls  # a record, not this checkout's path
        numbers = {"cpu": cpu_description(), "model": Path(model).name, "calls": str(shown), "n": args.n}
        Path(args.json).write_text(json.dumps({**numbers, **result}, indent=2) + "\n")


if __name__ == "__main__":
    main()
