"""Agentless (``agentless``): a constraint-aware prompt; the failing line first, then the function."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from lerobot_policy_recent.evaluation.baselines.base import Baseline
from lerobot_policy_recent.evaluation.baselines.program_prompt import BaselineStyle, ProgramPrompt
from lerobot_policy_recent.recent_plugin.methods.base import Method


@dataclass(frozen=True)
class ConstraintStyle(BaselineStyle):
    """Each primitive's description, the scene's objects and the workspace bounds in the header."""

    def header(self, prompt: ProgramPrompt) -> str:
        return prompt.api_header(described=True)


@Method.register_subclass("agentless")
@dataclass
class Agentless(Baseline):
    """A constraint-aware prompt; on a failure the failing line first, then the whole function."""

    style: ClassVar[BaselineStyle] = ConstraintStyle("agentless", statement_repairs=1)
