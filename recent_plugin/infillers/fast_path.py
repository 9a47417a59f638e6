"""The zero-token fast path: where the ontology decides a whole span, render it; ask the LM for the rest.

A determined conflict whose substitute call has every argument bound by role (no ``<type>``
placeholder left) holds nothing for an LM to decide: the ``rule`` renderer writes it in no time
and with no tokens. Spans with undecided arguments (interface rewiring), run-time patches and
whole-body regeneration still go to the LM. Off by default, so RECENT's numbers stay the paper's
method (one LM call per conflict); ``--fast-path`` trades that for a near-zero IGT on CPUs.
"""

from __future__ import annotations

from ontology.diagnosis import SPAN_TYPES
from recent_plugin.grounding.substitution import has_placeholders
from recent_plugin.grounding.units import RefactoringUnit
from recent_plugin.infillers.base import Completion, Infiller
from recent_plugin.infillers.rule import RuleInfiller


class FastPathInfiller:
    def __init__(self, lm: Infiller):
        self.lm, self.rule = lm, RuleInfiller()
        self.name = f"{lm.name}+fast-path"
        self.model = lm.model
        self.rendered = 0  # spans the fast path wrote (the rest went to the LM)

    def decided(self, unit: RefactoringUnit) -> bool:
        """The ontology bound every argument of the span's substitute, and this is its first attempt."""
        call = unit.hints.substitute_call
        return (
            unit.span_type in SPAN_TYPES  # the diagnosis' determined conflicts
            and unit.hints.attempt == 0
            and bool(call)
            and not has_placeholders(call)
        )

    def infill(self, unit: RefactoringUnit) -> Completion:
        if self.decided(unit):
            self.rendered += 1
            return self.rule.infill(unit)
        return self.lm.infill(unit)

    def count_tokens(self, text: str) -> int:
        return self.lm.count_tokens(text)  # GO's denominator stays in the LM's tokens
