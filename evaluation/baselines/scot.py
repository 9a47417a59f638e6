"""Structured Chain-of-Thought (``scot``): a structured plan first, then the program under it."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

from lerobot_policy_recent.evaluation.baselines.base import Baseline
from lerobot_policy_recent.evaluation.baselines.program_prompt import (
    EMPTY,
    PLAN,
    BaselineStyle,
    ProgramContext,
    ProgramPrompt,
)
from lerobot_policy_recent.recent_plugin.grounding.attempts import infill_until_valid
from lerobot_policy_recent.recent_plugin.grounding.gate import Verdict
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.methods.base import Method
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit


@dataclass(frozen=True)
class PlanStyle(BaselineStyle):
    """SCoT: before the program, a plan of substitutions and parameter mappings, shown in every later prompt."""

    def before_program(
        self, prompt: ProgramPrompt, infiller: Infiller, result: GroundedSkill, max_retries: int
    ) -> ProgramContext:
        return replace(prompt.context, plan=write_plan(prompt, infiller, result, max_retries))

    def repair_context(self, context: ProgramContext, grounded: GroundedSkill) -> ProgramContext:
        return replace(context, plan=plan_of(grounded))


@Method.register_subclass("scot")
@dataclass
class StructuredChainOfThought(Baseline):
    """SCoT as the paper implements it: first a structured plan (which target primitive replaces each
    call, how its arguments map), then the program under it, run as is; regenerated on an error."""

    style: ClassVar[BaselineStyle] = PlanStyle("scot", statement_repairs=0)


def write_plan(prompt: ProgramPrompt, infiller: Infiller, result: GroundedSkill, max_retries: int) -> str:
    """SCoT's structured plan, one line per substitution (empty where none came); its calls are grounding calls."""

    def judge(unit: RefactoringUnit, text: str) -> tuple[Verdict, str]:
        return (Verdict(True) if text else EMPTY), text

    accepted = infill_until_valid(
        infiller,
        lambda feedback, attempt: prompt.plan_unit(feedback=feedback, attempt=attempt),
        judge,
        kind="ground",
        max_retries=max_retries,
        calls=result.calls,
        clean=plan_lines,
    )
    return accepted.text if accepted is not None else ""


def plan_lines(text: str, unit: RefactoringUnit) -> str:
    """A plan as the model wrote it, without its comment and list markers."""
    lines = (line.strip().lstrip("#").strip().lstrip("-*").strip() for line in text.splitlines())
    return "\n".join(line for line in lines if line)


def plan_of(grounded: GroundedSkill) -> str:
    """The structured plan a SCoT grounding wrote (empty for any other)."""
    return next((c.text for c in reversed(grounded.calls) if c.span_type == PLAN and c.accepted), "")
