"""A baseline's program before execution: generated whole, and run as it is (the paper's protocol).

The program passes only the security gate (:func:`~..grounding.gate.security_gate`): no interface
validation, so a wrong name or keyword fails when the executor reaches it, with Python's error,
after what came before it ran. Only a program that cannot run at all (empty, a syntax error, an
unsafe construct) is regenerated before execution, the baseline's way: ``cap`` regenerates the
whole program with the error appended, ``repair`` and ``agentless`` rewrite the statement the
error points at (the whole program where it points at none). These retries are grounding calls
(GO-pre, IGT), as RECENT's rejected spans are.
"""

from __future__ import annotations

import time

from lerobot_policy_recent.evaluation.baselines.program_prompt import (
    EMPTY,
    BaselineStyle,
    ProgramContext,
    ProgramPrompt,
)
from lerobot_policy_recent.ontology.diagnosis import Diagnosis
from lerobot_policy_recent.ontology.skill_code import statement_span
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.grounding.attempts import infill_until_valid
from lerobot_policy_recent.recent_plugin.grounding.gate import Verdict
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill, unrecoverable
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit, apply_unit
from lerobot_policy_recent.skills.repository import Skill


def generate_skill(
    skill: Skill,
    target: Target,
    infiller: Infiller,
    style: BaselineStyle,
    context: ProgramContext,
    *,
    max_retries: int = 2,
) -> GroundedSkill:
    """The baseline's program for ``skill`` on ``target`` (validated, or with the reason it is not)."""
    started = time.perf_counter()
    robot = target.name
    result = GroundedSkill.start(skill, robot, Diagnosis(skill.name, robot), infiller)  # no ontology consulted
    context = style.before_program(ProgramPrompt(skill, target, style, context), infiller, result, max_retries)
    prompt = ProgramPrompt(skill, target, style, context)
    last: dict[str, object] = {"code": None, "verdict": None}  # the previous candidate and why it failed

    def make_unit(feedback: str | None, attempt: int) -> RefactoringUnit:
        verdict: Verdict | None = last["verdict"]  # type: ignore[assignment]
        if attempt and not style.rewrites_whole(1) and verdict is not None and verdict.line is not None:
            span = statement_span(last["code"], skill.entry, verdict.line)
            if span[0] < span[1]:  # the error points at a statement of the body: rewrite that one
                last["base"] = last["code"]
                return prompt.statement_unit(last["code"], span, feedback=feedback, attempt=attempt)
        last["base"] = skill.code
        return prompt.program_unit(feedback=feedback, attempt=attempt)

    def judge(unit: RefactoringUnit, text: str) -> tuple[Verdict, str]:
        candidate = apply_unit(last["base"], unit, text)  # type: ignore[arg-type]
        verdict = style.judge(candidate, skill.entry, target.api) if text else EMPTY
        last["code"], last["verdict"] = candidate, verdict
        return verdict, candidate

    accepted = infill_until_valid(
        infiller, make_unit, judge, kind="ground", max_retries=max_retries, calls=result.calls
    )
    if accepted is None:
        result.code = last["code"] or skill.code  # type: ignore[assignment]
        result.verdict = unrecoverable(
            result, f"unrecoverable: no runnable {style.name} program after {max_retries + 1} attempts"
        )
    else:
        result.code, result.verdict = accepted.candidate, accepted.verdict
    result.seconds = time.perf_counter() - started
    return result
