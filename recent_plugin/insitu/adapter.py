"""In-situ adaptation: patch the upcoming segment when a run-time check fails; repair a failed one.

Before a segment starts, the executor asks :meth:`InSituAdapter.before_segment` to evaluate the
checks instantiated from the warnings that guard it, on the latest observation. A violation
becomes a refactoring unit whose span is that segment alone and whose hints carry the
observation; the infiller writes the patch, validation admits it, and only then does it replace
the segment — the steps already taken stay taken. A primitive that fails at run time is repaired
the same way (:meth:`repair`): the span is the failed segment, the hint its failure. Every
infiller call is recorded as an :class:`~recent_plugin.grounding.grounder.LMCall` (EI and IT are
sums over them) and every decision as an :class:`AdaptationEvent` for the loggers.
"""

from __future__ import annotations

import ast
import logging
from dataclasses import dataclass, field

from ontology.diagnosis import Warning
from ontology.specs import ApiSpec
from recent_plugin.executor import Segment, SkillExecutor, SkillFailure
from recent_plugin.failures import FailureCategory
from recent_plugin.grounding.grounder import GroundedSkill, LMCall, clean_completion
from recent_plugin.grounding.units import Hints, apply_unit, cut_unit
from recent_plugin.grounding.validation import Verdict, validate_program
from recent_plugin.infillers.base import Infiller
from recent_plugin.insitu.checks import CHECKS, CheckInput, SceneFacts, Violation

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class AdaptationEvent:
    """One run-time decision: a check that failed, and the patch (or none) that answered it."""

    kind: str  # "revise" (a check failed before the segment) or "repair" (the segment failed)
    skill: str
    segment: int
    checks: tuple[str, ...]
    observation: str
    before: str
    after: str | None  # the accepted patch; None when no valid patch was found
    attempts: int


