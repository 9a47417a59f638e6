"""The ``rule`` backend: renders the ontology substitution with no LM (zero generated tokens).

It is the fast path when the ontology fully determines an edit and the reference the LM
backends are compared against. Where a required argument has no source counterpart (interface
rewiring) it cannot decide, and returns nothing.
"""

from __future__ import annotations

import time

from lerobot_policy_recent.recent_plugin.infillers.base import Completion
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import approximate_tokens
from lerobot_policy_recent.recent_plugin.refactoring.substitution import has_placeholders
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit


class RuleInfiller:
    name = "rule"
    samples = False
    model = "ontology-substitution"

    def infill(self, unit: RefactoringUnit) -> Completion:
        started = time.perf_counter()
        call = unit.hints.substitute_call or ""
        if has_placeholders(call):
            open_ = ", ".join(unit.hints.unfilled) or "an argument"
            why = (
                f"the ontology leaves {open_} of {unit.substitute or 'the call'} open, and the rule backend "
                "decides nothing: ground with an LM (--infiller.type llamacpp), or give the skill's metadata "
                "what decides it (docs/add_a_skill.md)"
            )
            return Completion(text="", generated_tokens=0, seconds=time.perf_counter() - started, declined=why)
        return Completion(text=call, generated_tokens=0, seconds=time.perf_counter() - started)

    def count_tokens(self, text: str) -> int:
        return approximate_tokens(text)
