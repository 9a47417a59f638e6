"""In-situ adaptation: patch the upcoming segment when a run-time check fails; repair a failed one.

Before a segment starts, the executor asks :meth:`InSituAdapter.before_segment` to evaluate the
checks instantiated from the warnings that guard it, on the latest observation. A violation
becomes a refactoring unit whose span is that segment alone and whose hints carry the
observation; the infiller writes the patch, validation admits it, and only then does it go in
before the segment — the steps already taken stay taken. Once a segment completes,
:meth:`InSituAdapter.after_segment` checks its effects the same way; an effect that did not
happen (a push that left the object short) is answered by statements inserted right after it
that do it again from the current scene. A primitive that fails at run time is repaired
the same way (:meth:`repair`): the span is the failed segment, the hint its failure. Every
infiller call is recorded as an :class:`~lerobot_policy_recent.recent_plugin.grounding.grounder.LMCall` (EI and IT are
sums over them) and every decision as an :class:`AdaptationEvent` for the loggers.
"""

from __future__ import annotations

import ast
import logging
import textwrap
from collections import Counter
from dataclasses import dataclass, field, replace

import numpy as np

from lerobot_policy_recent.logs.events import CheckVerdict, Emit, PatchApplied, ignore
from lerobot_policy_recent.ontology.diagnosis import Warning
from lerobot_policy_recent.ontology.skill_code import (
    assigned_names,
    called_names,
    definition_indices,
    dependency_indices,
    loads,
    parse_statements,
    plain_assignments,
    recomputed_indices,
    stores,
)
from lerobot_policy_recent.ontology.specs import ApiSpec
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.executor import RepairBudget, Segment, SkillExecutor, SkillFailure
from lerobot_policy_recent.recent_plugin.failures import FailureCategory
from lerobot_policy_recent.recent_plugin.grounding.attempts import (
    AdaptationEvent,
    LMCall,
    call_events,
    infill_until_valid,
    source_diff,
)
from lerobot_policy_recent.recent_plugin.grounding.gate import Verdict, validate_program
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill, changed_argument
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.insitu.checks import (
    CHECKS,
    CheckInput,
    Derivation,
    SceneFacts,
    Violation,
    moved_reads,
    off_table,
    placement_reached,
    state_reached,
)
from lerobot_policy_recent.recent_plugin.refactoring.units import (
    Hints,
    RefactoringUnit,
    apply_unit,
    at_indent,
    cut_unit,
)
from lerobot_policy_recent.recent_plugin.sandbox import UNKNOWN, evaluate_now
from lerobot_policy_recent.robosuite_envs.primitives.frames import SKILL_HELPERS
from lerobot_policy_recent.skills.repository import Placement, StateEffect

log = logging.getLogger(__name__)