@dataclass
class InSituAdapter:
    robot: str
    api: ApiSpec
    apis: dict[str, ApiSpec]
    infiller: Infiller
    scene: SceneFacts
    insitu: bool = True  # False: the paper's "w/o in-situ adaptation" (reactive repair only)
    max_retries: int = 2
    max_repairs: int = 2  # per skill
    calls: list[LMCall] = field(default_factory=list)
    events: list[AdaptationEvent] = field(default_factory=list)
    _repairs: dict[str, int] = field(default_factory=dict)

    # ------------------------------------------------------------------ guards
    def guard(self, grounded: GroundedSkill, segments: list[Segment]) -> None:
        """Attach each checkable 'before' warning to the top-level statement that contains it."""
        if not self.insitu:
            return
        warnings = [w for w in grounded.warnings() if w.phase == "before" and w.check in CHECKS]
        for segment in segments:
            first, last = segment.node.lineno, segment.node.end_lineno or segment.node.lineno
            segment.guards = tuple(w for w in warnings if first <= w.span.line <= last)

    def before_segment(self, executor: SkillExecutor, index: int) -> None:
        segment = executor.segments[index]
        violations = [v for w in segment.guards if (v := self._evaluate(executor, segment, w)) is not None]
        if not violations:
            return
        statements = tuple(dict.fromkeys(s for v in violations for s in v.statements))
        observation = "; ".join(v.observation for v in violations)
        checks = tuple(v.check for v in violations)
        if not statements:  # nothing a patch can change (e.g. the object is not there): run and see
            self.events.append(
                AdaptationEvent("revise", executor.grounded.skill, index, checks, observation, segment.source, None, 0)
            )
            return
        reason = "; ".join(dict.fromkeys(w.message for w in segment.guards if w.check in checks))
        self._patch(executor, index, "revise", "in_situ_revision", checks, reason, observation, statements)

    def _evaluate(self, executor: SkillExecutor, segment: Segment, warning: Warning) -> Violation | None:
        call = next(
            (
                n
                for n in ast.walk(segment.node)
                if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == warning.primitive
            ),
            None,
        )
        spec = self.api.get(warning.primitive)
        if call is None or spec is None:
            return None
        arguments = {k.arg: _value(k.value, executor) for k in call.keywords if k.arg}
        used = {n.id for n in ast.walk(call) if isinstance(n, ast.Name)}
        reads = executor.namespace["task"].position_reads
        stale = {
            var: (name, list(value))
            for var, value in executor.namespace.items()
            if var in used
            for name, read in reads
            if value is read
        }
        named = frozenset(v for v in executor.namespace.values() if isinstance(v, str) and v in self.scene.kinds)
        inp = CheckInput(
            warning=warning,
            obs=executor.session.obs,
            arguments={k: v for k, v in arguments.items() if v is not None},
            roles={p.name: p.role for p in spec.parameters},
            named=named,
            stale_reads=stale,
            scene=self.scene,
            api=self.api,
        )
        return CHECKS[warning.check](inp)

    # ------------------------------------------------------------------ repair
    def repair(self, executor: SkillExecutor, failure: SkillFailure) -> bool:
        """Replace the failed segment with a repaired one; it then runs again from the current state."""
        skill = executor.grounded.skill
        if self._repairs.get(skill, 0) >= self.max_repairs:
            return False
        self._repairs[skill] = self._repairs.get(skill, 0) + 1
        segment = executor.segments[failure.segment]
        if failure.segment < executor.cursor:
            return False
        # Positions the segment uses are re-read: the usual cause is a world that moved on.
        used = {n.id for n in ast.walk(segment.node) if isinstance(n, ast.Name)}
        reads = executor.namespace["task"].position_reads
        statements = tuple(
            dict.fromkeys(
                f"{var} = task.get_object_position({name!r})"
                for var, value in executor.namespace.items()
                if var in used
                for name, read in reads
                if value is read
            )
        )
        return self._patch(
            executor,
            failure.segment,
            "repair",
            "reactive_repair",
            (str(failure.category),),
            f"{failure.category}: the statement failed at run time",
            failure.message,
            statements,
        )

    # ------------------------------------------------------------------ patching
    def _patch(
        self,
        executor: SkillExecutor,
        index: int,
        kind: str,
        span_type: str,
        checks: tuple[str, ...],
        reason: str,
        observation: str,
        statements: tuple[str, ...],
    ) -> bool:
        segment = executor.segments[index]
        code = executor.source()
        start, end = executor.segment_offsets(index)
        suggestion = "\n".join([*statements, segment.source.replace("\n" + executor.indent, "\n")])
        feedback, accepted = None, None
        for attempt in range(self.max_retries + 1):
            hints = Hints(
                robot=self.robot,
                original_call=segment.source,
                substitute_call=suggestion,
                reason=reason,
                feedback=feedback,
                attempt=attempt,
                observation=observation,
            )
            unit = cut_unit(code, start, end, span_type, hints)
            completion = self.infiller.infill(unit)
            text = clean_completion(completion.text, unit)
            verdict = validate_program(apply_unit(code, unit, text), self.api, executor.grounded.entry, self.apis)
            if verdict.ok and not text:
                verdict = Verdict.reject(FailureCategory.EMPTY_CONTINUATION, "the patch is empty")
            self.calls.append(
                LMCall(
                    kind=kind,
                    span_type=span_type,
                    original=segment.source,
                    text=text,
                    generated_tokens=completion.generated_tokens,
                    seconds=completion.seconds,
                    accepted=verdict.ok,
                    category=None if verdict.ok else str(verdict.category),
                    message=verdict.message,
                )
            )
            if verdict.ok:
                accepted = text
                break
            feedback = verdict.message
        self.events.append(
            AdaptationEvent(
                kind, executor.grounded.skill, index, checks, observation, segment.source, accepted, attempt + 1
            )
        )
        if accepted is None:
            log.warning("%s: no valid %s patch for segment %d of %s", self.robot, kind, index, executor.grounded.skill)
            return False
        executor.replace_segment(index, accepted)
        return True


def _value(node: ast.expr, executor: SkillExecutor) -> object | None:
    """Evaluate an argument expression now (validated code; calls other than task queries are skipped)."""
    if any(isinstance(n, ast.Call) and isinstance(n.func, ast.Name) for n in ast.walk(node)):
        return None
    try:
        return eval(compile(ast.Expression(node), "<check>", "eval"), dict(executor.namespace))  # noqa: S307
    except Exception:  # noqa: BLE001 - a value we cannot compute is a check we cannot run
        return None
