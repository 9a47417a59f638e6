"""The paper's grounding ablations, each a change to what the infiller is asked, nothing else.

* ``name-similarity`` — substitutes and parameter mappings chosen by API-name similarity instead of
  the ontology's ``substitutableBy`` and role matching; edits stay localized.
* ``full-regen`` — the ontology's hints for every conflict, but the LM rewrites the whole body of
  the skill instead of filling one span per conflict.
* ``no-ontology`` — no diagnosis hints at all: the LM rewrites the whole body given only the target
  robot's API.

Each is a registered method below, as are ``recent-no-insitu`` and ``recent-no-offline-validation``,
which change a setting of RECENT's, and the sanity rows ``oracle-rule`` and ``source`` (the ceiling). Importing this module
registers them; the policy never does.
"""

from __future__ import annotations

import difflib
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import ClassVar

from lerobot_policy_recent.ontology.builder import Ontology
from lerobot_policy_recent.ontology.diagnosis import Conflict, Diagnosis, ParameterMapping, diagnose
from lerobot_policy_recent.ontology.skill_code import body_span
from lerobot_policy_recent.ontology.specs import ApiSpec, PrimitiveSpec
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.failures import FailureCategory
from lerobot_policy_recent.recent_plugin.grounding.attempts import infill_until_valid
from lerobot_policy_recent.recent_plugin.grounding.gate import Verdict, validate_program
from lerobot_policy_recent.recent_plugin.grounding.grounder import (
    GroundedSkill,
    ground_skill,
    refused_source,
    unrecoverable,
)
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.methods.base import Grounding, Method
from lerobot_policy_recent.recent_plugin.methods.recent import Recent
from lerobot_policy_recent.recent_plugin.refactoring.substitution import has_placeholders, render_substitute_call
from lerobot_policy_recent.recent_plugin.refactoring.units import (
    Hints,
    RefactoringUnit,
    SpanStyle,
    apply_unit,
    cut_unit,
)
from lerobot_policy_recent.skills.repository import Skill


def _whole_body_comments(hints: Hints) -> list[str]:
    """Every conflict's cue (full-regen) or only the API (no-ontology), after a rejection if any."""
    rejected = [f"Rejected before: {hints.feedback}"] if hints.feedback else []
    return [*rejected, f"{hints.robot}: {hints.reason}"]


# the body ends where the model ends the middle, or at the next definition
WHOLE_BODY = SpanStyle(_whole_body_comments, stop=("\ndef ", "\nclass "), whole_body=True)


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
    return cut_unit(code, start, end, "full_regeneration", hints, style=WHOLE_BODY)


def _render_all(code: str, diagnosis: Diagnosis) -> str | None:
    """The whole program with every ontology substitution applied (None where an argument is undecided)."""
    for conflict in sorted(diagnosis.conflicts, key=lambda c: c.span.start, reverse=True):
        call = render_substitute_call(code[conflict.span.start : conflict.span.end], conflict)
        if call is None or has_placeholders(call):
            return None
        indent = code[code.rfind("\n", 0, conflict.span.start) + 1 : conflict.span.start]
        code = code[: conflict.span.start] + call.replace("\n", "\n" + indent) + code[conflict.span.end :]
    return code


def regenerate_skill(
    skill: Skill,
    target: Target,
    onto: Ontology,
    infiller: Infiller,
    *,
    max_retries: int = 2,
    with_hints: bool,
    needed: Callable[[GroundedSkill], bool],
) -> GroundedSkill:
    """The whole-body ablations: one span, the entire skill, regenerated until it validates.

    ``with_hints``: every conflict's ontology hint in the prompt (else only the target's API);
    ``needed(result)``, asked once the original is diagnosed and validated, says whether to regenerate.
    """
    started = time.perf_counter()
    robot, api, apis = target.name, target.api, onto.apis
    diagnosis = diagnose(onto, skill.name, skill.code, robot, skill.source_embodiment, skill.placed_over)
    result = GroundedSkill.start(skill, robot, diagnosis, infiller)
    if refused := refused_source(skill, apis):
        result.verdict, result.seconds = refused, time.perf_counter() - started
        return result
    result.verdict = validate_program(skill.code, api, skill.entry, apis)
    if needed(result):
        _regenerate(result, skill, target, infiller, apis, max_retries, with_hints)
    result.seconds = time.perf_counter() - started
    return result


