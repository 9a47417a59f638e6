"""The ``llamacpp`` backend: a GGUF code model on CPU, prompted with Qwen2.5-Coder FIM tokens.

llama-cpp-python 0.3.36's ``create_completion(suffix=...)`` uses the wrong token ids for FIM, so
the FIM string is built here; its special markers are tokenized as special tokens. A whole
function body (a baseline's program) is asked for through the instruct model's chat template
instead (ChatML, :mod:`~lerobot_policy_recent.recent_plugin.refactoring.chat_prompt`). Decoding is
greedy (or seeded sampling at a temperature) with prompt-lookup drafts (:mod:`~lerobot_policy_recent.recent_plugin.infillers.lookup_decoding`).

The model runs in a worker process (:mod:`~lerobot_policy_recent.recent_plugin.infillers.llama_worker`) by default: a
crash of the native library then ends one LM call with :class:`LMWorkerCrashed` and an
explanation, not the robot's process and its logs. :class:`LlamaSession` is the model itself, the
part that runs inside that worker (or in-process, ``in_process=True``); it has a module of its own.
"""

from __future__ import annotations

import logging
import os
import time
from pathlib import Path

from lerobot_policy_recent.recent_plugin.infillers.base import Completion
from lerobot_policy_recent.recent_plugin.infillers.fim_formats import FORMATS
from lerobot_policy_recent.recent_plugin.infillers.llama_session import LlamaSession
from lerobot_policy_recent.recent_plugin.refactoring.chat_prompt import (
    CHATML_STOPS,
    build_chat,
    render_chatml,
    span_of_reply,
    writes_whole_body,
)
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import FimPrompt, build_prompt
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit

log = logging.getLogger(__name__)
QWEN = FORMATS["qwen2.5-coder"]  # the GGUFs we provision are Qwen2.5-Coder


class LlamaCppInfiller:
    """The FIM infiller over a :class:`LlamaSession`, by default one in a worker process."""

    name = "llamacpp"
    samples = True
    prompt_window = "dataflow"  # how much of a span's function its FIM prompt shows (set per instance)

    def __init__(self, model_path: str, *, in_process: bool = False, prompt_window: str = "dataflow", **options):
        """``options`` are :class:`LlamaSession`'s (``n_threads``, ``n_ctx``, ``seed``, ``state_bytes``);
        ``prompt_window``: how much of a span's function its prompt shows (``function`` or ``dataflow``)."""
        self.model = os.path.basename(model_path)
        self.prompt_window = prompt_window
        if in_process:
            self.lm = LlamaSession(model_path, **options)
        else:
            from lerobot_policy_recent.recent_plugin.infillers.llama_worker import LlamaWorker

            self.lm = LlamaWorker(str(Path(model_path)), **options)

    def info(self) -> dict[str, object]:
        return self.lm.info()

    def count_tokens(self, text: str) -> int:
        return len(self.lm.tokenize(text, False))

    def infill(self, unit: RefactoringUnit, *, temperature: float = 0.0, seed: int = 0) -> Completion:
        span_tokens = self.count_tokens(unit.span)
        started = time.perf_counter()
        if writes_whole_body(unit):  # a program is written, not a span edited: the instruct model's chat
            chat = build_chat(unit, span_tokens)
            sent = render_chatml(chat.messages)
            out = self.lm.generate(
                sent,
                max_tokens=chat.max_tokens,
                stops=CHATML_STOPS,
                gbnf=None,
                temperature=temperature,
                seed=seed,
            )
            text, shown = span_of_reply(out.text, unit.indent), sent  # system line and instruction included
        else:
            prompt = build_prompt(unit, span_tokens, self.prompt_window)
            if prompt.forced is not None and (tokens := self.count_tokens(prompt.forced)) <= prompt.max_tokens:
                return _forced(prompt, tokens, started)
            out = self.lm.generate(
                QWEN.render(prompt.prefix, prompt.suffix),
                max_tokens=prompt.max_tokens,
                stops=(*prompt.stop, *QWEN.stops),
                gbnf=prompt.grammar,
                temperature=temperature,
                seed=seed,
                draft_text=prompt.draft,
            )
            text, shown = out.text, prompt.shown()
        if out.context_full:
            log.warning(
                "%s: a prompt of %d tokens fills the LM's context; no completion (it is judged as empty)",
                unit.span_type,
                out.prompt_tokens,
            )
        return Completion(
            text=text,
            generated_tokens=out.generated_tokens,
            seconds=time.perf_counter() - started,
            prompt_tokens=out.prompt_tokens,
            evaluated_prompt_tokens=out.evaluated_prompt_tokens,
            prompt_seconds=out.prompt_seconds,
            generation_seconds=out.generation_seconds,
            prompt=shown,
        )

    def close(self) -> None:
        close = getattr(self.lm, "close", None)
        if close is not None:
            close()


def _forced(prompt: FimPrompt, tokens: int, started: float) -> Completion:
    """The completion of a prompt whose grammar admits one text, without decoding it.

    Decoding would copy that text token by token under the grammar (a grammar-held retry of a
    four-move sweep: 120 tokens, 3 to 4 s on a 2-core CPU) and end where the prompt's stops end it.
    ``tokens``, the text's own tokenization, is what decoding counts, or one more where the model
    wrote the final line break as a token of its own (110 of 124 dev retries: equal; the rest: one).
    """
    text = prompt.forced or ""
    for stop in prompt.stop:
        text = text.split(stop, 1)[0]
    return Completion(
        text=text,
        generated_tokens=tokens,
        seconds=time.perf_counter() - started,
        forced=True,
        prompt=prompt.shown(),
    )
