"""RECENT (the paper's method) and its fast-path variant.

RECENT grounds each determined conflict with one localized FIM edit before execution and adapts
during execution with in-situ checks. Its ablations and the sanity row live with the benchmark
harness (``evaluation/ablations.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from lerobot_policy_recent.recent_plugin.executor import Adapter
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill, ground_skill
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.insitu.adapter import InSituAdapter
from lerobot_policy_recent.recent_plugin.insitu.checks import SceneFacts
from lerobot_policy_recent.recent_plugin.methods.base import Adaptation, Grounding, Method
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
            base_xy=a.calibration.base_xyz[:2],  # where the mount puts this arm, measured
            reach=a.target.arm.reach,
            table_reach=a.calibration.table_reach_m,  # how far out the hand gets down to the table, measured
            inner_reach=a.calibration.inner_reach_m,  # how near the base it stops short, measured
            reach_limits=a.calibration.reach_limits(),  # how far out it gets in the air, measured
            table_top=a.calibration.table_top_z,
            push_path=a.ontology.path_of("push_object"),
            closing_axis=a.calibration.closing_axis,
            hand_half_xy=a.calibration.hand_half_xy,
        )
        skills = {step.skill: a.skill(step.skill) for step in a.task.plan}
        return InSituAdapter(
            **a.adapter_fields(),
            scene=scene,
            insitu=self.insitu,
            state_effects={name: skill.state_effects for name, skill in skills.items()},
            placements={name: skill.placements for name, skill in skills.items()},
        )


@Method.register_subclass("recent+fast-path")
@dataclass
class RecentFastPath(Recent):
    family: ClassVar[str] = "variant"
    fast_path: bool = True
