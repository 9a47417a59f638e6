"""A chat model behind an OpenAI-compatible ``/v1/chat/completions`` endpoint, for whole programs.

Large served models (the paper's CaP-Codex row) are chat models: they take no FIM string. The
unit's prompt (the header with the API, the example and the task, then the code up to the span)
becomes one user message that asks for the span alone; the reply's code block is the completion.
A reply that repeats the whole function is cut back to its body.
"""

from __future__ import annotations

import time

from lerobot_policy_recent.recent_plugin.infillers.base import Completion
from lerobot_policy_recent.recent_plugin.infillers.http import post_json
from lerobot_policy_recent.recent_plugin.refactoring.chat_prompt import build_chat, render_chatml, span_of_reply
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import approximate_tokens
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit


class OpenAIChatInfiller:
    name = "openai-chat"
    samples = True

    def __init__(self, base_url: str, model: str, *, api_key: str | None = None, timeout_s: float = 120.0):
        self.base_url, self.model, self.api_key, self.timeout_s = base_url.rstrip("/"), model, api_key, timeout_s

    def count_tokens(self, text: str) -> int:
        return approximate_tokens(text)  # a served chat model's tokenizer is not ours to call

    def infill(self, unit: RefactoringUnit, *, temperature: float = 0.0, seed: int = 0) -> Completion:
        chat = build_chat(unit, approximate_tokens(unit.span))
        started = time.perf_counter()
        out = post_json(
            self.base_url,
            "/v1/chat/completions",
            {
                "model": self.model,
                "messages": list(chat.messages),
                "temperature": temperature,
                "seed": seed,
            },
            api_key=self.api_key,
            timeout_s=self.timeout_s,
        )
        choices = out.get("choices") or [{}]
        usage = out.get("usage") or {}
        text = span_of_reply((choices[0].get("message") or {}).get("content") or "", unit.indent)
        return Completion(
            text=text,
            generated_tokens=int(usage.get("completion_tokens", approximate_tokens(text))),
            seconds=time.perf_counter() - started,
            prompt_tokens=int(usage.get("prompt_tokens", 0)),
            prompt=render_chatml(chat.messages),  # the messages sent, system line and instruction included
        )
