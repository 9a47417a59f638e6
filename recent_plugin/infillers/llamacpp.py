"""The ``llamacpp`` backend: a GGUF code model on CPU, prompted with Qwen2.5-Coder FIM tokens.

llama-cpp-python 0.3.36's ``create_completion(suffix=...)`` uses the wrong token ids for FIM, so
the FIM string is built here; its special markers are tokenized as special tokens. Decoding is
greedy with prompt-lookup drafts (:mod:`~recent_plugin.infillers.lookup_decoding`).
"""

from __future__ import annotations

import os
import time

from recent_plugin.grounding.fim_prompt import STATEMENT_LINE, STATEMENT_LINES, build_prompt
from recent_plugin.grounding.units import RefactoringUnit
from recent_plugin.infillers.base import Completion
from recent_plugin.infillers.fim_formats import FORMATS
from recent_plugin.infillers.lookup_decoding import LookupDecoder

QWEN = FORMATS["qwen2.5-coder"]  # the GGUFs we provision are Qwen2.5-Coder


class LlamaCppInfiller:
    name = "llamacpp"

    def __init__(self, model_path: str, *, n_threads: int | None = None, n_ctx: int = 2048, seed: int = 0):
        from llama_cpp import Llama

        self.model = os.path.basename(model_path)
        self.llm = Llama(
            model_path=model_path,
            n_ctx=n_ctx,
            n_threads=n_threads or min(2, os.cpu_count() or 1),
            seed=seed,
            verbose=False,
            # llama.cpp repacks the Q4 weights for its CPU kernels; with the file mapped as well, both
            # copies stay resident (1.76 GB for the 1.5B). Read into memory instead: 1.17 GB, ~1 s more load.
            use_mmap=False,
        )
        self._grammars: dict[str, object] = {}
        self.decoder = LookupDecoder(self.llm)

    def _grammar(self, gbnf: str):
        from llama_cpp import LlamaGrammar

        if gbnf in self._grammars:
            return self._grammars[gbnf]
        grammar = LlamaGrammar.from_string(gbnf, verbose=False)
        if gbnf in (STATEMENT_LINE, STATEMENT_LINES):  # per-retry call grammars are not kept
            self._grammars[gbnf] = grammar
        return grammar

    def count_tokens(self, text: str) -> int:
        return len(self.llm.tokenize(text.encode(), add_bos=False, special=False))

    def infill(self, unit: RefactoringUnit) -> Completion:
        prompt = build_prompt(unit, self.count_tokens(unit.span))
        text = QWEN.render(prompt.prefix, prompt.suffix)
        started = time.perf_counter()
        tokens = self.llm.tokenize(text.encode(), add_bos=False, special=True)
        out = self.decoder.generate(
            tokens,
            max_tokens=prompt.max_tokens,
            stops=(*prompt.stop, *QWEN.stops),
            grammar=self._grammar(prompt.grammar),
        )
        return Completion(
            text=out.text,
            generated_tokens=out.generated_tokens,
            seconds=time.perf_counter() - started,
            prompt_tokens=out.prompt_tokens,
        )
