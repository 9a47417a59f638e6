"""How a baseline answers a failure while it runs: regenerate, then go on from the current state.

Baselines have no run-time checks (they react to errors only), so :meth:`guard` and
:meth:`before_segment` do nothing. When a segment fails, ``cap`` regenerates the whole program
with the error appended and runs it from its first statement, in place of all the old one had
left to run; ``repair`` rewrites the failed statement with the error and the observed scene;
``agentless`` rewrites the statement first and the whole function if the skill fails again. Every
call is a ``repair`` (EI, IT). A repair is held to the security gate only, as the first program
was: it runs until it fails. The loop goes on until the task succeeds or its LM budget is spent
(every repair is an LM call), as the baselines' own loops do; ``max_repairs`` bounds it only
where no budget does.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lerobot_policy_recent.evaluation.baselines.program_prompt import (
    EMPTY,
    BaselineStyle,
    ProgramContext,
    ProgramPrompt,
)
from lerobot_policy_recent.logs.events import Emit, PatchApplied, ignore
from lerobot_policy_recent.ontology.specs import ApiSpec
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.executor import RepairBudget, Segment, SkillExecutor, SkillFailure
from lerobot_policy_recent.recent_plugin.grounding.attempts import (
    AdaptationEvent,
    LMCall,
    call_events,
    infill_until_valid,
    source_diff,
)
from lerobot_policy_recent.recent_plugin.grounding.gate import Verdict
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import one_line
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit, apply_unit
from lerobot_policy_recent.skills.repository import Skill


@dataclass
class BaselineAdapter:
    style: BaselineStyle
    target: Target
    apis: dict[str, ApiSpec]  # every robot's: a call of another robot's primitive is named as such
    infiller: Infiller
    context: ProgramContext
    skills: dict[str, Skill]  # the plan's skills by name (their prompts' examples)
    max_retries: int = 2
    # per skill; None: until the task's LM budget is spent (each repair is at least one LM call)
    max_repairs: int | None = 2
    calls: list[LMCall] = field(default_factory=list)
    events: list[AdaptationEvent] = field(default_factory=list)
    emit: Emit = ignore
    _budget: RepairBudget = field(init=False)
    # per skill, each failed statement and its error, oldest first (what a style may recall)
    _failed: dict[str, list[str]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._budget = RepairBudget(self.max_repairs)

    def guard(self, grounded: GroundedSkill, segments: list[Segment]) -> None:
        """Baselines check nothing ahead of time."""

    def before_segment(self, executor: SkillExecutor, index: int) -> None:
        """Baselines check nothing ahead of time."""

    def after_segment(self, executor: SkillExecutor, index: int) -> None:
        """Baselines check no effects (they react to failures only)."""

    def after_skill(self, executor: SkillExecutor) -> str | None:
        """Baselines check no effects (they react to failures only)."""
        return None

    def achieved(self, executor: SkillExecutor, failure: SkillFailure) -> bool:
        """Baselines check no effects: a failed step is repaired or fails."""
        return False

    def repair(self, executor: SkillExecutor, failure: SkillFailure) -> bool:
        name = executor.grounded.skill
        if not self._budget.take(executor, failure):
            return False
        skill = self.skills[name]
        error = f"line {failure.line}: {failure.category}: {failure.message}"
        error = self.style.error_feedback(str(failure.category), error)
        failed = self._failed.setdefault(name, [])
        recalled = self.style.history(failed)
        failed.append(f"`{one_line(executor.segments[failure.segment].source)}` ({failure.message})")
        if recalled:
            error = f"{error}; {recalled}"
        observation = self.style.scene(executor.session.obs)
        whole = self.style.rewrites_whole(self._budget.used[name])
        code = executor.source()
        segment = executor.segments[failure.segment]

        prompt = ProgramPrompt(
            skill, self.target, self.style, self.style.repair_context(self.context, executor.grounded)
        )

        def feedback(rejected: str | None) -> str:
            return error if rejected is None else f"{error}; then rejected: {rejected}"

        if whole:
            base = skill.code

            def make_unit(rejected: str | None, attempt: int) -> RefactoringUnit:
                return prompt.program_unit(feedback=f"{feedback(rejected)}; observed: {observation}", attempt=attempt)
        else:
            base = code
            span = executor.segment_offsets(failure.segment)

            def make_unit(rejected: str | None, attempt: int) -> RefactoringUnit:
                return prompt.statement_unit(
                    code, span, feedback=feedback(rejected), observation=observation, attempt=attempt
                )

        def judge(unit: RefactoringUnit, text: str) -> tuple[Verdict, str]:
            candidate = apply_unit(base, unit, text)
            return (self.style.judge(candidate, executor.grounded.entry, self.target.api) if text else EMPTY), candidate

        before = len(self.calls)
        accepted = infill_until_valid(
            self.infiller, make_unit, judge, kind="repair", max_retries=self.max_retries, calls=self.calls
        )
        for call in self.calls[before:]:
            for event in call_events(name, call):
                self.emit(event)
        after = accepted.text if accepted is not None else None
        self.events.append(
            AdaptationEvent(
                "repair", name, failure.segment, (str(failure.category),), observation, segment.source, after,
                len(self.calls) - before,
            )
        )  # fmt: skip
        if accepted is None:
            return False
        if whole:  # the new program replaces the failed statement and all the old one had left to run
            executor.replace_rest(failure.segment, accepted.text)
        else:
            executor.replace_segment(failure.segment, accepted.text)
        self.emit(PatchApplied(name, "repair", source_diff(code, executor.source()), executor.source()))
        return True