def _regenerate(result: GroundedSkill, skill: Skill, target: Target, infiller, apis, max_retries, with_hints) -> None:
    def judge(unit: RefactoringUnit, text: str) -> tuple[Verdict, str]:
        candidate = apply_unit(skill.code, unit, text)
        if not text:
            return Verdict.reject(FailureCategory.EMPTY_CONTINUATION, "the regenerated body is empty"), candidate
        return validate_program(candidate, target.api, skill.entry, apis), candidate

    accepted = infill_until_valid(
        infiller,
        lambda feedback, attempt: whole_skill_unit(
            skill.code,
            skill.entry,
            result.diagnosis,
            target,
            with_hints=with_hints,
            feedback=feedback,
            attempt=attempt,
        ),
        judge,
        kind="ground",
        max_retries=max_retries,
        calls=result.calls,
    )
    if accepted is None:
        result.verdict = unrecoverable(
            result, f"unrecoverable: the regenerated skill did not validate after {max_retries + 1} attempts"
        )
        return
    result.code, result.verdict = accepted.candidate, accepted.verdict
    result.edits = [(accepted.unit.span_start, accepted.unit.span_end, len(accepted.text))]


@Method.register_subclass("oracle-rule")
@dataclass
class OracleRule(Recent):
    """Sanity row: RECENT's pipeline with the ontology's rendering in place of the LM, for every span
    and every run-time patch. What the ontology and the checks achieve alone: the floor an LM must
    beat (RECENT's SR minus this one's, on the same episodes, is the LM's necessity)."""

    family: ClassVar[str] = "sanity"

    def model(self, lm: Infiller) -> Infiller:
        from lerobot_policy_recent.recent_plugin.infillers.rule import RuleInfiller

        return RuleInfiller()


@Method.register_subclass("source")
@dataclass
class Source(Recent):
    """The ceiling row: each episode of a target runs on the task's source robot (the Panda, the
    Franka Hand) with its own reference skills, RECENT's checks and adaptation, and the same LM.
    Nothing is grounded, so its success is what the world leaves the skills; a method's SR over it,
    on the same episodes, is the share of the ceiling the grounding keeps."""

    family: ClassVar[str] = "sanity"
    on_source: ClassVar[bool] = True


@Method.register_subclass("recent-no-insitu")
@dataclass
class NoInsitu(Recent):
    """The paper's "w/o in-situ adaptation": no run-time checks, reactive repair only."""

    family: ClassVar[str] = "ablation"
    expected: ClassVar[dict[str, int]] = {"sr": -1}
    insitu: bool = False


@Method.register_subclass("recent-no-offline-validation")
@dataclass
class NoOfflineValidation(Recent):
    """The paper's "w/o offline validation": skills are served without a passing validation record."""

    family: ClassVar[str] = "ablation"
    expected: ClassVar[dict[str, int]] = {"sr": -1, "go": +1}
    offline_validation: bool = False


@Method.register_subclass("recent-name-similarity")
@dataclass
class NameSimilarity(Recent):
    """Substitutes and parameter mappings by API-name similarity instead of the ontology; edits stay localized."""

    family: ClassVar[str] = "ablation"
    expected: ClassVar[dict[str, int]] = {"sr": -1, "ei": +1}

    def ground(self, g: Grounding) -> GroundedSkill:
        def by_name(diagnosis):
            source = g.ontology.api(g.skill.source_embodiment)
            return name_similarity_conflicts(diagnosis, source, g.target.api)

        return ground_skill(g.skill, g.target, g.ontology, g.infiller, max_retries=g.max_retries, rediagnose=by_name)


@dataclass
class WholeBodyRegeneration(Recent):
    """The whole-body ablations: one span, the entire skill, regenerated until it validates."""

    family: ClassVar[str] = "ablation"
    with_hints: ClassVar[bool]  # every conflict's ontology hint in the prompt, or only the target's API

    def needed(self, result: GroundedSkill) -> bool:
        """Whether the diagnosed and validated original must be regenerated at all."""
        raise NotImplementedError

    def ground(self, g: Grounding) -> GroundedSkill:
        return regenerate_skill(
            g.skill,
            g.target,
            g.ontology,
            g.infiller,
            max_retries=g.max_retries,
            with_hints=self.with_hints,
            needed=self.needed,
        )


@Method.register_subclass("recent-full-regen")
@dataclass
class FullRegen(WholeBodyRegeneration):
    """Every conflict's ontology hint, but the LM rewrites the whole body instead of one span per conflict."""

    expected: ClassVar[dict[str, int]] = {"sr": -1, "go": +1}
    with_hints: ClassVar[bool] = True

    def needed(self, result: GroundedSkill) -> bool:
        return bool(result.diagnosis.conflicts)


@Method.register_subclass("recent-no-ontology")
@dataclass
class NoOntology(WholeBodyRegeneration):
    """No diagnosis hints: the LM rewrites the whole body given only the target robot's API."""

    expected: ClassVar[dict[str, int]] = {"sr": -1, "ei": +1}
    with_hints: ClassVar[bool] = False

    def needed(self, result: GroundedSkill) -> bool:
        return not (result.verdict.ok and not result.diagnosis.warnings)
