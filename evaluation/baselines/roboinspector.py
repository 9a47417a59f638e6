"""RoboInspector (``roboinspector``): a behaviour detector before execution, categorised feedback."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from lerobot_policy_recent.evaluation.baselines.base import Baseline
from lerobot_policy_recent.evaluation.baselines.inspector import categorised, inspection_verdict
from lerobot_policy_recent.evaluation.baselines.program_prompt import BaselineStyle
from lerobot_policy_recent.ontology.specs import ApiSpec
from lerobot_policy_recent.recent_plugin.grounding.gate import Verdict
from lerobot_policy_recent.recent_plugin.methods.base import Method


@dataclass(frozen=True)
class InspectorStyle(BaselineStyle):
    """A program passes the security gate, then the Nonsense / Disorder / Infeasible / Badpose
    detector; a run-time failure is told with the behaviour it shows."""

    def judge(self, candidate: str, entry: str, api: ApiSpec) -> Verdict:
        verdict = super().judge(candidate, entry, api)
        return inspection_verdict(candidate, entry, api) if verdict.ok else verdict

    def error_feedback(self, category: str, error: str) -> str:
        return f"{categorised(category).capitalize()} ({error})"


@Method.register_subclass("roboinspector")
@dataclass
class RoboInspector(Baseline):
    """RoboInspector as the paper adopts it: a behaviour detector (Nonsense / Disorder / Infeasible /
    Badpose) before execution, and regeneration with categorised feedback when it finds something or
    the program fails."""

    style: ClassVar[BaselineStyle] = InspectorStyle("roboinspector", statement_repairs=0)
