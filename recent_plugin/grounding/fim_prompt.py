"""Render a refactoring unit as a Fill-in-the-Middle prompt: hints become comments before the span.

The span type decides which cues appear, so the LM sees only what this edit needs.
"""

from __future__ import annotations

from dataclasses import dataclass

from recent_plugin.grounding.units import Hints, RefactoringUnit


@dataclass(frozen=True)
class FimPrompt:
    prefix: str
    suffix: str
    stop: tuple[str, ...]  # text stops that end the span (on top of the model's special tokens)
    max_tokens: int


def hint_lines(span_type: str, hints: Hints) -> list[str]:
    """Comment lines for one edit; the substitute's signature comes last, nearest the span."""
    lines = [f"{hints.robot} ({span_type.replace('_', ' ')}): {hints.reason}", f"Was: {hints.original_call}"]
    edits = []
    if hints.mapping:
        edits.append("map " + ", ".join(f"{src} -> {dst}" for src, dst in hints.mapping))
    if hints.dropped:
        edits.append("drop " + ", ".join(hints.dropped))
    if hints.unfilled:
        edits.append("also pass " + ", ".join(hints.unfilled))
    if edits:
        lines.append("Arguments: " + "; ".join(edits))
    if hints.feedback:
        lines.append(f"Rejected before: {hints.feedback}")
    if span_type in {"api_substitution", "interface_rewiring"} and hints.substitute_signature:
        lines.append(f"{hints.robot} API: {hints.substitute_signature}")
        lines.append(f"Call exactly: {hints.substitute_template}")
    return lines


def build_prompt(unit: RefactoringUnit, span_tokens: int) -> FimPrompt:
    comments = "".join(f"{unit.indent}# {line}\n" for line in hint_lines(unit.span_type, unit.hints))
    single_line = "\n" not in unit.span
    return FimPrompt(
        prefix=unit.prefix + comments + unit.indent,
        suffix=unit.suffix,
        stop=("\n",) if single_line else ("\n\n",),
        max_tokens=max(24, 2 * span_tokens + 16),
    )