@dataclass
class InSituAdapter:
    target: Target
    apis: dict[str, ApiSpec]  # every robot's: a call of another robot's primitive is named as such
    infiller: Infiller
    scene: SceneFacts
    insitu: bool = True  # False: the paper's "w/o in-situ adaptation" (reactive repair only)
    max_retries: int = 2
    max_repairs: int = 2  # per skill
    calls: list[LMCall] = field(default_factory=list)
    events: list[AdaptationEvent] = field(default_factory=list)
    emit: Emit = ignore  # the loggers' view: check verdicts, infiller calls, patches
    # per skill (its metadata): what it leaves in the perceived state of the objects it acts on, and
    # where it leaves the objects it moves
    state_effects: dict[str, tuple[StateEffect, ...]] = field(default_factory=dict)
    placements: dict[str, tuple[Placement, ...]] = field(default_factory=dict)
    _budget: RepairBudget = field(init=False)
    _reruns: Counter = field(default_factory=Counter)  # effects done again, per skill
    _bodies: dict[str, tuple[Segment, ...]] = field(default_factory=dict)  # each skill's statements as grounded

    def __post_init__(self) -> None:
        self._budget = RepairBudget(self.max_repairs)

    # ------------------------------------------------------------------ guards
    def guard(self, grounded: GroundedSkill, segments: list[Segment]) -> None:
        """Attach each checkable warning to the top-level statement that contains it (before or after it runs)."""
        if not self.insitu:
            return
        warnings = [w for w in grounded.warnings() if w.check in CHECKS]
        for segment in segments:
            inside = [w for w in warnings if _guards(w, segment.node)]
            segment.guards = tuple(w for w in inside if w.phase == "before")
            if isinstance(segment.node, ast.Expr):  # a bare call: doing it again repeats exactly that call
                segment.effects = tuple(w for w in inside if w.phase == "after")
        self._bodies[grounded.skill] = tuple(replace(s) for s in segments)

    def after_skill(self, executor: SkillExecutor) -> str | None:
        """Once the skill's last statement has run: is every object's state, and every object it
        moved, where the skill leaves it?

        What the skill did not bring about (a drawer still shut, a button unlit, a cube short of the
        zone) is answered by running the skill's statements again from the current scene, as
        grounded, with their checks, up to ``max_repairs`` times; after that what is unmet is
        returned, to fail the skill by name.
        """
        skill = executor.grounded.skill
        if not self.insitu:
            return None
        verdicts = self._effect_verdicts(executor, len(executor.segments) - 1)
        unmet = [(check, observation) for check, met, observation in verdicts if not met]
        if not unmet:
            return None
        observation = f"after {skill}: " + "; ".join(text for _, text in unmet)
        if self._reruns[skill] >= self.max_repairs:
            return observation
        self._reruns[skill] += 1
        body = self._bodies[skill]
        at = len(executor.segments)
        self._insert_copy(
            executor,
            executor.segments[-1],
            at,
            [s.source for s in body],
            tuple(dict.fromkeys(check for check, _ in unmet)),
            observation,
            shown=[s.source for s in body],
        )
        for copy, original in zip(executor.segments[at:], body, strict=False):  # one statement each
            copy.guards, copy.effects, copy.checked = original.guards, original.effects, False
        return None

    def achieved(self, executor: SkillExecutor, failure: SkillFailure) -> bool:
        """A step failed, yet what the skill is for already holds as perceived: every object state
        and placement it declares (it declares at least one), with nothing left in the hand. The
        skill ends there, recorded, instead of repairing a step whose purpose is met: a block pushed
        off the closed lid fell into the box it was to be carried to, and three grasps of it,
        wedged against the wall, failed the task."""
        if not self.insitu or executor.session.obs.held() is not None:
            return False
        verdicts = self._effect_verdicts(executor, failure.segment)
        if not verdicts or not all(met for _, met, _ in verdicts):
            return False
        observation = f"{failure.message}; what {executor.grounded.skill} is for holds: " + "; ".join(
            text for _, _, text in verdicts
        )
        checks = tuple(dict.fromkeys(check for check, _, _ in verdicts))
        segment = executor.segments[failure.segment]
        self.events.append(
            AdaptationEvent(
                "achieved", executor.grounded.skill, failure.segment, checks, observation, segment.source, None, 0
            )
        )
        return True

    def _effect_verdicts(self, executor: SkillExecutor, index: int) -> list[tuple[str, bool, str]]:
        """The skill's declared effects as perception reads them now (each emitted as a verdict at segment ``index``)."""
        skill, names, obs = executor.grounded.skill, executor.namespace, executor.session.obs
        verdicts = [
            ("state_reached", *state_reached(e, names.get(e.parameter), obs)) for e in self.state_effects.get(skill, ())
        ] + [
            ("placement_reached", *placement_reached(p, names.get(p.parameter), names.get(p.over), obs))
            for p in self.placements.get(skill, ())
        ]
        for check, met, observation in verdicts:
            self.emit(CheckVerdict(skill, index, check, met, observation))
        return verdicts

    def before_segment(self, executor: SkillExecutor, index: int) -> None:
        segment = executor.segments[index]
        self._answer(executor, segment, self._violations(executor, index, segment.guards), at=index)

    def after_segment(self, executor: SkillExecutor, index: int) -> None:
        """Check what the completed segment ``index`` did; a missing effect is done again right after it."""
        segment = executor.segments[index]
        self._answer(executor, segment, self._violations(executor, index, segment.effects), at=index + 1)

    def _violations(self, executor: SkillExecutor, index: int, warnings: tuple[Warning, ...]) -> list[Violation]:
        violations = []
        for warning in warnings:
            violation = self._evaluate(executor, executor.segments[index], warning)
            self.emit(
                CheckVerdict(
                    executor.grounded.skill,
                    index,
                    warning.check,
                    violation is None,
                    violation.observation if violation else "",
                )
            )
            if violation is not None:
                violations.append(violation)
        return violations

    def _answer(self, executor: SkillExecutor, segment: Segment, violations: list[Violation], *, at: int) -> None:
        """Patch in the statements the violations ask for, before segment ``at`` (nothing that ran is touched)."""
        if not violations:
            return
        observation = "; ".join(v.observation for v in violations)
        checks = tuple(v.check for v in violations)
        refused = [v for v in violations if v.refuse]
        if refused:  # infeasible as sensed: fail here, named, rather than send the arm
            executor.refuse("; ".join(v.observation for v in refused))
            return
        if any(v.rerun for v in violations):
            self._rerun(executor, segment, at, checks, observation, regrasp=any(v.regrasp for v in violations))
            return
        statements = tuple(dict.fromkeys(s for v in violations for s in v.statements))
        if not statements:  # nothing a patch can change (e.g. the object is not there): run and see
            self.events.append(
                AdaptationEvent("revise", executor.grounded.skill, at, checks, observation, segment.source, None, 0)
            )
            return
        instruction = "; and ".join(v.instruction for v in violations if v.statements)
        cue = "; ".join(v.cue or v.observation for v in violations)
        follow = tuple(dict.fromkeys(s for v in violations if v.statements for s in v.follow))
        patched = self._patch(
            executor,
            segment,
            at,
            "revise",
            "in_situ_revision",
            checks,
            instruction,
            observation,
            statements,
            cue=cue,
            follow=follow,
        )
        undo = tuple(dict.fromkeys(s for v in violations for s in v.after))
        if patched and undo and _inserted(executor, segment, statements):
            self._insert_copy(executor, segment, segment.index + 1, undo, checks, observation, shown=undo)

    def _evaluate(self, executor: SkillExecutor, segment: Segment, warning: Warning) -> Violation | None:
        call = next(
            (
                n
                for n in ast.walk(segment.node)
                if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == warning.primitive
            ),
            None,
        )
        spec = self.target.api.get(warning.primitive)
        if call is None or spec is None:
            return None
        arguments = {k.arg: _value(k.value, executor) for k in call.keywords if k.arg}
        chain = dependencies(executor.segments[: segment.index], call, set(executor.primitives))
        stale = _position_reads(executor, loads(call).union(*(loads(s.node) for s in chain)))
        named = frozenset(v for v in executor.namespace.values() if isinstance(v, str) and v in self.scene.sizes)
        inp = CheckInput(
            obs=executor.session.obs,
            arguments={k: v for k, v in arguments.items() if v is not None},
            params=tuple(replace(p, role=dict(warning.roles).get(p.name, p.role)) for p in spec.parameters),
            named=named,
            stale_reads=stale,
            derived=tuple(
                Derivation(s.source, frozenset(loads(s.node)), frozenset(stores(s.node)))
                for s in latest_definitions(executor.segments[: segment.index], set(executor.primitives))
            ),
            scene=self.scene,
            api=self.target.api,
            frames=executor.session.frames,
            before=executor.segment_obs if warning.phase == "after" else None,
        )
        return CHECKS[warning.check](inp)

    def _rerun(
        self, executor: SkillExecutor, segment: Segment, at: int, checks, observation: str, *, regrasp: bool = False
    ) -> None:
        """An effect that did not happen: run the statement again, after what it uses is recomputed.

        ``regrasp``: the object left the hand (a place that did not hold), so the skill's latest grasp
        before the statement is done again first, from a fresh read. The patch is code the skill
        already holds — copied, not generated — so no LM is asked. The copied grasp and statement keep
        their guards (a copied place is held to the same reach and clearance as the original); the copy
        is checked again once it completes, up to ``max_repairs`` times per skill.
        """
        primitives, kept = set(executor.primitives), held_reads(executor)
        earlier = executor.segments[: segment.index]
        grasp = self._latest_grasp(earlier) if regrasp else None
        redo: tuple[str, ...] = ()
        copied: list[tuple[int, Segment]] = []  # (offset in redo, the statement it copies)
        if grasp is not None:
            redo = (*recomputation(earlier[: grasp.index], grasp.node, primitives, kept), grasp.source)
            copied.append((len(redo) - 1, grasp))
        traced = self._traced_span(executor.grounded.skill, segment)
        reads = (s for t in traced for s in recomputation(earlier, t.node, primitives, kept))
        redo += (*dict.fromkeys(reads), *(t.source for t in traced[:-1]))
        copied += [(len(redo) - len(traced) + 1 + i, t) for i, t in enumerate(traced[:-1])]
        redo += (*recomputation(earlier, segment.node, primitives, kept), segment.source)
        copied.append((len(redo) - 1, segment))
        self._insert_copy(executor, segment, at, redo, checks, observation, shown=(segment.source, *redo))
        for offset, original in copied:
            copy = executor.segments[at + offset]
            copy.guards, copy.checked = original.guards, False
        self._reruns[executor.grounded.skill] += 1
        if self._reruns[executor.grounded.skill] <= self.max_repairs:
            executor.segments[at + len(redo) - 1].effects = segment.effects

    def _traced_span(self, skill: str, segment: Segment) -> tuple[Segment, ...]:
        """Where ``segment`` ends a traced call whose effect it checks (a traced pick's lift), the span's
        statements as grounded, the segment's own last: the grasp is done again from its first move.
        Empty for a statement that is a call of its own."""
        spans = [(w.span.line, w.span.line + w.through) for w in segment.effects if w.through is not None]
        if not spans:
            return ()
        (first, last), by_line = spans[0], {}
        for grounded in self._bodies.get(skill, ()):  # a loop's body repeats: each line's text is the same
            by_line.setdefault(grounded.node.lineno, grounded)
        return tuple(by_line[line] for line in range(first, last + 1) if line in by_line)

    def _latest_grasp(self, earlier: list[Segment]) -> Segment | None:
        """The last of ``earlier`` that calls a primitive of this robot that grasps an object."""
        grasps = {p.name for p in self.target.api.primitives if "grasp_object" in p.capabilities}
        return next((s for s in reversed(earlier) if _calls(s.node) & grasps), None)

    def _insert_copy(self, executor, segment, at, statements, checks, observation, *, shown) -> None:
        """Put statements the skill already holds before segment ``at``, and record it (no LM call)."""
        before = executor.source()
        executor.insert_segments(at, ("\n" + executor.indent).join(statements))
        after = "\n".join(_bare(s, executor) for s in shown)
        skill = executor.grounded.skill
        self.events.append(AdaptationEvent("revise", skill, at, checks, observation, segment.source, after, 0))
        self.emit(PatchApplied(skill, "revise", source_diff(before, executor.source()), executor.source()))

    # ------------------------------------------------------------------ repair
    def repair(self, executor: SkillExecutor, failure: SkillFailure) -> bool:
        """Replace the failed segment with a repaired one; it then runs again from the current state."""
        segment = executor.segments[failure.segment]
        if self.insitu and self._refused_on_retry(executor, segment):
            return True
        if not self._budget.take(executor, failure):
            return False
        if self.insitu and self._rerun_if_stale(executor, segment, failure):
            return True
        # The usual cause is a world that moved on: recompute what the statement uses, then retry it.
        # Worded as an object_unmoved check's patch is ("read obj_pos again"): a small model writes
        # the recomputation from this wording more reliably than from "recompute ... before retrying",
        # or from one that also shows the unrolled loop's constants (docs/history.md, "Run-time patches").
        statements = recomputation(
            executor.segments[: failure.segment], segment.node, set(executor.primitives), held_reads(executor)
        )
        return self._patch(
            executor,
            segment,
            failure.segment,
            "repair",
            "reactive_repair",
            (str(failure.category),),
            f"read {', '.join(assigned_names(at_indent('\n'.join(statements), executor.indent)))} again before retrying",
            f"{_bare(segment.source, executor).split('(')[0]} failed ({failure.message})",
            statements,
        )

    def _refused_on_retry(self, executor: SkillExecutor, segment: Segment) -> bool:
        """A retry runs in the scene as it is now. Where a guard of the failed statement finds it
        infeasible there (the ball it grasps rolled off the table), the skill is refused by name
        instead of retried. Only refusals count: the guards' patches ran before the first try."""
        refused = [v for w in segment.guards if (v := self._evaluate(executor, segment, w)) is not None and v.refuse]
        for violation in refused:
            self.emit(
                CheckVerdict(executor.grounded.skill, segment.index, violation.check, False, violation.observation)
            )
        self._answer(executor, segment, refused, at=segment.index)  # refusals only: the skill ends, named
        return bool(refused)

    def _rerun_if_stale(self, executor: SkillExecutor, segment: Segment, failure: SkillFailure) -> bool:
        """A failed statement whose positions were read before the object moved: the observation
        explains the failure, and the fix is determined — read again, recompute, retry — so the
        recomputation is copied in (no LM call), as a violated effect's rerun is."""
        chain = dependencies(executor.segments[: segment.index], segment.node, set(executor.primitives))
        stale = _position_reads(executor, loads(segment.node).union(*(loads(s.node) for s in chain)))
        reads = moved_reads(stale, executor.session.obs)
        gone = [g for _, name, _, now in reads if (g := off_table(executor.session.obs, self.scene, name, now))]
        if gone:  # it left the table: no retry brings it back, so the skill is refused here, by name
            self.emit(CheckVerdict(executor.grounded.skill, segment.index, "object_unmoved", False, "; ".join(gone)))
            executor.refuse("; ".join(gone))
            return True
        moved = [f"{name} moved since {var} was read" for var, name, _, _ in reads]
        # what may compute another value, as a repair recomputes: not an unrolled loop's constants, nor a
        # `lift += 0.01` that would add its offset twice
        redo = recomputation(
            executor.segments[: segment.index], segment.node, set(executor.primitives), held_reads(executor)
        )
        if not moved or not redo:
            return False
        observation = f"{_bare(segment.source, executor).split('(')[0]} failed ({failure.message}); {'; '.join(moved)}"
        self.emit(CheckVerdict(executor.grounded.skill, segment.index, "object_unmoved", False, observation))
        self._insert_copy(
            executor, segment, segment.index, redo, ("object_unmoved",), observation, shown=(*redo, segment.source)
        )
        return True

    # ------------------------------------------------------------------ patching
    def _patch(
        self,
        executor: SkillExecutor,
        segment: Segment,
        at: int,
        kind: str,
        span_type: str,
        checks: tuple[str, ...],
        reason: str,
        observation: str,
        statements: tuple[str, ...],
        *,
        cue: str | None = None,
        follow: tuple[str, ...] = (),
    ) -> bool:
        """Insert statements before segment ``at`` (an empty FIM span: what follows stays the suffix).

        ``segment`` is the statement the check or failure is about: ``at`` is its own index (a
        precondition, a repair) or the next one (an effect). Without statements a repair simply
        runs the segment again, with no infiller call. ``cue``: the observation as the LM's hint
        shows it (default: as the log records it). ``follow``: statements the skill already holds,
        copied in after an accepted patch (what derives from a value the patch reads again).
        """
        accepted, attempts = (None, 0) if statements else ("", 0)
        if statements:
            accepted, attempts = self._infill_insertion(
                executor, segment, at, kind, span_type, reason, cue or observation, statements
            )
        if accepted and follow:
            accepted = "\n".join([accepted, *(_bare(s, executor) for s in follow)])
        bare = _bare(segment.source, executor)
        order = [accepted, bare] if at == segment.index else [bare, accepted]
        after = None if accepted is None else "\n".join(filter(None, order))
        self.events.append(
            AdaptationEvent(kind, executor.grounded.skill, at, checks, observation, segment.source, after, attempts)
        )
        if accepted is None:
            log.warning(
                "%s: no valid %s patch for segment %d of %s", self.target.name, kind, at, executor.grounded.skill
            )
            return False
        if accepted:
            before = executor.source()
            executor.insert_segments(at, accepted.replace("\n", "\n" + executor.indent))
            self.emit(
                PatchApplied(executor.grounded.skill, kind, source_diff(before, executor.source()), executor.source())
            )
        return True

    def _infill_insertion(
        self, executor, segment, at, kind, span_type, reason, observation, statements
    ) -> tuple[str | None, int]:
        code, start = executor.source(), executor.segment_offsets(at)[0]
        suggestion = "\n".join(statements)  # nested lines at the body's indentation, as segments keep them
        wanted = called_names(at_indent(suggestion, executor.indent))
        suggested = parse_statements(at_indent(suggestion, executor.indent))  # the skill's or a check's code

        def make_unit(feedback: str | None, attempt: int) -> RefactoringUnit:
            hints = Hints(
                target=self.target,
                original_call=segment.source,
                substitute_call=suggestion,
                reason=reason,
                feedback=feedback,
                attempt=attempt,
                observation=observation,
            )
            return cut_unit(code, start, start, span_type, hints)

        def judge(unit: RefactoringUnit, text: str) -> tuple[Verdict, str]:
            candidate = apply_unit(code, unit, text + "\n" + unit.indent if text else "")
            if not text:
                return Verdict.reject(FailureCategory.EMPTY_CONTINUATION, "the patch is empty"), candidate
            body = at_indent(text, unit.indent)
            called = called_names(body)
            if called != wanted:
                message = f"the patch must call {sorted(wanted)}, it calls {sorted(called)}"
                return Verdict.reject(FailureCategory.HALLUCINATED_API, message), candidate
            verdict = validate_program(candidate, self.target.api, executor.grounded.entry, self.apis)
            if not verdict.ok:
                return verdict, candidate
            written = parse_statements(body)  # validated: it parses
            kept = changed_argument(written, suggestion, "the check wrote") or changed_assignment(
                written, suggested, executor.namespace
            )
            return kept or verdict, candidate

        before = len(self.calls)
        accepted = infill_until_valid(
            self.infiller, make_unit, judge, kind=kind, max_retries=self.max_retries, calls=self.calls
        )
        attempts = len(self.calls) - before
        for call in self.calls[before:]:
            for event in call_events(executor.grounded.skill, call):
                self.emit(event)
        if accepted is None:
            return None, attempts
        return textwrap.dedent(accepted.unit.indent + accepted.text), attempts


