"""RepairAgent-style (``repair``): generate as ``cap``, then rewrite the failing statement."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from lerobot_policy_recent.evaluation.baselines.base import Baseline
from lerobot_policy_recent.evaluation.baselines.program_prompt import BaselineStyle
from lerobot_policy_recent.recent_plugin.methods.base import Method


@Method.register_subclass("repair")
@dataclass
class RepairAgent(Baseline):
    """RepairAgent-style: generate as ``cap``, then rewrite the failing statement with the error and the scene."""

    style: ClassVar[BaselineStyle] = BaselineStyle("repair", statement_repairs=None)
