"""RECENT (the paper's method), its variants, and its grounding ablations.

RECENT grounds each determined conflict with one localized FIM edit before execution and adapts
during execution with in-situ checks. The variants change one setting; the ablations change what
the infiller is asked before execution (``grounding/ablations.py``) and keep in-situ adaptation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from lerobot_policy_recent.recent_plugin.executor import Adapter
from lerobot_policy_recent.recent_plugin.grounding.ablations import name_similarity_conflicts
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill, ground_skill, regenerate_skill
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.insitu.adapter import InSituAdapter
from lerobot_policy_recent.recent_plugin.insitu.checks import SceneFacts
from lerobot_policy_recent.recent_plugin.methods.base import Adaptation, Grounding, Method
from lerobot_policy_recent.robosuite_envs.calibrate import calibration
from lerobot_policy_recent.robosuite_envs.objects import get_kind


@Method.register_subclass("recent")
@dataclass
class Recent(Method):
    insitu: bool = True  # run-time checks patch upcoming segments (False: reactive repair only)
    offline_validation: bool = True  # serve only skills validated in simulation
    fast_path: bool = False  # render spans the ontology or a run-time check fully decides, without the LM

    @property
    def label(self) -> str:
        return self.name if self.insitu else f"{self.name} (no in-situ)"

    def require_validated(self) -> bool:
        return self.offline_validation

    def infiller(self, lm: Infiller) -> Infiller:
        if not self.fast_path or lm.name == "rule":
            return lm
        from lerobot_policy_recent.recent_plugin.infillers.fast_path import FastPathInfiller

        return FastPathInfiller(lm)

    def ground(self, g: Grounding) -> GroundedSkill:
        return ground_skill(g.skill, g.target, g.ontology, g.infiller, max_retries=g.max_retries)

    def adapter(self, a: Adaptation) -> Adapter:
        scene = SceneFacts(
            loose=frozenset(o.name for o in a.task.objects if not get_kind(o.kind).fixed),
            sizes={o.name: tuple(o.size) for o in a.task.objects if o.size is not None},
            task_objects=frozenset(v for step in a.task.plan for v in step.args.values()),
            base_xy=calibration(a.target.name).base_xyz[:2],  # where the mount puts this arm, measured
            reach=a.target.arm.reach,
            push_path=a.ontology.path_of("push_object"),
        )
        return InSituAdapter(**a.adapter_fields(), scene=scene, insitu=self.insitu)


@Method.register_subclass("recent+fast-path")
@dataclass
class RecentFastPath(Recent):
    family: ClassVar[str] = "variant"
    fast_path: bool = True


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