def changed_assignment(written: list[ast.stmt], suggested: list[ast.stmt], namespace: dict) -> Verdict | None:
    """A patch assigns every name the suggested statements assign, each to the same value.

    The statements are the check's or the skill's own (a repair recomputes what the failed statement
    uses), so what they assign is decided; a value may be written differently (``obj`` for the
    ``'cube'`` it holds). Unchecked, an unrolled loop's next item (``name = second`` for ``first``)
    would pass validation and move the wrong object.
    """
    wanted, got = plain_assignments(suggested), plain_assignments(written)
    missing = [targets for targets in wanted if targets not in got]
    if missing:
        return Verdict.reject(FailureCategory.HALLUCINATED_KWARG, f"the patch must assign {', '.join(missing)} as well")
    for targets, value in wanted.items():
        if not _same_value(got[targets], value, namespace):
            return Verdict.reject(
                FailureCategory.HALLUCINATED_KWARG,
                f"{targets} = {ast.unparse(got[targets])} changes the value it must hold: "
                f"{targets} = {ast.unparse(value)}",
            )
    return None


def _same_value(node: ast.expr, wanted: ast.expr, namespace: dict) -> bool:
    """Whether two expressions compute the same value: the same code, or, part by part, calls of the
    same function on the same values and names or literals that hold the same value now."""
    if ast.dump(node) == ast.dump(wanted):
        return True
    if isinstance(node, ast.Call) and isinstance(wanted, ast.Call):
        given, asked = {k.arg: k.value for k in node.keywords}, {k.arg: k.value for k in wanted.keywords}
        return (
            ast.dump(node.func) == ast.dump(wanted.func)
            and len(node.args) == len(wanted.args)
            and all(_same_value(a, b, namespace) for a, b in zip(node.args, wanted.args, strict=True))
            and given.keys() == asked.keys()
            and all(_same_value(value, asked[name], namespace) for name, value in given.items())
        )
    if isinstance(node, ast.List | ast.Tuple) and isinstance(wanted, ast.List | ast.Tuple):
        return len(node.elts) == len(wanted.elts) and all(
            _same_value(a, b, namespace) for a, b in zip(node.elts, wanted.elts, strict=True)
        )
    if any(isinstance(n, ast.Call) for n in (*ast.walk(node), *ast.walk(wanted))):
        return False
    mine, theirs = evaluate_now(node, namespace), evaluate_now(wanted, namespace)
    if mine is UNKNOWN or theirs is UNKNOWN:
        return False
    try:
        return bool(np.array_equal(mine, theirs))  # positions may be arrays on one side, lists on the other
    except (TypeError, ValueError):  # ragged or incomparable values: not shown to be the same
        return False


