"""One budget of LM calls per task, the same for every method (the comparison's equal footing).

Every call a method makes for one episode counts against it: grounding the plan's skills (a
cached grounding counts the calls that produced it) and every revise or repair while the robot
runs. A call beyond the budget is not made: :class:`BudgetedInfiller` raises
:class:`LMBudgetExhausted`, which ends that attempt loop as if no valid answer came. Spans the
fast path renders and the rule backend's are no LM calls and cost nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

from lerobot_policy_recent.recent_plugin.infillers.base import Completion, Infiller
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit


class LMBudgetExhausted(RuntimeError):
    """The task's LM calls are spent; no further call is made."""


@dataclass
class CallBudget:
    limit: int  # LM calls per task; 0: unlimited
    used: int = 0

    def remaining(self) -> int | None:
        return None if not self.limit else max(0, self.limit - self.used)

    def affords(self, calls: int) -> bool:
        return not self.limit or self.used + calls <= self.limit

    def charge(self, calls: int) -> None:
        """Count calls made earlier (a cached grounding's) against the budget."""
        self.used += calls

    def take(self) -> None:
        if not self.affords(1):
            raise LMBudgetExhausted(f"the task's LM call budget ({self.limit} calls) is spent")
        self.used += 1


class BudgetedInfiller:
    """The LM behind a :class:`CallBudget`: each call takes one, and none is made once it is spent."""

    def __init__(self, lm: Infiller, budget: CallBudget):
        self.lm, self.budget = lm, budget
        self.name, self.model = lm.name, lm.model

    def infill(self, unit: RefactoringUnit) -> Completion:
        self.budget.take()
        return self.lm.infill(unit)

    def count_tokens(self, text: str) -> int:
        return self.lm.count_tokens(text)
