"""``Target``: a robot resolved once, as the ontology built it, and handed down instead of its name.

Grounding, the methods, in-situ adaptation and the executor all need the same few facts about the
robot a skill runs on; resolving the name in each of them repeated lookups and their errors.
"""

from __future__ import annotations

from dataclasses import dataclass

from lerobot_policy_recent.ontology.mjcf import ArmFacts, GripperFacts
from lerobot_policy_recent.ontology.specs import ApiSpec, SpecError
from lerobot_policy_recent.robosuite_envs.primitives import module_functions


@dataclass(frozen=True)
class Target:
    """The robot's name, its primitive API (the YAML spec), and its arm and gripper read from MJCF."""

    name: str
    api: ApiSpec
    arm: ArmFacts
    gripper: GripperFacts

    def primitives(self) -> dict[str, object]:
        """The callables the executor binds into skill code (the API's ``module``)."""
        try:
            return module_functions(self.api.module)
        except ModuleNotFoundError as error:
            raise SpecError(self.api.path, "module", f"{self.api.module!r} cannot be imported ({error})") from None
