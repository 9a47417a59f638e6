"""A chat model behind an OpenAI-compatible ``/v1/chat/completions`` endpoint, for whole programs.

Large served models (the paper's CaP-Codex row) are chat models: they take no FIM string. The
unit's prompt (the header with the API, the example and the task, then the code up to the span)
becomes one user message that asks for the span alone; the reply's code block is the completion.
A reply that repeats the whole function is cut back to its body.
"""

from __future__ import annotations

import re
import time

from lerobot_policy_recent.recent_plugin.infillers.base import Completion
from lerobot_policy_recent.recent_plugin.infillers.http import post_json
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import approximate_tokens, build_prompt
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit

SYSTEM = "You write Python skill code for robots. Answer with code only, in one ```python block."
_BLOCK = re.compile(r"```(?:python)?\n(.*?)(?:```|$)", re.DOTALL)


class OpenAIChatInfiller:
    name = "openai-chat"

    def __init__(self, base_url: str, model: str, *, api_key: str | None = None, timeout_s: float = 120.0):
        self.base_url, self.model, self.api_key, self.timeout_s = base_url.rstrip("/"), model, api_key, timeout_s

    def count_tokens(self, text: str) -> int:
        return approximate_tokens(text)  # a served chat model's tokenizer is not ours to call

    def infill(self, unit: RefactoringUnit, *, temperature: float = 0.0, seed: int = 0) -> Completion:
        prompt = build_prompt(unit, approximate_tokens(unit.span))
        ask = (
            "Write the code that goes at <FILL> below"
            + (", the whole body of the last function" if "program" in unit.span_type else "")
            + ". Reply with that code only, indented as it stands there.\n\n"
        )
        started = time.perf_counter()
        out = post_json(
            self.base_url,
            "/v1/chat/completions",
            {
                "model": self.model,
                "messages": [
                    {"role": "system", "content": SYSTEM},
                    {"role": "user", "content": ask + prompt.prefix + "<FILL>" + prompt.suffix},
                ],
                "temperature": temperature,
                "seed": seed,
            },
            api_key=self.api_key,
            timeout_s=self.timeout_s,
        )
        choices = out.get("choices") or [{}]
        usage = out.get("usage") or {}
        text = span_of_reply((choices[0].get("message") or {}).get("content") or "")
        return Completion(
            text=text,
            generated_tokens=int(usage.get("completion_tokens", approximate_tokens(text))),
            seconds=time.perf_counter() - started,
            prompt_tokens=int(usage.get("prompt_tokens", 0)),
        )


def span_of_reply(reply: str) -> str:
    """The code of a chat reply: its first code block (or the reply), without a repeated ``def`` line
    and docstring, dedented to the body's first line."""
    match = _BLOCK.search(reply)
    code = (match.group(1) if match else reply).strip("\n")
    lines = code.splitlines()
    if lines and lines[0].lstrip().startswith("def "):
        lines = lines[1:]
        if lines and lines[0].strip().startswith(('"""', "'''")):
            quote = lines[0].strip()[:3]
            end = (
                0
                if lines[0].strip().count(quote) >= 2
                else next((i for i, line in enumerate(lines[1:], 1) if quote in line), 0)
            )
            lines = lines[end + 1 :]
    body = "\n".join(lines)
    first = next((line for line in lines if line.strip()), "")
    indent = len(first) - len(first.lstrip())
    return "\n".join(line[indent:] if line[:indent].isspace() else line for line in body.splitlines()).strip()
