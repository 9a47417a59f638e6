"""The baselines RECENT is compared with, as registered methods (``evaluation/baselines/`` holds their prompts).

Each writes the whole program from a prompt that shows the task, and answers a failure its own
way (see :mod:`lerobot_policy_recent.evaluation.baselines`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace
from typing import ClassVar

from lerobot_policy_recent.evaluation.baselines.adapter import BaselineAdapter
from lerobot_policy_recent.evaluation.baselines.generate import generate_skill
from lerobot_policy_recent.evaluation.baselines.program_prompt import BaselineStyle, ProgramContext
from lerobot_policy_recent.ontology.builder import Ontology
from lerobot_policy_recent.ontology.skill_code import call_sites
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.executor import Adapter
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill, ground_skill
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.methods.base import Adaptation, Grounding, Method
from lerobot_policy_recent.recent_plugin.refactoring.substitution import has_placeholders
from lerobot_policy_recent.robosuite_envs.tasks import TaskSpec
from lerobot_policy_recent.skills.repository import Skill, SkillNotValidatedError, list_skills, serve_skill


@dataclass
class Baseline(Method):
    family: ClassVar[str] = "baseline"
    style: ClassVar[BaselineStyle]
    # Other skills, as the ontology renders them for the target, shown as examples of its API before
    # the reference skill (the original CaP prompts' in-context examples); 0 shows none.
    api_examples: int = 0

    def grounding_key(self, task: TaskSpec | None) -> str:
        shown = task.task_id if task is not None else ""  # the prompt shows the task
        return f"{shown} api_examples={self.api_examples}" if self.api_examples else shown

    def ground(self, g: Grounding) -> GroundedSkill:
        context = self.context(g.task, (g.skill,), g.target, g.ontology, g.max_retries)
        return generate_skill(g.skill, g.target, g.infiller, self.style, context, max_retries=g.max_retries)

    def adapter(self, a: Adaptation) -> Adapter:
        skills = {step.skill: a.skill(step.skill) for step in a.task.plan}
        return BaselineAdapter(
            **a.adapter_fields(),
            style=self.style,
            context=self.context(a.task, tuple(skills.values()), a.target, a.ontology, a.max_retries),
            skills=skills,
        )

    def context(
        self, task: TaskSpec | None, skills: tuple[Skill, ...], target: Target, ontology: Ontology, max_retries: int
    ) -> ProgramContext:
        """What the prompt shows besides the skill (the same for every skill of ``skills``)."""
        context = program_context(task)
        if self.api_examples:
            shown = api_examples(skills, task, target, ontology, max_retries, self.api_examples)
            context = replace(context, api_examples=shown)
        return context


@Method.register_subclass("cap")
@dataclass
class CodeAsPolicies(Baseline):
    """Code-as-Policies: the whole program; on a failure, the whole program again with the error appended."""

    style: ClassVar[BaselineStyle] = BaselineStyle("cap", constraints=False, statement_repairs=0)


@Method.register_subclass("repair")
@dataclass
class RepairAgent(Baseline):
    """RepairAgent-style: generate as ``cap``, then rewrite the failing statement with the error and the scene."""

    style: ClassVar[BaselineStyle] = BaselineStyle("repair", constraints=False, statement_repairs=None)


@Method.register_subclass("cap-target-example")
@dataclass
class CodeAsPoliciesTargetExample(CodeAsPolicies):
    """Sanity row: CaP with a perfect example, the skill's program for the *target* robot (the
    ontology's complete rendering, no LM). What CaP can do at best with this model and protocol.
    A skill the ontology cannot render completely for the target (an argument only an LM can
    decide) has no such program, and the row refuses it rather than showing a different example."""

    family: ClassVar[str] = "sanity"
    style: ClassVar[BaselineStyle] = BaselineStyle("cap-target-example", statement_repairs=0)

    def context(
        self, task: TaskSpec | None, skills: tuple[Skill, ...], target: Target, ontology: Ontology, max_retries: int
    ) -> ProgramContext:
        examples = tuple((skill.name, target_program(skill, target, ontology, max_retries)) for skill in skills)
        return replace(super().context(task, skills, target, ontology, max_retries), target_examples=examples)


@Method.register_subclass("cap-api-examples")
@dataclass
class CodeAsPoliciesApiExamples(CodeAsPolicies):
    """CaP prompted as the original CaP prompts are: in-context examples written in the *target's*
    API (other skills of the library, as the ontology renders them for the target with no LM),
    then the skill's source program and the task. Nothing of the task's own skills is shown in the
    target's API (that is cap-target-example). A target on which the ontology renders few skills
    completely (Sawyer: only the skills without pick or place) gets what it renders."""

    style: ClassVar[BaselineStyle] = BaselineStyle("cap-api-examples", statement_repairs=0)
    api_examples: int = 2


def target_program(skill: Skill, target: Target, ontology: Ontology, max_retries: int) -> str:
    """``skill`` as the ontology renders it for ``target`` with no LM; ValueError where it cannot completely."""
    from lerobot_policy_recent.recent_plugin.infillers.rule import RuleInfiller

    grounded = ground_skill(skill, target, ontology, RuleInfiller(), max_retries=max_retries)
    if not grounded.valid or has_placeholders(grounded.code):
        why = (
            grounded.verdict.message
            if grounded.verdict is not None and not grounded.verdict.ok
            else "placeholders left"
        )
        raise ValueError(
            f"cap-target-example: no reference program of {skill.name} for {target.name}: the ontology cannot "
            f"render it completely ({why}); the row needs targets whose skills it renders (UR5e, Robotiq85, …)"
        )
    return grounded.code


def api_examples(
    skills: tuple[Skill, ...], task: TaskSpec | None, target: Target, ontology: Ontology, max_retries: int, count: int
) -> tuple[tuple[str, str], ...]:
    """``count`` validated skills of the library that ``skills`` come from, neither among them nor in
    ``task``'s plan, each as the ontology renders it completely for ``target``: chosen greedily to
    show as many of the target's primitives as they can, the shorter program first on a tie."""
    if not skills:
        return ()
    library, source = skills[0].path.parent, skills[0].source_embodiment
    excluded = {s.name for s in skills} | ({step.skill for step in task.plan} if task is not None else set())
    candidates: list[tuple[str, str, frozenset[str]]] = []
    for name in list_skills(library):
        if name in excluded:
            continue
        try:
            skill = serve_skill(name, library)
            if skill.source_embodiment != source:
                continue
            code = target_program(skill, target, ontology, max_retries)
        except (SkillNotValidatedError, ValueError):
            continue  # not a program a prompt could show as the target's own
        uses = frozenset(site.name for site in call_sites(code) if site.name in target.api.names())
        candidates.append((name, code, uses))
    chosen: list[tuple[str, str]] = []
    shown: set[str] = set()
    while candidates and len(chosen) < count:
        best = min(candidates, key=lambda c: (-len(c[2] - shown), len(c[1]), c[0]))
        candidates.remove(best)
        chosen.append((best[0], best[1]))
        shown |= best[2]
    return tuple(chosen)


