"""Render the ontology's substitution for one span: the substitute call with mapped arguments bound.

Arguments the ontology can map (same role) keep the original expressions (translated where the
vocabularies differ); required parameters nothing maps to stay as ``<type>`` placeholders, which
is what is left for the LM to decide. The ``rule`` backend emits this text as it is.
"""

from __future__ import annotations

import ast
import re

from lerobot_policy_recent.ontology.diagnosis import OMITTED, Conflict, ParameterMapping
from lerobot_policy_recent.ontology.specs import PATH_ROLE

PLACEHOLDER = re.compile(r"<[a-z_]+>")


def render_substitute_call(span: str, conflict: Conflict) -> str | None:
    substitute = conflict.substitute
    if conflict.omitted:
        return OMITTED
    if substitute is None:
        return None
    statement = ast.parse(span).body[0]
    call = statement.value  # the diagnosis flags only `f(...)` and `x = f(...)` statements
    given = {k.arg: k.value for k in call.keywords if k.arg}
    targets = "".join(f"{ast.unparse(t)} = " for t in getattr(statement, "targets", []))
    # Preparatory primitives first (one per line), then the substitute itself.
    first = [_preparatory_call(conflict, k, given) for k in range(len(conflict.preparatory))]
    if conflict.path:
        return "\n".join([*first, *_traced(conflict, given, targets)])
    by_target, kept = {m.target: m for m in conflict.mapping}, dict(conflict.kept)
    arguments = ["env", "task"]
    for param in substitute.parameters:
        mapping = by_target.get(param.name)
        if mapping is not None and mapping.source in given:
            arguments.append(f"{param.name}={_bound(given[mapping.source], mapping)}")
        elif param.name in kept:  # what the original relied on without stating it (its motion's time)
            arguments.append(f"{param.name}={kept[param.name]}")
        elif param.required:
            arguments.append(f"{param.name}=<{param.type}>")
    return "\n".join([*first, f"{targets}{substitute.name}({', '.join(arguments)})"])


def _preparatory_call(conflict: Conflict, k: int, given: dict[str, ast.expr]) -> str:
    """``close_robotiq85(env, task)``, or a move that takes the original's argument: ``move_gripper_to(env,
    task, obj_name=box)``; ``<type>`` where nothing given determines it."""
    arguments = ["env", "task"]
    for mapping in conflict.preparatory_arguments[k] if conflict.preparatory_arguments else ():
        value = given.get(mapping.source)
        text = mapping.conversion.template if value is None else _bound(value, mapping)  # None: a placeholder
        arguments.append(f"{mapping.target}={text}")
    return f"{conflict.preparatory[k]}({', '.join(arguments)})"


def _bound(value: ast.expr, mapping: ParameterMapping) -> str:
    """The original argument as the substitute takes it: translated, then converted."""
    value = _translate(value, mapping)
    return ast.unparse(value) if mapping.conversion is None else mapping.conversion.apply(_operand(value))


def _traced(conflict: Conflict, given: dict[str, ast.expr], targets: str) -> list[str]:
    """One move per path step, to the original argument's position plus the step's offset."""
    point = conflict.substitute.by_role(PATH_ROLE)
    moves = []
    for step in conflict.path:
        if step.actuate:
            moves.append(f"{step.actuate}(env, task)")
            continue
        value = given.get(step.source)
        if value is not None and step.lookup:
            value = ast.parse(step.point(ast.unparse(value)), mode="eval").body  # a name: where that object is
        where = "<position>" if value is None else _offset(value, step.offset)
        if value is not None and step.conversion is not None:
            where = step.conversion.apply(where if any(step.offset) else _operand(value))  # _offset's: a list
        moves.append(f"{conflict.substitute.name}(env, task, {point.name}={where})")
    moves[-1] = targets + moves[-1]
    return moves


def _offset(value: ast.expr, offset: tuple[float, float, float]) -> str:
    """``value + offset`` as plain Python: element-wise on a literal, else indexed (no numpy in skills)."""
    if not any(offset):
        return ast.unparse(value)
    if isinstance(value, ast.List | ast.Tuple) and len(value.elts) == 3:
        items = [ast.unparse(e) for e in value.elts]
    else:
        base = ast.unparse(value)
        if not isinstance(value, ast.Name | ast.Attribute | ast.Subscript | ast.Call):
            base = f"({base})"
        items = [f"{base}[{i}]" for i in range(3)]
    return "[" + ", ".join(_plus(item, d) for item, d in zip(items, offset, strict=True)) + "]"


def _plus(expression: str, delta: float) -> str:
    return expression if not delta else f"{expression} {'+' if delta > 0 else '-'} {abs(delta):g}"


def _operand(value: ast.expr) -> str:
    """``value`` as text that a conversion may index or iterate over (``(a + b)[:3]``, not ``a + b[:3]``)."""
    text = ast.unparse(value)
    atomic = ast.Name | ast.Attribute | ast.Subscript | ast.Call | ast.List | ast.Tuple | ast.Constant
    return text if isinstance(value, atomic) else f"({text})"


def has_placeholders(text: str) -> bool:
    return bool(PLACEHOLDER.search(text))


def _translate(value: ast.expr, mapping: ParameterMapping) -> ast.expr:
    if isinstance(value, ast.Constant) and mapping.values:
        return ast.Constant(mapping.translate(value.value))
    return value
