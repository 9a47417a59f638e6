"""The LM calls every method makes, and their records: the retry loop, LMCall and AdaptationEvent.

RECENT's grounding and in-situ adaptation, its ablations and the baselines all ask an infiller
for a span, judge it and retry with the rejection as feedback, and all are measured by the same
records (GO, EI, IT and IGT are sums over :class:`LMCall`), so the loop and the records live here,
below each of them.
"""

from __future__ import annotations

import difflib
import io
import logging
import tokenize
from collections.abc import Callable
from dataclasses import dataclass

from lerobot_policy_recent.logs.events import Event, InfillCall, ValidationVerdict
from lerobot_policy_recent.recent_plugin.grounding.budget import LMBudgetExhausted
from lerobot_policy_recent.recent_plugin.grounding.gate import Verdict
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import build_prompt, decided_by_rule, hint_lines
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class LMCall:
    """One infiller call; GO/EI/IT/IGT are sums over these records, never estimates."""

    kind: str  # "ground" (before execution), "revise" (in-situ), "repair" (after a failure)
    span_type: str
    original: str
    text: str
    generated_tokens: int
    seconds: float
    accepted: bool
    category: str | None = None
    message: str = ""
    span: str = ""  # the span the unit replaced (empty for an insertion)
    hints: tuple[str, ...] = ()  # the hint comments as the model saw them
    prompt: str = ""  # what was sent (``Completion.prompt``): prefix + <FILL> + suffix, or a program's whole chat
    rendered: bool = False  # the fast path wrote it; a revise or repair so written is no interruption
    attempt: int = 0  # 0 for a span's first call, then its retries
    decided: bool = False  # the ontology or a check wrote every argument (decided_by_rule): no LM was needed
    prompt_tokens: int = 0
    evaluated_prompt_tokens: int = 0  # not already in the model's cache
    prompt_seconds: float = 0.0  # of ``seconds``: prompt evaluation (0 where the backend does not measure it)
    generation_seconds: float = 0.0  # of ``seconds``: generation
    forced: bool = False  # the grammar admitted one text, returned without running the model (still a call)
    declined: bool = False  # the backend cannot decide this span (the rule backend, an open argument): not retried


def call_events(skill: str, call: LMCall) -> list[Event]:
    """An infiller call as the logs see it: the unit, prompt and completion, then the validation verdict."""
    return [
        InfillCall(
            skill,
            call.kind,
            call.span_type,
            call.span,
            list(call.hints),
            call.prompt,
            call.text,
            call.generated_tokens,
            call.seconds,
            call.rendered,
            call.forced,
            call.prompt_tokens,
            call.evaluated_prompt_tokens,
            round(call.prompt_seconds, 4),
            round(call.generation_seconds, 4),
        ),
        ValidationVerdict(skill, call.kind, call.accepted, call.category or "", "" if call.accepted else call.message),
    ]


def strip_comments(text: str) -> str:
    """Drop comments the LM appended to its code (they are prompt echoes, not part of the edit)."""
    try:
        tokens = [t for t in tokenize.generate_tokens(io.StringIO(text).readline) if t.type != tokenize.COMMENT]
        return tokenize.untokenize(tokens)
    except (tokenize.TokenError, SyntaxError, IndentationError):
        return text  # broken code is reported by validation, as written


def clean_completion(text: str, unit: RefactoringUnit) -> str:
    """The span as it goes into the code: comments and trailing space dropped, later lines re-indented."""
    lines = [line.rstrip() for line in strip_comments(text).strip().splitlines() if line.strip()]
    if not lines:
        return ""
    # later lines already at (or inside) the body's indentation keep theirs: nested blocks stay nested
    return "\n".join(
        [lines[0], *(line if line.startswith(unit.indent) else unit.indent + line.lstrip() for line in lines[1:])]
    )


@dataclass(frozen=True)
class Attempt:
    """An accepted infill: the unit it answered, the cleaned span text and the program with it applied."""

    unit: RefactoringUnit
    text: str
    candidate: str
    verdict: Verdict


def infill_until_valid(
    infiller: Infiller,
    make_unit: Callable[[str | None, int], RefactoringUnit],
    judge: Callable[[RefactoringUnit, str], tuple[Verdict, str]],
    *,
    kind: str,
    max_retries: int,
    calls: list[LMCall],
    clean: Callable[[str, RefactoringUnit], str] = clean_completion,
) -> Attempt | None:
    """Ask for a span, judge it, retry with the rejection as feedback; every call is recorded in ``calls``.

    ``make_unit(feedback, attempt)`` cuts the unit; ``judge(unit, text)`` returns the verdict and
    the candidate program. The one loop behind grounding, regeneration, revision and repair.
    ``clean`` turns the completion into the span's text (code by default; SCoT's plan keeps its lines).
    """
    feedback = None
    for attempt in range(max_retries + 1):
        unit = make_unit(feedback, attempt)
        try:
            completion = infiller.infill(unit)
        except LMBudgetExhausted as spent:
            log.info("%s: no further %s attempt: %s", unit.span_type, kind, spent)
            return None
        text = clean(completion.text, unit)
        verdict, candidate = judge(unit, text)
        if completion.declined and not verdict.ok:
            verdict = Verdict.reject(verdict.category, completion.declined)
        calls.append(
            LMCall(
                kind=kind,
                span_type=unit.span_type,
                original=unit.hints.original_call,
                text=text,
                generated_tokens=completion.generated_tokens,
                seconds=completion.seconds,
                accepted=verdict.ok,
                category=None if verdict.ok else str(verdict.category),
                message=verdict.message,
                span=unit.span,
                hints=tuple(hint_lines(unit)),
                prompt=completion.prompt or build_prompt(unit, 0).shown(),
                rendered=completion.rendered,
                attempt=attempt,
                decided=decided_by_rule(unit),
                prompt_tokens=completion.prompt_tokens,
                evaluated_prompt_tokens=completion.evaluated_prompt_tokens,
                prompt_seconds=completion.prompt_seconds,
                generation_seconds=completion.generation_seconds,
                forced=completion.forced,
                declined=bool(completion.declined),
            )
        )
        if verdict.ok:
            return Attempt(unit, text, candidate, verdict)
        if completion.declined:
            return None  # no feedback changes what the backend can decide
        feedback = verdict.message
    return None


@dataclass(frozen=True)
class AdaptationEvent:
    """One run-time decision: a check that failed, and the patch (or none) that answered it."""

    # "revise" (a check failed before the segment), "repair" (the segment failed), "achieved" (it
    # failed, and what the skill is for already holds: the skill ends there)
    kind: str
    skill: str
    segment: int
    checks: tuple[str, ...]
    observation: str
    before: str
    after: str | None  # the accepted patch; None when no valid patch was found
    attempts: int


def source_diff(before: str, after: str) -> str:
    """A patch as the logs show it: the skill before and after, as a unified diff."""
    return "".join(
        difflib.unified_diff(
            before.splitlines(keepends=True), after.splitlines(keepends=True), "before", "after (patched)"
        )
    )