def _guards(warning: Warning, node: ast.stmt) -> bool:
    """The warning's check belongs to this statement: it contains the warned call, or (a span
    rendered one statement per line) it is one of the lines the warning guards."""
    first, last = node.lineno, node.end_lineno or node.lineno
    if warning.through is None:
        return first <= warning.span.line <= last
    if warning.phase == "after":  # what the span's lines did together: read once its last has run
        return first == warning.span.line + warning.through
    return warning.span.line <= first <= warning.span.line + warning.through


def _inserted(executor: SkillExecutor, segment: Segment, statements: tuple[str, ...]) -> bool:
    """The statements right before ``segment`` are ``statements``: the patch is the one suggested (an
    LM that wrote its own is not undone by what undoes the suggestion)."""
    start = segment.index - len(statements)
    wanted = [ast.dump(node) for s in statements for node in parse_statements(s)]
    return start >= 0 and [ast.dump(s.node) for s in executor.segments[start : segment.index]] == wanted


def _calls(node: ast.AST) -> set[str]:
    """The functions a statement calls by name."""
    return {n.func.id for n in ast.walk(node) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}


def _bare(source: str, executor: SkillExecutor) -> str:
    """A segment's source without the body indentation of its later lines."""
    return source.replace("\n" + executor.indent, "\n")


