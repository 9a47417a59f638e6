"""Whole programs as a chat: the prompt an instruct model expects when it writes a function body.

FIM fits an edit inside code. A whole body (a baseline's program, the full-regeneration ablation)
is a request to write code, and an instruct checkpoint is trained to take that through its chat
template: a system line, then the unit as one user message with ``<FILL>`` where the body goes (the
header with the API, the example and the task above it; the code after it below). The reply's code
block is the span. The same messages serve a served chat model (``/v1/chat/completions``) and a
local one, whose template renders them (Qwen2.5's is ChatML).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import (
    FILL,
    approximate_tokens,
    build_prompt,
)
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit

SYSTEM = "You write Python skill code for robots. Answer with code only, in one ```python block."
FENCE_TOKENS = 16  # the reply's ```python … ``` around the code
CHATML_STOPS = ("<|im_end|>", "<|endoftext|>")  # the end of an assistant turn in ChatML
_BLOCK = re.compile(r"```(?:python)?\n(.*?)(?:```|$)", re.DOTALL)


@dataclass(frozen=True)
class ChatPrompt:
    messages: tuple[dict[str, str], ...]  # {"role": ..., "content": ...}, system first
    max_tokens: int  # the FIM span's budget plus the code fence, and for a whole body, room to restate its header


def writes_whole_body(unit: RefactoringUnit) -> bool:
    """A whole function body is written, not a span edited: what an instruct model gets as a chat."""
    return unit.style is not None and unit.style.whole_body


def build_chat(unit: RefactoringUnit, span_tokens: int) -> ChatPrompt:
    """The unit as one user message: what to write, then the code with ``<FILL>`` at the span."""
    prompt = build_prompt(unit, span_tokens)  # the same text and hints the FIM prompt holds
    ask = (
        f"Write the code that goes at {FILL} below"
        + (", the whole body of the last function" if writes_whole_body(unit) else "")
        + ". Reply with that code only, indented as it stands there.\n\n"
    )
    restated = restatement_tokens(prompt.prefix) if writes_whole_body(unit) else 0
    return ChatPrompt(
        messages=(
            {"role": "system", "content": SYSTEM},
            {"role": "user", "content": ask + prompt.prefix + FILL + prompt.suffix},
        ),
        max_tokens=prompt.max_tokens + FENCE_TOKENS + restated,
    )


def restatement_tokens(prefix: str) -> int:
    """Room for what an instruct model writes again before a whole body: the function's ``def`` line,
    its docstring, and the comment lines above the fill (an error fed back, the scene). Qwen2.5-Coder
    restates them in most replies; ``span_of_reply`` drops the first two, and the comments do nothing
    when the program runs. Without this room, a regenerated program whose prompt carries a long error
    was cut mid-statement and failed to parse. The count is doubled, as the span's own budget is:
    digits and punctuation cost more real tokens than ``approximate_tokens`` counts."""
    start = prefix.rfind("\ndef ")
    return 0 if start < 0 else 2 * approximate_tokens(prefix[start + 1 :])


def render_chatml(messages: tuple[dict[str, str], ...] | list[dict[str, str]]) -> str:
    """ChatML, the template of Qwen2.5's instruct checkpoints, ending where the assistant's turn begins."""
    turns = "".join(f"<|im_start|>{m['role']}\n{m['content']}<|im_end|>\n" for m in messages)
    return turns + "<|im_start|>assistant\n"


def span_of_reply(reply: str, indent: str = "") -> str:
    """The code of a chat reply as a FIM span would stand: its first code block (or the reply),
    without a repeated ``def`` line and docstring, the first line bare and the later ones at the
    body's ``indent`` (nested blocks stay nested)."""
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
    depth = len(first) - len(first.lstrip())
    dedented = [line[depth:] if line[:depth].isspace() else line for line in body.splitlines()]
    code = "\n".join(dedented).strip()
    return code.replace("\n", "\n" + indent) if indent else code
