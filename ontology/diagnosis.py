"""The diagnosis operator D(skill, robot): determined conflicts with their substitution hints.

A call site conflicts when the target robot lacks the called primitive. The ontology's
``substitutableBy`` relation names the substitute; parameters are mapped by role, so the
conflict carries everything the refactoring step needs — no LM is involved here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ontology.builder import Ontology
from ontology.skill_code import CodeSpan, call_sites
from ontology.specs import PrimitiveSpec

SPAN_TYPES = ("api_substitution", "parameter_binding", "interface_rewiring", "preparatory_step")


@dataclass(frozen=True)
class ParameterMapping:
    source: str  # parameter name in the original call
    target: str  # parameter name of the substitute
    role: str
    values: tuple[tuple[object, object], ...] = ()  # literal translation when the vocabularies differ

    def translate(self, value: object) -> object:
        return dict(self.values).get(value, value)


@dataclass(frozen=True)
class Conflict:
    """A determined conflict: an exact code span, what it calls, and how to rewrite it."""

    span: CodeSpan
    span_type: str
    original: str  # the source primitive
    substitute: PrimitiveSpec | None
    mapping: tuple[ParameterMapping, ...] = ()
    dropped: tuple[str, ...] = ()  # source parameters the substitute has no role for
    unfilled: tuple[str, ...] = ()  # required substitute parameters nothing maps to
    reason: str = ""


@dataclass(frozen=True)
class Warning:
    """An undetermined factor: checked on live observations before ``span`` runs."""

    kind: str
    span: CodeSpan
    check: str
    observation: str
    message: str


@dataclass(frozen=True)
class Diagnosis:
    skill: str
    robot: str
    conflicts: tuple[Conflict, ...] = ()
    warnings: tuple[Warning, ...] = field(default_factory=tuple)

    @property
    def compatible(self) -> bool:
        return not self.conflicts


def _value_map(source: tuple | None, target: tuple | None) -> tuple[tuple[object, object], ...]:
    """Same role, different literal vocabularies of equal size (``'z'`` ↔ ``'down'``): map them in order."""
    if not source or not target or tuple(source) == tuple(target) or len(source) != len(target):
        return ()
    return tuple(zip(source, target, strict=True))


def diagnose(onto: Ontology, skill_name: str, code: str, robot: str, source: str = "Panda") -> Diagnosis:
    source_api, target_api = onto.api(source), onto.api(robot)
    conflicts = []
    for site in call_sites(code, skill_name):
        original = source_api.get(site.name)
        if original is None or target_api.get(site.name) is not None:
            continue  # a helper, or a primitive the target shares
        candidates = onto.substitutes(source, site.name, robot)
        if not candidates:
            conflicts.append(
                Conflict(
                    span=site.span,
                    span_type="api_substitution",
                    original=site.name,
                    substitute=None,
                    reason=f"{robot} has no primitive with the effects of {site.name} ({', '.join(sorted(original.effects))})",
                )
            )
            continue
        substitute = candidates[0]
        mapping, dropped = [], []
        for param in original.parameters:
            target = substitute.by_role(param.role)
            if target is None:
                dropped.append(param.name)
            else:
                mapping.append(
                    ParameterMapping(param.name, target.name, param.role, _value_map(param.choices, target.choices))
                )
        mapped = {m.target for m in mapping}
        unfilled = tuple(p.name for p in substitute.parameters if p.required and p.name not in mapped)
        conflicts.append(
            Conflict(
                span=site.span,
                span_type="interface_rewiring" if unfilled else "api_substitution",
                original=site.name,
                substitute=substitute,
                mapping=tuple(mapping),
                dropped=tuple(dropped),
                unfilled=unfilled,
                reason=f"no {site.name}; use {substitute.name} (same effects)",
            )
        )
    return Diagnosis(skill=skill_name, robot=robot, conflicts=tuple(conflicts))
