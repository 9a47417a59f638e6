"""``LlamaSession``: the loaded GGUF model, its tokenizer and decoder, and its compiled grammars.

The part of the ``llamacpp`` backend that touches native code: it runs inside the LM worker
process (:mod:`~lerobot_policy_recent.recent_plugin.infillers.llama_worker`), or in-process for tests.
"""

from __future__ import annotations

import os
import statistics
import time
from collections import OrderedDict

from lerobot_policy_recent.recent_plugin.infillers.llama_runtime import CpuKernels, load_cpu_kernels, wheel_description
from lerobot_policy_recent.recent_plugin.infillers.lookup_decoding import Decoded, LookupDecoder
from lerobot_policy_recent.recent_plugin.infillers.prompt_states import STATE_BUDGET_BYTES, PromptStates

GRAMMARS_KEPT = 8  # compiled GBNF grammars kept per session (the statement grammars recur; retry grammars do not)


# Room for the longest calls the methods make: a baseline's regeneration prompt (its program, the
# error, the detector's findings) and its completion passed 2048 tokens on a paper-length task. The
# KV cache this reserves is 28 KiB a token for the 1.5B (230 MiB); a saved prompt state stays the
# size of its prompt (6 MiB for 220 tokens at either size). The decoder keeps every call within it.
N_CTX = 8192


class LlamaSession:
    """One loaded GGUF with its decoder: tokenize, generate, measure. Runs wherever it is built."""

    def __init__(
        self,
        model_path: str,
        *,
        n_threads: int | None = None,
        n_ctx: int = N_CTX,
        seed: int = 0,
        state_bytes: int = STATE_BUDGET_BYTES,
    ):
        """``state_bytes``: how much memory earlier prompts' saved KV states may take (0: none kept)."""
        self.kernels: CpuKernels = load_cpu_kernels()  # before the model: it decides which kernels run
        from llama_cpp import Llama

        self.model = os.path.basename(model_path)
        self.n_threads = n_threads or min(2, os.cpu_count() or 1)
        self.llm = Llama(
            model_path=model_path,
            n_ctx=n_ctx,
            n_threads=self.n_threads,
            seed=seed,
            verbose=False,
            # llama.cpp repacks the Q4 weights for its CPU kernels; with the file mapped as well, both
            # copies stay resident (1.76 GB for the 1.5B). Read into memory instead: 1.17 GB, ~1 s more load.
            use_mmap=False,
        )
        self._grammars: OrderedDict[str, object] = OrderedDict()
        self.decoder = LookupDecoder(self.llm, states=PromptStates(state_bytes))

    def info(self) -> dict[str, object]:
        """What runs: model, threads, CPU kernels and wheel (for logs, errors and benchmarks)."""
        return {
            "model": self.model,
            "n_threads": self.n_threads,
            "cpu_kernels": self.kernels.variant,
            "cpu_kernels_path": self.kernels.path,
            "cpu_kernel_scores": self.kernels.scores,
            "left_out": list(self.kernels.left_out),
            "wheel": wheel_description(),
            "pid": os.getpid(),
        }

    def forget_prompt_states(self) -> None:
        """Drop every saved prompt state and the KV cache (a cold start, for benchmarks)."""
        self.decoder.states.clear()
        self.llm.reset()

    def prompt_state_stats(self) -> dict[str, int]:
        states = self.decoder.states
        return {"saved": len(states), "bytes": states.bytes, "restored": states.restored}

    def grammar(self, gbnf: str | None):
        if gbnf is None:
            return None
        from llama_cpp import LlamaGrammar

        if gbnf not in self._grammars:
            self._grammars[gbnf] = LlamaGrammar.from_string(gbnf, verbose=False)
            while len(self._grammars) > GRAMMARS_KEPT:
                self._grammars.popitem(last=False)
        self._grammars.move_to_end(gbnf)
        return self._grammars[gbnf]

    def tokenize(self, text: str, special: bool = False) -> list[int]:
        return self.llm.tokenize(text.encode(), add_bos=False, special=special)

    def generate(
        self,
        text: str,
        *,
        max_tokens: int,
        stops: tuple[str, ...],
        gbnf: str | None = None,
        temperature: float = 0.0,
        seed: int = 0,
        draft_text: str | None = None,
    ) -> Decoded:
        """The completion of ``text`` (FIM markers as special tokens) under the grammar ``gbnf``: greedy,
        or sampled at ``temperature`` from a generator seeded with ``seed``. ``draft_text``: what the
        completion is likely to copy (the hint's call); it only speeds decoding up."""
        tokens = self.tokenize(text, special=True)
        return self.decoder.generate(
            tokens,
            max_tokens=max_tokens,
            stops=stops,
            grammar=self.grammar(gbnf),
            temperature=temperature,
            seed=seed,
            expected=self.tokenize(draft_text) if draft_text else (),
        )

    def speed(self, prompt: str, *, repeats: int = 3, gen_tokens: int = 64) -> dict[str, float]:
        """Prompt-evaluation and generation tokens/s on ``prompt`` (medians of ``repeats`` cold runs)."""
        tokens = self.tokenize(prompt)
        prefill, decode = [], []
        for _ in range(repeats):
            self.llm.reset()
            started = time.perf_counter()
            self.llm.eval(tokens)
            prefill.append(len(tokens) / (time.perf_counter() - started))
            started = time.perf_counter()
            out = self.llm.create_completion(prompt, max_tokens=gen_tokens, temperature=0.0, top_k=1)
            decode.append(out["usage"]["completion_tokens"] / (time.perf_counter() - started))  # prompt cached
        self.llm.reset()
        return {
            "prompt_tokens": len(tokens),
            "prefill_tok_s": statistics.median(prefill),
            "decode_tok_s": statistics.median(decode),
        }
