"""``Target``: a robot resolved once, as the ontology built it, and handed down instead of its name.

Grounding, the methods, in-situ adaptation and the executor all need the same few facts about the
robot a skill runs on; resolving the name in each of them repeated lookups and their errors.

The callables behind the API are the simulator's (``robosuite_envs/primitives/binding.py`` binds
and cross-checks them); the ontology knows only the spec and the MJCF facts.
"""

from __future__ import annotations

from dataclasses import dataclass

from lerobot_policy_recent.ontology.mjcf import ArmFacts, GripperFacts
from lerobot_policy_recent.ontology.specs import ApiSpec


@dataclass(frozen=True)
class Target:
    """The robot's name, its primitive API (the YAML spec), and its arm and gripper read from MJCF."""

    name: str
    api: ApiSpec
    arm: ArmFacts
    gripper: GripperFacts
