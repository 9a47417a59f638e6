"""``Method``: how a skill is grounded before execution and adapted while it runs.

RECENT, its ablations and every baseline are subclasses registered under the name ``recent bench
--methods`` and ``--method`` take (draccus choices, so ``lerobot-eval --policy.method.type=cap``
takes the same names). The agent asks the method; nothing compares method names.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import draccus

from lerobot_policy_recent.logs.events import Emit, ignore
from lerobot_policy_recent.ontology.builder import Ontology
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.executor import Adapter
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.robosuite_envs.calibration import Calibration
from lerobot_policy_recent.robosuite_envs.tasks import TaskSpec
from lerobot_policy_recent.skills.repository import Skill


@dataclass(frozen=True)
class Grounding:
    """What a method grounds with: the skill, the resolved robot, the ontology, the LM and the task it serves."""

    skill: Skill
    target: Target
    ontology: Ontology
    infiller: Infiller
    task: TaskSpec | None
    max_retries: int


@dataclass(frozen=True)
class Adaptation:
    """What a method adapts with during one episode (its calls and events are that episode's)."""

    target: Target
    calibration: Calibration  # the target's, measured once: read here, never looked up again by name
    ontology: Ontology
    infiller: Infiller
    task: TaskSpec
    skill: Callable[[str], Skill]  # the agent's skill by name (validated unless the method says not)
    max_retries: int
    max_repairs: int
    emit: Emit = ignore
    # every LM call is taken from a task budget with a limit: a loop that only the LM drives may run
    # until that budget is spent (a baseline's repairs) instead of stopping at ``max_repairs``
    lm_budget_binds: bool = False

    def adapter_fields(self) -> dict[str, object]:
        """What every run-time adapter is built with: the robot, every API, the LM, the budgets, the log."""
        return {
            "target": self.target,
            "apis": self.ontology.apis,
            "infiller": self.infiller,
            "max_retries": self.max_retries,
            "max_repairs": self.max_repairs,
            "emit": self.emit,
        }


@dataclass
class Method(draccus.ChoiceRegistry):
    """A grounding-and-adaptation strategy. Subclasses register a name and override the behaviour."""

    family: ClassVar[str] = "recent"  # recent | variant (of RECENT) | ablation | baseline
    # What the paper's ablation tables expect it to do to RECENT's numbers: metric -> +1 (up) or -1 (down).
    expected: ClassVar[dict[str, int]] = {}
    # Runs each episode on the task's source robot instead of the target (the bench's ceiling row).
    on_source: ClassVar[bool] = False

    @classmethod
    def default_choice_name(cls) -> str:
        return "recent+fast-path"  # the product's; a flag such as ``--method.insitu=false`` alone keeps it

    @property
    def name(self) -> str:
        return Method.get_choice_name(type(self))

    @property
    def label(self) -> str:
        """The method as an episode's log names it."""
        return self.name

    def require_validated(self) -> bool:
        """Serve only skills whose validation record matches their code (False: an ablation)."""
        return True

    def model(self, lm: Infiller) -> Infiller:
        """The LM this method runs on: the run's ``lm``, or a model of its own (a sanity row without
        an LM, a baseline on another model). The task's call budget is taken from this one."""
        return lm

    def infiller(self, lm: Infiller) -> Infiller:
        """The infiller this method asks: ``lm``, or something in front of it."""
        return lm

    def grounding_key(self, task: TaskSpec | None) -> str:
        """What besides the skill, robot, ontology and LM a grounding depends on (a cache key part)."""
        return ""

    def ground(self, g: Grounding) -> GroundedSkill:
        raise NotImplementedError

    def adapter(self, a: Adaptation) -> Adapter:
        raise NotImplementedError


def method_named(name: str) -> Method:
    """A fresh instance of the method registered as ``name``, with a clear error for an unknown one."""
    try:
        return Method.get_choice_class(name)()
    except KeyError:
        raise ValueError(f"unknown method {name!r}; choose from: {', '.join(Method.get_known_choices())}") from None
