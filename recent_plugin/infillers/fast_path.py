"""The zero-token fast path: where the ontology or a run-time check decides a whole span, render it;
ask the LM for the rest.

A determined conflict whose substitute call has every argument bound by role (no ``<type>``
placeholder left) holds nothing for an LM to decide: the ``rule`` renderer writes it in no time
and with no tokens. The same holds while the skill runs: a check that saw the cube move writes
the re-read itself (``obj_pos = task.get_object_position('cube')``), the obstacle check the sweep
with its coordinates, a repair the recomputation copied from the skill; the LM would only copy
them. Spans with undecided arguments (interface rewiring), retries after a rejected rendering and
whole-body regeneration still go to the LM. A rendered run-time patch is no interruption (EI
counts the repair and revise calls made to the model, as the paper's formula does; the robot does
not wait for a sub-millisecond rendering) but it is still a run-time patch: the benchmark reports
those per task beside EI, so the fast path hides none of them.

The product's default (``recent+fast-path``: ``recent run`` and ``lerobot-eval`` without a method):
the LM is asked only what is open. The paper's method (``recent``: an LM call per conflict and per
violation) is the benchmark's row, so RECENT's numbers stay the paper's.
"""

from __future__ import annotations

from dataclasses import replace

from lerobot_policy_recent.recent_plugin.infillers.base import Completion, Infiller, samples
from lerobot_policy_recent.recent_plugin.infillers.rule import RuleInfiller
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import decided_by_rule
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit


class FastPathInfiller:
    def __init__(self, lm: Infiller):
        self.lm, self.rule = lm, RuleInfiller()
        self.name = f"{lm.name}+fast-path"
        self.model = lm.model

    def infill(self, unit: RefactoringUnit) -> Completion:
        if decided_by_rule(unit):
            return replace(self.rule.infill(unit), rendered=True)
        return self.lm.infill(unit)

    @property
    def samples(self) -> bool:
        return samples(self.lm)

    def count_tokens(self, text: str) -> int:
        return self.lm.count_tokens(text)  # GO's denominator stays in the LM's tokens
