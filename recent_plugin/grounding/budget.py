"""One budget of LM calls per task, the same for every method (the comparison's equal footing).

Every call a method makes for one episode counts against it: grounding the plan's skills (a
cached grounding counts the calls that produced it) and every revise or repair while the robot
runs. A call beyond the budget is not made: :class:`BudgetedInfiller` raises
:class:`LMBudgetExhausted`, which ends that attempt loop as if no valid answer came. Spans the
fast path renders and the rule backend's are no LM calls and cost nothing.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

from lerobot_policy_recent.recent_plugin.infillers.base import Completion, Infiller, samples
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
    """The LM behind a :class:`CallBudget`, for one episode: each call takes one, and none is made once
    it is spent. With a ``temperature`` above 0 every call of an LM that samples does so, seeded from
    the episode's ``seed``, the ``scope`` that makes it (one skill's grounding, or the run time) and
    its place in that scope: seeds are real repetitions, and a skill grounded in an earlier episode
    of the worker (served from the cache) is the grounding this episode would have made itself.
    Seeded by the call's place in the whole episode, it was not: the same skill came after other
    skills in another task, drew with other seeds, and the record depended on what ran before."""

    def __init__(self, lm: Infiller, budget: CallBudget, *, temperature: float = 0.0, seed: int = 0, scope: str = ""):
        self.lm, self.budget = lm, budget
        self.name, self.model = lm.name, lm.model
        self.samples = samples(lm)
        self.temperature, self.seed, self.scope = (temperature if self.samples else 0.0), seed, scope
        self.calls = 0  # made through this infiller: the call's place in its scope

    def infill(self, unit: RefactoringUnit) -> Completion:
        self.budget.take()
        self.calls += 1
        if self.temperature <= 0:
            return self.lm.infill(unit)
        call_seed = zlib.crc32(f"{self.seed}:{self.scope}:{self.calls}".encode())
        return self.lm.infill(unit, temperature=self.temperature, seed=call_seed)  # type: ignore[call-arg]

    def count_tokens(self, text: str) -> int:
        return self.lm.count_tokens(text)
