"""The ``openai`` backend: any OpenAI-compatible ``/v1/completions`` server (vLLM, llama.cpp's server, …).

vLLM rejects ``suffix`` for most models, so the FIM string is sent pre-formatted as the prompt.
Generated tokens come from the server's ``usage`` (the model's own tokenizer); skill tokens from
llama.cpp's ``/tokenize`` when the server has it, else a tokenizer-free approximation.
"""

from __future__ import annotations

import logging
import time

from lerobot_policy_recent.recent_plugin.infillers.base import Completion
from lerobot_policy_recent.recent_plugin.infillers.fim_formats import fim_format
from lerobot_policy_recent.recent_plugin.infillers.http import post_json
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import approximate_tokens, build_prompt
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit

log = logging.getLogger(__name__)


class OpenAICompatInfiller:
    name = "openai"
    samples = True

    def __init__(
        self,
        base_url: str,
        model: str,
        *,
        api_key: str | None = None,
        timeout_s: float = 60.0,
        prompt_window: str = "dataflow",
    ):
        self.base_url = base_url.rstrip("/")
        self.prompt_window = prompt_window  # how much of a span's function its FIM prompt shows
        self.model = model
        self.format = fim_format(model)
        self.api_key = api_key
        self.timeout_s = timeout_s
        self._tokenize_available: bool | None = None

    def _post(self, path: str, body: dict) -> dict:
        return post_json(self.base_url, path, body, api_key=self.api_key, timeout_s=self.timeout_s)

    def count_tokens(self, text: str) -> int:
        if self._tokenize_available is not False:
            try:
                tokens = self._post("/tokenize", {"content": text}).get("tokens")
                if isinstance(tokens, list):
                    self._tokenize_available = True
                    return len(tokens)
            except RuntimeError:
                pass
            self._tokenize_available = False
            log.warning("%s has no /tokenize; skill tokens are approximated (GO's denominator)", self.base_url)
        return approximate_tokens(text)

    def infill(self, unit: RefactoringUnit, *, temperature: float = 0.0, seed: int = 0) -> Completion:
        prompt = build_prompt(unit, approximate_tokens(unit.span), self.prompt_window)
        started = time.perf_counter()
        out = self._post(
            "/v1/completions",
            {
                "model": self.model,
                "prompt": self.format.render(prompt.prefix, prompt.suffix),
                "max_tokens": prompt.max_tokens,
                "temperature": temperature,
                "seed": seed,
                "stop": [*prompt.stop, *self.format.stops],
            },
        )
        seconds = time.perf_counter() - started
        choices = out.get("choices") or [{}]
        usage = out.get("usage") or {}
        return Completion(
            text=choices[0].get("text", ""),
            generated_tokens=int(usage.get("completion_tokens", 0)),
            seconds=seconds,
            prompt_tokens=int(usage.get("prompt_tokens", 0)),
            prompt=prompt.shown(),
        )
