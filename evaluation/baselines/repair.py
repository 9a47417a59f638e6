"""RepairAgent-style (``repair``): generate as ``cap``, then rewrite the failing statement."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from lerobot_policy_recent.evaluation.baselines.base import Baseline
from lerobot_policy_recent.evaluation.baselines.program_prompt import BaselineStyle
from lerobot_policy_recent.recent_plugin.methods.base import Method

RECALLED = 4  # earlier failed rewrites a repair prompt recalls, newest last


@dataclass(frozen=True)
class RepairAgentStyle(BaselineStyle):
    """RepairAgent keeps what its tools returned in a growing prompt, so a patch sees the patches that
    failed before it. Here that history is the skill's latest failed rewrites and their errors (a
    bounded window: the prompt stays within the model's context however long the loop runs)."""

    def history(self, failed: list[str]) -> str:
        recent = list(dict.fromkeys(failed))[-RECALLED:]
        return "; ".join(f"tried before and failed: {line}" for line in recent)


@Method.register_subclass("repair")
@dataclass
class RepairAgent(Baseline):
    """RepairAgent-style: generate as ``cap``, then rewrite the failing statement with the error, the
    scene and the rewrites that already failed."""

    style: ClassVar[BaselineStyle] = RepairAgentStyle("repair", statement_repairs=None)