@Method.register_subclass("cap-distilled")
@dataclass
class CodeAsPoliciesDistilled(CodeAsPolicies):
    """The paper's CaP-CodeV-R1 row: CaP's protocol on another, smaller or distilled model (``model``).

    The paper's CodeV-R1-Distill-Qwen-7B cannot be provisioned offline here; the slot defaults to
    the other model that can, Qwen2.5-Coder-0.5B-Instruct. ``--method.model_name=PATH`` runs any GGUF.
    """

    model_name: str = "qwen2.5-coder-0.5b"  # a known model name (`recent model list`) or a .gguf path

    def model(self, lm: Infiller) -> Infiller:
        return _llamacpp(self.model_name, getattr(lm, "n_threads", None))


@Method.register_subclass("cap-llm")
@dataclass
class CodeAsPoliciesLLM(CodeAsPolicies):
    """The paper's CaP-Codex row: CaP's protocol on a large served chat model (``--method.base_url``,
    ``--method.model_name``, the key in ``$OPENAI_API_KEY``), with the richer inputs the appendix gives
    it: object positions and orientations, and the error unfiltered, in every repair prompt."""

    style: ClassVar[BaselineStyle] = BaselineStyle("cap-llm", statement_repairs=0, raw_state=True)
    base_url: str | None = None  # an OpenAI-compatible server with /v1/chat/completions
    model_name: str = "gpt-5.2-codex"

    def model(self, lm: Infiller) -> Infiller:
        import os

        from lerobot_policy_recent.recent_plugin.infillers.openai_chat import OpenAIChatInfiller

        if not self.base_url:
            raise ValueError("cap-llm needs a served chat model: pass --method.base_url (and --method.model_name)")
        return OpenAIChatInfiller(self.base_url, self.model_name, api_key=os.environ.get("OPENAI_API_KEY"))


@functools.cache
def _llamacpp(model: str, n_threads: int | None) -> Infiller:
    """One loaded model per process, whichever agents ask for it."""
    from lerobot_policy_recent.recent_plugin.infillers.configs import LlamaCppConfig

    return LlamaCppConfig(model=model, n_threads=n_threads).build()


@Method.register_subclass("scot")
@dataclass
class StructuredChainOfThought(Baseline):
    """SCoT as the paper implements it: first a structured plan (which target primitive replaces each
    call, how its arguments map), then the program under it, run as is; regenerated on an error."""

    style: ClassVar[BaselineStyle] = BaselineStyle("scot", statement_repairs=0, structured_plan=True)


@Method.register_subclass("progprompt")
@dataclass
class ProgPrompt(Baseline):
    """ProgPrompt as the paper adapts it: a Pythonic header importing the target's actions, the scene's
    objects, the source program as a one-shot example to translate; run as is, regenerated on an error."""

    style: ClassVar[BaselineStyle] = BaselineStyle("progprompt", statement_repairs=0, pythonic=True)


@Method.register_subclass("roboinspector")
@dataclass
class RoboInspector(Baseline):
    """RoboInspector as the paper adopts it: a behaviour detector (Nonsense / Disorder / Infeasible /
    Badpose) before execution, and regeneration with categorised feedback when it finds something or
    the program fails."""

    style: ClassVar[BaselineStyle] = BaselineStyle("roboinspector", statement_repairs=0, inspect=True)


@Method.register_subclass("agentless")
@dataclass
class Agentless(Baseline):
    """A constraint-aware prompt; on a failure the failing line first, then the whole function."""

    style: ClassVar[BaselineStyle] = BaselineStyle("agentless", constraints=True, statement_repairs=1)


def program_context(task: TaskSpec | None) -> ProgramContext:
    """What a baseline's prompt shows of the task: its instruction and the scene's objects."""
    if task is None:
        return ProgramContext(instruction="")
    return ProgramContext(task.instruction, tuple(f"{o.name} ({o.kind})" for o in task.objects))
