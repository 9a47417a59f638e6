"""Render the ontology's substitution for one span: the substitute call with mapped arguments bound.

Arguments the ontology can map (same role) keep the original expressions (translated where the
vocabularies differ); required parameters nothing maps to stay as ``<type>`` placeholders, which
is what is left for the LM to decide. The ``rule`` backend emits this text as it is.
"""

from __future__ import annotations

import ast
import re

from ontology.diagnosis import Conflict, ParameterMapping

PLACEHOLDER = re.compile(r"<[a-z_]+>")


def render_substitute_call(span: str, conflict: Conflict) -> str | None:
    substitute = conflict.substitute
    if substitute is None:
        return None
    statement = ast.parse(span).body[0]
    call = statement.value  # the diagnosis flags only `f(...)` and `x = f(...)` statements
    given = {k.arg: k.value for k in call.keywords if k.arg}
    by_target = {m.target: m for m in conflict.mapping}
    arguments = ["env", "task"]
    for param in substitute.parameters:
        mapping = by_target.get(param.name)
        if mapping is not None and mapping.source in given:
            arguments.append(f"{param.name}={ast.unparse(_translate(given[mapping.source], mapping))}")
        elif param.required:
            arguments.append(f"{param.name}=<{param.type}>")
    targets = "".join(f"{ast.unparse(t)} = " for t in getattr(statement, "targets", []))
    # Preparatory primitives first (one per line), then the substitute itself.
    return "\n".join(
        [
            *(f"{name}(env, task)" for name in conflict.preparatory),
            f"{targets}{substitute.name}({', '.join(arguments)})",
        ]
    )


def has_placeholders(text: str) -> bool:
    return bool(PLACEHOLDER.search(text))


def _translate(value: ast.expr, mapping: ParameterMapping) -> ast.expr:
    if isinstance(value, ast.Constant) and mapping.values:
        return ast.Constant(mapping.translate(value.value))
    return value
