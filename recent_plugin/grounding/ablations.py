"""The paper's grounding ablations, each a change to what the infiller is asked, nothing else.

* ``name-similarity`` — substitutes and parameter mappings chosen by API-name similarity instead of
  the ontology's ``substitutableBy`` and role matching; edits stay localized.
* ``full-regen`` — the ontology's hints for every conflict, but the LM rewrites the whole body of
  the skill instead of filling one span per conflict.
* ``no-ontology`` — no diagnosis hints at all: the LM rewrites the whole body given only the target
  robot's API.

Each is a registered method (:mod:`lerobot_policy_recent.recent_plugin.methods.recent`), as are
``recent-no-insitu`` and ``recent-no-offline-validation``, which change a setting of RECENT's.
"""

from __future__ import annotations

import difflib
from dataclasses import replace

from lerobot_policy_recent.ontology.diagnosis import Conflict, Diagnosis, ParameterMapping
from lerobot_policy_recent.ontology.skill_code import body_span
from lerobot_policy_recent.ontology.specs import ApiSpec, PrimitiveSpec
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.refactoring.substitution import has_placeholders, render_substitute_call
from lerobot_policy_recent.recent_plugin.refactoring.units import Hints, RefactoringUnit, cut_unit


def _similarity(a: str, b: str) -> float:
    return difflib.SequenceMatcher(None, a.lower(), b.lower()).ratio()


def name_similarity_conflicts(diagnosis: Diagnosis, source: ApiSpec, target: ApiSpec) -> Diagnosis:
    """Replace each conflict's substitute and mapping with the most similarly *named* ones."""
    conflicts = []
    for conflict in diagnosis.conflicts:
        original = source.get(conflict.original)
        substitute = max(target.primitives, key=lambda p: (_similarity(conflict.original, p.name), p.name))
        conflicts.append(_rename_mapping(conflict, original, substitute))
    return replace(diagnosis, conflicts=tuple(conflicts))


def _rename_mapping(conflict: Conflict, original: PrimitiveSpec, substitute: PrimitiveSpec) -> Conflict:
    mapping, dropped, taken = [], [], set()
    for param in original.parameters:
        free = [p for p in substitute.parameters if p.name not in taken]
        best = max(free, key=lambda p: _similarity(param.name, p.name), default=None)
        if best is None or _similarity(param.name, best.name) < 0.5:
            dropped.append(param.name)
            continue
        taken.add(best.name)
        mapping.append(ParameterMapping(param.name, best.name, role=""))
    unfilled = tuple(p.name for p in substitute.parameters if p.required and p.name not in taken)
    return replace(
        conflict,
        span_type="interface_rewiring" if unfilled else "api_substitution",
        substitute=substitute,
        mapping=tuple(mapping),
        dropped=tuple(dropped),
        unfilled=unfilled,
        preparatory=(),
        reason=f"no {conflict.original}; the most similar name is {substitute.name}",
    )


def whole_skill_unit(
    code: str, entry: str, diagnosis: Diagnosis, target: Target, *, with_hints: bool, feedback=None, attempt=0
) -> RefactoringUnit:
    """One unit spanning the whole body: with every conflict's hint (full-regen), or only the API (no-ontology)."""
    start, end = body_span(code, entry)
    if with_hints:
        rendered = _render_all(code, diagnosis)
        reason = "; ".join(
            f"line {c.span.line}: {c.reason}" + (f" ({c.substitute.signature()})" if c.substitute else "")
            for c in diagnosis.conflicts
        )
        expected = rendered[start : end + len(rendered) - len(code)] if rendered is not None else None
    else:
        reason = f"rewrite for {target.name}; its primitives: " + "; ".join(
            p.signature() for p in target.api.primitives
        )
        expected = None  # without the ontology there is nothing to render without an LM
    hints = Hints(
        target=target,
        original_call=code[start:end],
        substitute_call=expected,
        reason=reason,
        feedback=feedback,
        attempt=attempt,
    )
    return cut_unit(code, start, end, "full_regeneration", hints)


def _render_all(code: str, diagnosis: Diagnosis) -> str | None:
    """The whole program with every ontology substitution applied (None where an argument is undecided)."""
    for conflict in sorted(diagnosis.conflicts, key=lambda c: c.span.start, reverse=True):
        call = render_substitute_call(code[conflict.span.start : conflict.span.end], conflict)
        if call is None or has_placeholders(call):
            return None
        indent = code[code.rfind("\n", 0, conflict.span.start) + 1 : conflict.span.start]
        code = code[: conflict.span.start] + call.replace("\n", "\n" + indent) + code[conflict.span.end :]
    return code