def _value(node: ast.expr, executor: SkillExecutor) -> object | None:
    """Evaluate an argument expression now (validated code). A call by bare name may be a primitive,
    which must not run twice, and is skipped; the ontology's pure conversion helpers are not, so a
    pose the ontology rendered (``to_frame(p) + quat_to_rotvec(...)``) is read as any position is."""
    if any(
        isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id not in SKILL_HELPERS
        for n in ast.walk(node)
    ):
        return None
    value = evaluate_now(node, executor.namespace)
    return None if value is UNKNOWN else value


def recomputation(
    earlier: list[Segment], node: ast.AST, primitives: set[str], kept: frozenset[str] = frozenset()
) -> tuple[str, ...]:
    """What to run again before the statement, in order: of its :func:`dependencies`, those whose value
    may have changed (``skill_code.recomputed_indices``), the ``kept`` names' reads left as they are."""
    return tuple(earlier[i].source for i in recomputed_indices([s.node for s in earlier], node, primitives, kept))


def held_reads(executor: SkillExecutor) -> frozenset[str]:
    """The variables that hold a position read of the object the hand holds now. Read again, it is
    where the hand carries it: a rake's home, re-read in a drag's repair, became the spot beside the
    zone, and the rake was put back over the cube the next skill was to pick up."""
    held = executor.session.obs.held()
    if held is None:
        return frozenset()
    return frozenset(
        var for var, (name, _) in _position_reads(executor, set(executor.namespace)).items() if name == held
    )


def dependencies(earlier: list[Segment], node: ast.AST, primitives: set[str]) -> list[Segment]:
    """Earlier segments (assignments and branches of them, no primitive calls) the statement depends on, in order.

    Only the latest definition of a value is taken (a second repair copies the first one's
    recomputation, not the original's as well).
    """
    return [earlier[i] for i in dependency_indices([s.node for s in earlier], node, primitives)]


def latest_definitions(earlier: list[Segment], primitives: set[str]) -> list[Segment]:
    """The earlier segments that still define a value, in order.

    What a re-read must recompute comes from these: everything still derived from the old value,
    whether or not the next call uses it (``goal`` as well as ``start``).
    """
    return [earlier[i] for i in definition_indices([s.node for s in earlier], primitives)]


def _position_reads(executor: SkillExecutor, names: set[str]) -> dict[str, tuple[str, list[float]]]:
    """Of ``names``, the variables that still hold an object position as the task returned it: name -> (object, value)."""
    reads = executor.namespace["task"].position_reads
    return {
        var: (name, list(value))
        for var, value in executor.namespace.items()
        if var in names
        for name, read in reads
        if value is read
    }
