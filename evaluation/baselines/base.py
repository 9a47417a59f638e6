"""``Baseline``: what every baseline shares as a registered method (one per module beside this one).

Each baseline writes the whole program from a prompt that shows the task, and answers a failure
its own way; its :class:`BaselineStyle` (the prompt's strategy) lives in its module.
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
        fields = a.adapter_fields()
        # every repair is an LM call: where a budget binds, the loop runs until it is spent or the task succeeds
        if a.lm_budget_binds:
            fields["max_repairs"] = None
        return BaselineAdapter(
            **fields,
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


def program_context(task: TaskSpec | None) -> ProgramContext:
    """What a baseline's prompt shows of the task: its instruction and the scene's objects."""
    if task is None:
        return ProgramContext(instruction="")
    return ProgramContext(task.instruction, tuple(f"{o.name} ({o.kind})" for o in task.objects))


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


@functools.cache
def llamacpp_model(model: str, n_threads: int | None) -> Infiller:
    """One loaded model per process, whichever agents ask for it."""
    from lerobot_policy_recent.recent_plugin.infillers.configs import LlamaCppConfig

    return LlamaCppConfig(model=model, n_threads=n_threads).build()
