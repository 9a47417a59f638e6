"""What a hint says about an argument the ontology leaves open: facts, not the answer.

For each such argument: what its role means, and what is in scope to write it from (the object
names the function holds and the positions it read, each with where it came from). The LM decides;
validation then holds the answer to the argument's role (``grounding/grounder.py``).
"""

from __future__ import annotations

import ast
from dataclasses import dataclass

from lerobot_policy_recent.ontology.conversions import OBJECT_NAME, POINTS
from lerobot_policy_recent.ontology.diagnosis import Conflict
from lerobot_policy_recent.ontology.skill_code import enclosing_function, position_names
from lerobot_policy_recent.ontology.specs import RECEIVING_ROLES, ROLE_MEANINGS

POSITION_QUERY = "task.get_object_position(name) reads a named object's position [x, y, z] (m, world frame)"


@dataclass(frozen=True)
class Exclusion:
    """Names an open argument may not take, and why: a place's receptacle is not the object the hand
    holds (put "on itself"), written as its variable or as its name in quotes. The span is rejected
    with ``why``, and its retry is held to the other names in scope."""

    call: str  # the callee whose argument it is (the substitute, or a call made before it)
    argument: str
    names: tuple[str, ...]  # the held object's variable first, then its default name quoted
    why: str


def exclusions(code: str, conflict: Conflict) -> tuple[Exclusion, ...]:
    """What the open arguments of ``conflict`` (its substitute's, or a preparatory call's) may not name:
    a receiving argument (a receptacle, what the hand moves over) never names the object the hand
    holds there, by the source's data flow. A span is judged while the calls before it are still to
    be grounded, so the whole program's role check cannot see this there: it blamed the grasp's
    span instead, three times, and failed the skill."""
    if conflict.substitute is None or conflict.held is None:
        return ()
    held, since = conflict.held
    sub = conflict.substitute
    open_ = [(sub.name, p.name, p.role) for name in conflict.unfilled if (p := sub.parameter(name)) is not None]
    for call, arguments in zip(conflict.preparatory, conflict.preparatory_arguments, strict=False):
        open_ += [
            (call, m.target, m.role) for m in arguments if m.conversion is not None and not m.conversion.determined
        ]
    receiving = dict.fromkeys((call, argument, role) for call, argument, role in open_ if role in RECEIVING_ROLES)
    if not receiving:
        return ()
    spellings = (held, *_quoted_default(code, conflict.span.start, held))
    return tuple(
        Exclusion(
            call,
            argument,
            spellings,
            f"{call}'s {argument} is {ROLE_MEANINGS[role]}, but {held} is the object held since line {since}",
        )
        for call, argument, role in receiving
    )


def _quoted_default(code: str, offset: int, name: str) -> tuple[str, ...]:
    """``"cube"`` and ``'cube'`` where ``name`` is a parameter of the function at ``offset`` with the default ``"cube"``."""
    func = _function_at(code, offset)
    default = _name_defaults(func).get(name) if func is not None else None
    return (f'"{default}"', f"'{default}'") if default is not None else ()


def _name_defaults(func: ast.FunctionDef) -> dict[str, str]:
    """The function's parameters whose default is a string (an object's name), with it."""
    args = func.args.args
    pairs = zip(args[len(args) - len(func.args.defaults) :], func.args.defaults, strict=True)
    return {a.arg: d.value for a, d in pairs if isinstance(d, ast.Constant) and isinstance(d.value, str)}


def _function_at(code: str, offset: int) -> ast.FunctionDef | None:
    lo, hi = enclosing_function(code, offset)
    try:
        func = ast.parse(code[lo:hi]).body[0]
    except (SyntaxError, IndexError):
        return None
    return func if isinstance(func, ast.FunctionDef) else None


def decision_facts(code: str, conflict: Conflict, barred: tuple[Exclusion, ...] = ()) -> tuple[str, ...]:
    """The hint lines for ``conflict``'s unfilled arguments, or, where nothing is left open, for the
    names the ontology took from a point (:func:`named_by_point`). ``barred``: its
    :func:`exclusions`, whose held object the hint names."""
    if conflict.substitute is None:
        return ()
    if not conflict.unfilled:
        return named_by_point(conflict)
    lines, points = [], False
    for name in dict.fromkeys(conflict.unfilled):
        param = conflict.substitute.parameter(name)
        if param is None:  # an argument of a preparatory call: its placeholder and the API line say what it is
            continue
        points |= param.type in POINTS
        meaning = ROLE_MEANINGS.get(param.role)
        if meaning is None:
            continue
        lines.append(f"{name} is {meaning}")
    scope = in_scope(code, conflict.span.start)
    if scope:
        lines.append("In scope: " + "; ".join(scope))
    if conflict.held is not None and barred:
        lines.append(f"The hand holds {conflict.held[0]} here (taken at line {conflict.held[1]})")
    if points:
        lines.append(POSITION_QUERY)
    return tuple(lines)


def named_by_point(conflict: Conflict) -> tuple[str, ...]:
    """Why an object-name argument is the object it is, where the original passed a point: the
    point was placed by that object's position (``obj_name is what the held object is put on or
    into: target, whose position places place's target_pos``). Given only the call to copy, the 1.5B
    wrote the object the skill had picked up (``obj``), the first name in scope."""
    lines = []
    for m in conflict.mapping:
        param = conflict.substitute.parameter(m.target)
        meaning = ROLE_MEANINGS.get(param.role) if param is not None and param.type == OBJECT_NAME else None
        if not (meaning and m.conversion is not None and m.conversion.determined and m.source):
            continue
        if m.source == conflict.by_placements and conflict.held is not None:
            why = f"where the skill's placements put {conflict.held[0]}, which the hand holds here"
        else:
            why = f"whose position places {conflict.original}'s {m.source}"
        lines.append(f"{m.target} is {meaning}: {m.conversion.template}, {why}")
    return tuple(lines)


def in_scope(code: str, offset: int) -> list[str]:
    """The object names and positions the function at ``offset`` holds before it, with their origins."""
    func = _function_at(code, offset)
    if func is None:
        return []
    lo, hi = enclosing_function(code, offset)
    line = code.count("\n", lo, offset) + 1  # the span's line within the function's text
    found = [
        f"{arg} (an object name, a parameter: {default!r} by default)" for arg, default in _name_defaults(func).items()
    ]
    positions = position_names(code[lo:hi]).variables
    for node in ast.walk(func):
        if not (isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name)):
            continue
        if node.lineno >= line:
            continue
        var = node.targets[0].id
        if isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            found.append(f"{var} (an object name: {node.value.value!r})")
        elif var in positions:
            read = isinstance(node.value, ast.Call)  # task.get_object_position(name) itself
            what = f"the position of {positions[var]}" if read else f"a point placed by {positions[var]}'s position"
            found.append(f"{var} ({what}: {ast.unparse(node.value)})")
    return found
