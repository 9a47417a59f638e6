"""Refactoring units z = ⟨span m, prefix, suffix, span type ρ, hints κ⟩.

A unit is cut from the current skill code around one conflict. Its prefix and suffix reach only
to the enclosing function (a tight window keeps CPU prompt evaluation cheap); the hints are the
ontology's cues for this one edit, rendered later as comments before the span.
"""

from __future__ import annotations

import ast
import json
from collections.abc import Callable
from dataclasses import dataclass

from lerobot_policy_recent.ontology.conversions import undetermined_facts
from lerobot_policy_recent.ontology.diagnosis import Conflict, ParameterMapping
from lerobot_policy_recent.ontology.skill_code import (
    enclosing_function,
    name_variables,
    object_literals,
    variable_kinds,
)
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.refactoring.decisions import Exclusion, decision_facts, exclusions
from lerobot_policy_recent.recent_plugin.refactoring.substitution import render_substitute_call


@dataclass(frozen=True)
class Hints:
    """κ: the grounding metadata for one span, for the robot it is grounded onto."""

    target: Target
    original_call: str
    substitute_signature: str | None = None
    substitute_call: str | None = None  # the substitution with mapped arguments bound, <type> where undecided
    mapping: tuple[ParameterMapping, ...] = ()
    dropped: tuple[str, ...] = ()
    unfilled: tuple[str, ...] = ()
    reason: str = ""
    feedback: str | None = None  # why the previous attempt was rejected, on a retry
    attempt: int = 0
    observation: str | None = None  # in-situ: what the run-time check saw
    facts: tuple[str, ...] = ()  # what an undetermined conversion's value is (units, frame), not a call to copy
    exclusions: tuple[Exclusion, ...] = ()  # names an open argument may not take (the held object as a receptacle)

    @property
    def robot(self) -> str:
        """The robot's name, as the prompt shows it."""
        return self.target.name


@dataclass(frozen=True)
class RefactoringUnit:
    """One span to fill and its context. ``style`` is None for RECENT's spans, whose prompts the
    product's builder knows; a method of the benchmark harness (a baseline, an ablation) brings its own."""

    span_start: int  # character offsets of m in the whole code
    span_end: int
    span: str  # m
    prefix: str  # ψ_pre: enclosing function up to the span's line, excluding its indentation
    suffix: str  # ψ_suf: from the end of the span to the end of the enclosing function
    indent: str
    span_type: str  # ρ
    hints: Hints  # κ
    substitute: str | None = None
    style: SpanStyle | None = None


@dataclass(frozen=True)
class SpanStyle:
    """How a span that is none of RECENT's is prompted: its comment lines, where the LM stops,
    whether it is a whole function body, and the grammar it is held to (None: written freely)."""

    comments: Callable[[Hints], list[str]]  # the lines before the span, from its hints
    stop: tuple[str, ...] | None = None  # None: the builder's, by the span's shape (one line or several)
    whole_body: bool = False  # a function body, blank lines and all (an instruct model writes it as a chat)
    grammar: str | None = None  # GBNF for backends that take one


def unit_from_conflict(
    code: str, conflict: Conflict, target: Target, *, feedback: str | None = None, attempt: int = 0
) -> RefactoringUnit:
    """Cut a unit for ``conflict`` from ``code`` (conflicts are resolved last-first, so offsets hold)."""
    start, end = conflict.span.start, conflict.span.end
    sub = conflict.substitute
    barred = exclusions(code, conflict)
    hints = Hints(
        target=target,
        original_call=code[start:end],
        substitute_signature=sub.signature() if sub else None,
        substitute_call=render_substitute_call(code[start:end], conflict),
        mapping=conflict.mapping,
        dropped=conflict.dropped,
        unfilled=conflict.unfilled,
        reason=conflict.reason,
        feedback=feedback,
        attempt=attempt,
        facts=undetermined_facts(conflict) + decision_facts(code, conflict, barred),
        exclusions=barred,
    )
    return cut_unit(code, start, end, conflict.span_type, hints, substitute=sub.name if sub else None)


def cut_unit(
    code: str,
    start: int,
    end: int,
    span_type: str,
    hints: Hints,
    *,
    substitute: str | None = None,
    style: SpanStyle | None = None,
) -> RefactoringUnit:
    """The unit for ``code[start:end]``: prefix and suffix reach to the enclosing function's ends.

    An empty span at a statement's start is an insertion: the suffix then begins on the next
    line, so the LM writes whole lines before the statement rather than the start of it.
    """
    line_start = code.rfind("\n", 0, start) + 1
    lo, hi = enclosing_function(code, start)
    indent = code[line_start:start]
    suffix = code[end:hi] if start < end else "\n" + indent + code[end:hi]
    return RefactoringUnit(
        span_start=start,
        span_end=end,
        span=code[start:end],
        prefix=code[lo:line_start],
        suffix=suffix,
        indent=indent,
        span_type=span_type,
        hints=hints,
        substitute=substitute,
        style=style,
    )


def names_in_scope(unit: RefactoringUnit) -> tuple[str, ...]:
    """What an object-name argument of the unit's span may be written as: the function's variables
    that hold an object name (``obj="cube"``), then the names it writes in quotes for a task query,
    quoted (``"table"``). A name from anywhere else is no object the skill knows: the 1.5B, offered
    any quoted name, wrote ``obj_name="cube1"``, and it validated."""
    try:
        func = ast.parse(unit.prefix + unit.indent + unit.span + unit.suffix).body[0]
    except (SyntaxError, IndexError):
        return ()
    if not isinstance(func, ast.FunctionDef):
        return ()
    return name_variables(variable_kinds(func)) + tuple(json.dumps(n) for n in object_literals(func))


def apply_unit(code: str, unit: RefactoringUnit, replacement: str) -> str:
    return code[: unit.span_start] + replacement + code[unit.span_end :]


def at_indent(text: str, indent: str) -> str:
    """Statements as they sit in a body at ``indent``: top-level lines at ``indent``; nested lines, written
    deeper (a segment keeps its later lines at the body's indentation), kept as they are."""
    first, *rest = text.splitlines() or [""]
    return "\n".join(
        [indent + first.lstrip(), *(line if line.startswith(indent) else indent + line.lstrip() for line in rest)]
    )
