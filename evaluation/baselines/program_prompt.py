"""The baselines' refactoring units: a program header before the skill's signature, then the span.

Every baseline asks the same FIM infiller as RECENT. What differs is the prompt: a header of
comments with the target robot's primitives and the Panda reference skill as the in-context
example (``cap``, ``repair``), plus primitive descriptions, the scene's objects and the workspace
bounds (``agentless``); or ProgPrompt's Pythonic header, which imports the target's actions, lists
the scene's objects as a Python list and asks to translate the reference (``progprompt``). The
span is the whole body (program synthesis) or one failing statement (localized repair); either
way generation stays proportional to what it replaces.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

from lerobot_policy_recent.ontology.conversions import api_notes
from lerobot_policy_recent.ontology.skill_code import body_span
from lerobot_policy_recent.ontology.specs import ApiSpec
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.failures import FailureCategory
from lerobot_policy_recent.recent_plugin.grounding.gate import Verdict, security_gate
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import CODE_LINES, one_line
from lerobot_policy_recent.recent_plugin.refactoring.units import Hints, RefactoringUnit, SpanStyle, cut_unit
from lerobot_policy_recent.robosuite_envs.observation import Observation
from lerobot_policy_recent.robosuite_envs.primitives.session import TaskContext
from lerobot_policy_recent.robosuite_envs.table import TABLE_SIZE, TABLE_Z
from lerobot_policy_recent.skills.repository import Skill

EMPTY = Verdict.reject(FailureCategory.EMPTY_CONTINUATION, "the completion is empty")
PROGRAM = "program_synthesis"  # the whole body, written from the prompt
STATEMENT = "localized_repair"  # one failing statement, rewritten in place
PLAN = "structured_plan"  # SCoT's plan: comment lines before the code


def _failed(hints: Hints) -> list[str]:
    return [f"Failed before: {hints.feedback}"] if hints.feedback else []


def _statement_comments(hints: Hints) -> list[str]:
    observed = [f"Observed: {hints.observation}"] if hints.observation else []
    return [f"Was: {one_line(hints.original_call)}", *_failed(hints), *observed, f"Rewrite it for {hints.robot}:"]


# The prompt header holds the API; a span's comments carry only the error. A program ends where the
# model ends the middle or at the next definition; SCoT's plan continues the header's own comment lines.
PROGRAM_STYLE = SpanStyle(
    lambda hints: [*_failed(hints), f"Program for {hints.robot}:"], stop=("\ndef ", "\nclass "), whole_body=True
)
# The rewrite's prompt ends in comment lines; held to code lines, the model cannot go on commenting.
STATEMENT_STYLE = SpanStyle(_statement_comments, grammar=CODE_LINES)
PLAN_STYLE = SpanStyle(lambda hints: [], stop=("\n\n", "\ndef "))


@dataclass(frozen=True)
class BaselineStyle:
    """A baseline's strategy: what its prompt shows, what a program must pass, and how a failure is
    answered. This class is the shared default (CaP's); a baseline overrides the hooks it changes,
    in its own module (``evaluation/baselines/<name>.py``)."""

    name: str
    # Failures of a skill answered by rewriting the failing statement before the whole program is
    # regenerated: 0 regenerates at once (cap), None never does (repair).
    statement_repairs: int | None = 0

    def header(self, prompt: ProgramPrompt) -> str:
        """The lines before the skill's signature in every prompt."""
        return prompt.api_header(described=False)

    def before_program(
        self, prompt: ProgramPrompt, infiller: Infiller, result: GroundedSkill, max_retries: int
    ) -> ProgramContext:
        """The context the program is written under (a stage before it may add to it, as SCoT's plan)."""
        return prompt.context

    def repair_context(self, context: ProgramContext, grounded: GroundedSkill) -> ProgramContext:
        """The context a repair prompt shows, given the grounding the failing program came from."""
        return context

    def judge(self, candidate: str, entry: str, api: ApiSpec) -> Verdict:
        """What a program must pass before it runs: the security gate."""
        return security_gate(candidate, entry, api.names())

    def error_feedback(self, category: str, error: str) -> str:
        """How a run-time failure is told to the LM."""
        return error

    def history(self, failed: list[str]) -> str:
        """What a repair prompt recalls of the skill's earlier attempts that failed (``failed``: one
        line each, oldest first): nothing by default, as CaP and Agentless see only the last error."""
        return ""

    def scene(self, obs: Observation) -> str:
        """The observed scene, as a repair prompt shows it."""
        return describe_scene(obs)

    def rewrites_whole(self, failures: int) -> bool:
        """Whether the ``failures``-th failure of a skill (1 for the first) regenerates the whole program."""
        return self.statement_repairs is not None and failures > self.statement_repairs


@dataclass(frozen=True)
class ProgramContext:
    """What a baseline's prompt shows besides the skill: the task instruction and the scene."""

    instruction: str
    objects: tuple[str, ...] = ()  # "name (kind)"
    plan: str = ""  # SCoT: the structured plan written before the code, one line per substitution
    # (skill, its program on the target robot): the in-context example in place of the source skill
    # (the cap-target-example sanity row); a skill without one shows its source program
    target_examples: tuple[tuple[str, str], ...] = ()
    # (skill, its program on the target robot) for *other* skills: examples of the target's own API,
    # shown before the reference skill, as the original CaP prompts show theirs (``cap``)
    api_examples: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class ProgramPrompt:
    """What one baseline shows the LM for one skill on one robot; it cuts that skill's units."""

    skill: Skill
    target: Target
    style: BaselineStyle
    context: ProgramContext

    def header(self) -> str:
        """What precedes the skill's signature in every prompt: the baseline's own header."""
        return self.style.header(self)

    def api_header(self, *, described: bool) -> str:
        """Comment lines with the target's primitives and the example program (``described``: each
        primitive's description, the scene's objects and the workspace bounds)."""
        lines = self.api_example_lines()
        lines += [f"# Example: this skill written for the {self.example_robot()} robot", self.example(), ""]
        lines.append(
            f"# The {self.target.name} robot has other primitives (env and task are always the first two arguments):"
        )
        for primitive in self.target.api.primitives:
            about = f"  -- {primitive.description}" if described and primitive.description else ""
            lines.append(f"#   {primitive.signature()}{about}")
        lines.append("# Scene queries: " + ", ".join(f"task.{q}(...)" for q in TaskContext.QUERIES))
        lines += [f"# {note}" for note in api_notes(self.target.api)]
        if described:
            half_x, half_y = TABLE_SIZE[0] / 2, TABLE_SIZE[1] / 2
            lines.append("# Scene objects: " + ", ".join(self.context.objects))
            lines.append(
                f"# Workspace: x in [{-half_x:.2f}, {half_x:.2f}] m, y in [{-half_y:.2f}, {half_y:.2f}] m, "
                f"table top at z = {TABLE_Z:.2f} m; every target must lie inside it"
            )
        lines.append(f"# Task: {self.context.instruction}")
        if self.context.plan:
            lines.append("# Structured plan:")
            lines += [f"# - {line}" for line in self.context.plan.splitlines()]
        lines.append(
            f"# This step: {self.skill.intent} Write it for {self.target.name}, calling only the {self.target.name} primitives."
        )
        return "\n".join(lines) + "\n"

    def plan_unit(self, *, feedback: str | None = None, attempt: int = 0) -> RefactoringUnit:
        """SCoT's first stage: after the header, comment lines naming, for each call of the example, the
        target primitive that replaces it and how its arguments map; the signature follows."""
        code = self.skill.code
        start, end = body_span(code, self.skill.entry)
        ask = (
            f"# Before any code, a structured plan: for each call in the example, the {self.target.name} "
            "primitive that replaces it and how its arguments map, one line each.\n# - "
        )
        hints = Hints(target=self.target, original_call=code[start:end], feedback=feedback, attempt=attempt)
        return RefactoringUnit(0, 0, "", self.header() + ask, "\n" + code[:start], "", PLAN, hints, style=PLAN_STYLE)

    def example(self) -> str:
        """The reference skill, renamed for its robot (``put_in_bin_panda``), as the in-context example."""
        code = dict(self.context.target_examples).get(self.skill.name, self.skill.code)
        return renamed_for(code, self.skill.entry, self.example_robot())

    def api_example_lines(self) -> list[str]:
        """Other skills' programs for the target robot, each renamed for it: how its API is used."""
        if not self.context.api_examples:
            return []
        lines = [f"# Examples of other skills written for the {self.target.name} robot, using its primitives:"]
        for _, code in self.context.api_examples:
            lines += [renamed_for(code, None, self.target.name), ""]
        return lines

    def example_robot(self) -> str:
        """The robot the in-context example is written for: the target where the context has its program."""
        return (
            self.target.name if self.skill.name in dict(self.context.target_examples) else self.skill.source_embodiment
        )

    def program_unit(self, *, feedback: str | None = None, attempt: int = 0) -> RefactoringUnit:
        """The whole entry body of the skill as one span, the header and signature before it."""
        code = self.skill.code
        start, end = body_span(code, self.skill.entry)
        hints = Hints(target=self.target, original_call=code[start:end], feedback=feedback, attempt=attempt)
        return self._headed(cut_unit(code, start, end, PROGRAM, hints, style=PROGRAM_STYLE))

    def statement_unit(
        self,
        code: str,
        span: tuple[int, int],
        *,
        feedback: str | None = None,
        observation: str | None = None,
        attempt: int = 0,
    ) -> RefactoringUnit:
        """One statement of ``code`` (its character range ``span``) as the span, the header before the function."""
        start, end = span
        hints = Hints(
            target=self.target,
            original_call=code[start:end],
            feedback=feedback,
            attempt=attempt,
            observation=observation,
        )
        return self._headed(cut_unit(code, start, end, STATEMENT, hints, style=STATEMENT_STYLE))

    def _headed(self, unit: RefactoringUnit) -> RefactoringUnit:
        return replace(unit, prefix=self.header() + unit.prefix)


def renamed_for(code: str, entry: str | None, robot: str) -> str:
    """``code`` with its function ``entry`` (every top-level function where None) renamed for
    ``robot`` (``put_in_bin`` becomes ``put_in_bin_ur5e``), so that no example defines the entry."""
    name = re.escape(entry) if entry else r"\w+"
    return re.sub(rf"^def ({name})\(", lambda m: f"def {m.group(1)}_{robot.lower()}(", code, flags=re.M).rstrip("\n")


def describe_scene(obs: Observation, *, raw: bool = False) -> str:
    """The observed scene in one line, as a baseline's repair prompt shows it (``raw``: with each
    object's orientation quaternion, and the end effector's pose)."""

    def numbers(values) -> str:
        return ", ".join(f"{v:.3f}" for v in values)

    parts = [
        f"{name} at [{numbers(state.pos)}]" + (f" quat [{numbers(state.quat)}]" if raw else "")
        for name, state in obs.objects.items()
    ]
    if raw:
        parts.append(f"end effector at [{numbers(obs.eef_pos)}] quat [{numbers(obs.eef_quat)}]")
    held = obs.held()
    return "; ".join(parts) + (f"; holding {held}" if held else "")
