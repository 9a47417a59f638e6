"""The ``rule`` backend: renders the ontology substitution with no LM (zero generated tokens).

It is the fast path when the ontology fully determines an edit and the reference the LM
backends are compared against.
"""

from __future__ import annotations

import ast
import time

from recent_plugin.grounding.units import RefactoringUnit
from recent_plugin.infillers.base import Completion, approximate_tokens


class RuleInfiller:
    name = "rule"
    model = "ontology-substitution"

    def infill(self, unit: RefactoringUnit) -> Completion:
        started = time.perf_counter()
        return Completion(text=render_substitution(unit), generated_tokens=0, seconds=time.perf_counter() - started)

    def count_tokens(self, text: str) -> int:
        return approximate_tokens(text)


def render_substitution(unit: RefactoringUnit) -> str:
    """Rewrite the call in ``unit.span`` to the substitute with arguments renamed by the mapping."""
    if unit.substitute is None:
        return ""
    statement = ast.parse(unit.span).body[0]
    call = statement.value  # the diagnoser only flags `f(...)` and `x = f(...)` statements
    mapping = dict(unit.hints.mapping)
    keywords = [
        ast.keyword(arg=mapping[k.arg], value=k.value)
        for k in call.keywords
        if k.arg in mapping and k.arg not in unit.hints.dropped
    ]
    call.func = ast.Name(id=unit.substitute, ctx=ast.Load())
    call.args = call.args[:2]  # env, task
    call.keywords = keywords
    return ast.unparse(statement)
