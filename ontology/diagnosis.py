"""The diagnosis operator D(skill, robot): determined conflicts with their substitution hints.

A call site conflicts when the target robot lacks the called primitive. The ontology's
``substitutableBy`` relation names the substitute; parameters are mapped by role, so the
conflict carries everything the refactoring step needs — no LM is involved here.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

from lerobot_policy_recent.ontology.builder import Ontology, tracing_moves
from lerobot_policy_recent.ontology.conversions import (
    NAME_LOOKUP,
    OBJECT_NAME,
    POINTS,
    WORLD_POSITION,
    Conversion,
    conversion,
)
from lerobot_policy_recent.ontology.skill_code import (
    CallSite,
    CodeSpan,
    PositionNames,
    call_sites,
    parse_expression,
    position_bindings,
    position_names,
)
from lerobot_policy_recent.ontology.specs import (
    NAMED_BY_POINT,
    PATH_ROLE,
    TIMEOUT_ROLE,
    ApiSpec,
    ParameterSpec,
    PrimitiveSpec,
    held_along,
)

SPAN_TYPES = ("api_substitution", "parameter_binding", "interface_rewiring", "preparatory_step", "path_tracing")


@dataclass(frozen=True)
class ParameterMapping:
    source: str  # parameter name in the original call
    target: str  # parameter name of the substitute
    role: str
    values: tuple[tuple[object, object], ...] = ()  # literal translation when the vocabularies differ
    conversion: Conversion | None = None  # other units, frame or rotation: how the value becomes the target's

    def translate(self, value: object) -> object:
        return dict(self.values).get(value, value)


@dataclass(frozen=True)
class PathStep:
    """One move of a traced path: to the value of ``source`` (a position argument of the original call) plus ``offset``."""

    source: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    conversion: Conversion | None = None  # the move's point takes other units, frame or a pose
    actuate: str = ""  # an actuation step instead of a move: the robot's parameterless primitive to call
    lookup: str = ""  # the argument is an object's name: the query (a template) that gives its position

    def point(self, argument: str) -> str:
        """The world position the step starts from, given the original argument's text."""
        return self.lookup.replace("{}", argument) if self.lookup else argument

    def render(self) -> str:
        """``start_pos + 0.1z``, or ``close_gripper()``: how diagnoses show a step."""
        if self.actuate:
            return f"{self.actuate}()"
        return self.point(self.source) + "".join(
            f" {'+' if v > 0 else '-'} {abs(v):g}{axis}" for axis, v in zip("xyz", self.offset, strict=True) if v
        )


@dataclass(frozen=True)
class Conflict:
    """A determined conflict: an exact code span, what it calls, and how to rewrite it."""

    span: CodeSpan
    span_type: str
    original: str  # the source primitive
    substitute: PrimitiveSpec | None
    mapping: tuple[ParameterMapping, ...] = ()
    dropped: tuple[str, ...] = ()  # source parameters the substitute has no role for
    unfilled: tuple[str, ...] = ()  # required substitute parameters nothing maps to
    preparatory: tuple[str, ...] = ()  # target primitives to call first (they establish a missing state)
    # per preparatory primitive, the original call's arguments it takes (a vacuum's detach needs the
    # cup over the receptacle first: move_gripper_to(obj_name=<the place's receptacle>))
    preparatory_arguments: tuple[tuple[ParameterMapping, ...], ...] = ()
    path: tuple[PathStep, ...] = ()  # path tracing: one call of the substitute (a move) per step
    reason: str = ""
    # what the hand holds as the call starts, by the source's data flow: the object and the line of the
    # grasp that took it (a place's receptacle is never it); None where nothing known is held
    held: tuple[str, int] | None = None
    # the original's point argument whose object the skill's ``placements`` named, where no one
    # position places it (the held object ends over that object): how the hint says where it came from
    by_placements: str = ""
    # the call has no counterpart to make and is dropped (rendered as ``pass``): a hand closed only to
    # push with, on an end effector that takes no shape (see :func:`_shaping_only`)
    omitted: bool = False
    # substitute parameters given a value the original call relied on without stating it: (name, literal),
    # the time its motion had where the substitute's default gives less (see :func:`_time_kept`)
    kept: tuple[tuple[str, str], ...] = ()

    @property
    def refused(self) -> bool:
        """The robot cannot make this call in any form (no substitute, no path to trace, not dropped):
        the skill is refused on that robot, with ``reason``, before anything is generated or run."""
        return self.substitute is None and not self.path and not self.omitted

    def preparatory_calls(self) -> list[str]:
        """``close_robotiq85``, or ``move_gripper_to(obj_name=obj_name)``: each preparatory call with
        the original's parameters it takes (how diagnoses show them)."""
        arguments = self.preparatory_arguments or ((),) * len(self.preparatory)
        return [
            name + (f"({', '.join(f'{m.target}={m.source or m.conversion.template}' for m in args)})" if args else "")
            for name, args in zip(self.preparatory, arguments, strict=True)
        ]


@dataclass(frozen=True)
class Warning:
    """An undetermined factor: checked on live observations before (or after) ``span`` runs."""

    kind: str  # the runtime condition, e.g. "surface_flat"
    span: CodeSpan  # the upcoming statement it guards
    primitive: str  # the target primitive that statement calls
    check: str  # name of the run-time check
    observation: str  # what the check reads
    message: str
    phase: str = "before"  # "before" for preconditions, "after" for effects
    through: int | None = None  # a span rendered one statement per line: the check guards its first through+1
    # a traced call's move stands for the original call: its point plays the original's role there
    # (the descent of a traced pick is the grasp): (parameter, role) pairs the check reads it by
    roles: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class Diagnosis:
    skill: str
    robot: str
    conflicts: tuple[Conflict, ...] = ()
    warnings: tuple[Warning, ...] = field(default_factory=tuple)

    @property
    def compatible(self) -> bool:
        return not self.conflicts

    def summary(self) -> dict:
        """The reviewable essence (the format of ``tests/data/expected_diagnoses.yaml``)."""
        return {
            "conflicts": [
                {
                    "line": c.span.line,
                    "original": c.original,
                    "substitute": c.substitute.name if c.substitute else None,
                    "span_type": c.span_type,
                    "mapping": {m.source: m.target for m in c.mapping},
                    "dropped": list(c.dropped),
                    "unfilled": list(c.unfilled),
                    **({"omitted": True} if c.omitted else {}),
                    **({"preparatory": c.preparatory_calls()} if c.preparatory else {}),
                    **(
                        {"conversions": {m.target: m.conversion.template for m in c.mapping if m.conversion}}
                        if any(m.conversion for m in c.mapping)
                        else {}
                    ),
                    **({"path": [p.render() for p in c.path]} if c.path else {}),
                    **({"kept": dict(c.kept)} if c.kept else {}),
                }
                for c in self.conflicts
            ],
            "warnings": sorted(
                f"{w.span.line}:{w.primitive}:{w.kind}:{w.phase}"
                + (f":through {w.through}" if w.through is not None else "")
                for w in self.warnings
            ),
        }


def _value_map(source: tuple | None, target: tuple | None) -> tuple[tuple[object, object], ...]:
    """Same role, different literal vocabularies of equal size (``'z'`` ↔ ``'down'``): map them in order."""
    if not source or not target or tuple(source) == tuple(target) or len(source) != len(target):
        return ()
    return tuple(zip(source, target, strict=True))


def diagnose(
    onto: Ontology,
    skill_name: str,
    code: str,
    robot: str,
    source: str = "Panda",
    placements: Mapping[str, str] | None = None,
) -> Diagnosis:
    """D(skill, robot) = ⟨determined conflicts, undetermined warnings⟩ — no LM involved.

    ``placements``: what the skill's metadata says each object it moves ends over (parameter to
    parameter, for an object with one placement). Where no one position places a place's release
    point, the object the hand holds there ends over that one: the receptacle a place by name takes.
    """
    source_api, target_api = onto.api(source), onto.api(robot)
    sites = [s for s in call_sites(code, skill_name) if source_api.get(s.name) is not None]
    bindings, names = position_bindings(code), position_names(code)
    holds = held_along(
        [(source_api.get(s.name), dict(s.arguments)) for s in sites],
        lambda param, text: text if param.type == OBJECT_NAME else names.of(text),
    )
    conflicts, warnings = [], []
    pressed = _pressed_deeper(onto, source, robot, sites)
    for site, held in zip(sites, holds, strict=True):
        original = source_api.get(site.name)
        target, conflict = target_api.get(site.name), None
        if target is not None and not _same_signature(original, target):
            target = None  # the same name, another interface (the two Panda APIs' picks: a position, a name)
        if target is None:
            held_at = None if held is None else (held[0], sites[held[1]].span.line)
            site_names, declared = _declared_release(original, site, names, held, placements or {})
            conflict = _conflict(onto, site, original, source, robot, site_names, sites, held, pressed)
            conflict = replace(conflict, held=held_at, by_placements=declared)
            conflicts.append(conflict)
            target = conflict.substitute
        if target is not None:
            warnings += _warnings(onto, site, original, target, source, robot, sites, bindings)
        if conflict is not None and any(not step.actuate for step in conflict.path):
            warnings.append(_approach_warning(onto, site, conflict))
            if any(step.actuate for step in conflict.path):
                warnings += _traced_warnings(onto, site, original, conflict, source, robot, sites, bindings)
    return Diagnosis(skill=skill_name, robot=robot, conflicts=tuple(conflicts), warnings=tuple(warnings))


def _declared_release(
    original: PrimitiveSpec,
    site: CallSite,
    names: PositionNames,
    held: tuple[str, int] | None,
    placements: Mapping[str, str],
) -> tuple[PositionNames, str]:
    """``names``, where the skill declares where the object the hand holds at a place ends, with the
    place's release point naming that object (a drop point two objects place, over the bin), and
    the point's parameter (empty where nothing was declared); a point that one object's position
    places keeps naming that object."""
    point = original.by_role(RELEASE_POINT)
    over = placements.get(held[0]) if held is not None else None
    expression = dict(site.arguments).get(point.name) if point is not None else None
    if over is None or expression is None or names.of(expression) is not None:
        return names, ""
    return replace(names, declared={**names.declared, expression: over}), point.name


def _same_signature(original: PrimitiveSpec, target: PrimitiveSpec) -> bool:
    """Whether a call of ``original`` runs unchanged as ``target``: the same parameters, as the same types."""
    return [(p.name, p.type) for p in original.parameters] == [(p.name, p.type) for p in target.parameters]


def _conflict(
    onto: Ontology,
    site: CallSite,
    original: PrimitiveSpec,
    source: str,
    robot: str,
    names: PositionNames,
    sites: Sequence[CallSite],
    held: tuple[str, int] | None,
    pressed: float = 0.0,
) -> Conflict:
    candidates = onto.substitutes(source, site.name, robot)
    if candidates and _shaping_only(onto.api(source), original, candidates, sites):
        substitute = min(candidates, key=lambda c: c.name)
        return Conflict(
            span=site.span,
            span_type="api_substitution",
            original=site.name,
            substitute=None,
            omitted=True,
            reason=(
                f"{site.name} only closes the hand to push or press with (nothing in the skill opens or releases it); "
                f"{robot} has no fingers to close, and {substitute.name} would hold whatever it touches: "
                "the call is dropped"
            ),
        )
    by_name = candidates and not any(c.by_role(RELEASE_POINT) for c in candidates)  # a place that takes no point
    if by_name and (back := _put_back(original, site, names, held)):
        why = f"{site.name} puts {back} back at its own earlier point, where no object is to put it on by name"
        return _traced_place(onto, site, original, robot, why) or _refused(
            site, f"{why}; {robot} places only onto a named object and has no move to trace the place with"
        )
    if by_name and (beside := _beside(original, site, names)):
        why = f"{site.name} lets go beside {beside}'s centre, where a place by name would not"
        if traced := _traced_place(onto, site, original, robot, why):
            return traced  # else the place by name stays: over the centre is the nearest it gets
    tracers = onto.path_tracers(source, site.name, robot) if not candidates else []
    if tracers:
        return _path_conflict(onto, site, original, tracers[0], robot)
    if not candidates:
        return _refused(
            site, f"{robot} has no primitive with the effects of {site.name} ({', '.join(sorted(original.effects))})"
        )
    substitute = min(candidates, key=lambda c: (len(c.preconditions - original.preconditions), c.name))
    given = dict(site.arguments)
    mapping, dropped, lowered = [], [], False
    for param in original.parameters:
        target = substitute.by_role(param.role) or _named_by_point(param, substitute, given, names)
        if target is None:
            dropped.append(param.name)
        else:
            values, converted = _value_map(param.choices, target.choices), _converted(param, target, given, names)
            if pressed and param.role == PATH_ROLE and converted is None:
                converted = _pressed_point(given.get(param.name), names, pressed)
                lowered = lowered or converted is not None
            mapping.append(ParameterMapping(param.name, target.name, param.role, values, converted))
    mapping += _also_named(original, substitute, mapping, given, names)
    located = _located(original, substitute, mapping, given)
    mapping += located
    dropped = [name for name in dropped if name not in {m.source for m in located}]
    preparatory, arguments = _preparatory_steps(onto, original, substitute, robot, dropped, given, names)
    taken = {m.source for args in arguments for m in args}
    dropped = [name for name in dropped if name not in taken]
    # required and mapped from nothing, or from an argument that does not determine it (a position for a pose)
    undetermined = {m.target for m in mapping if m.conversion and not m.conversion.determined and m.source in given}
    kept = _time_kept(original, substitute, given)
    mapped = ({m.target for m in mapping} - undetermined) | {name for name, _ in kept}
    unfilled = tuple(p.name for p in substitute.parameters if p.required and p.name not in mapped) + tuple(
        m.target for args in arguments for m in args if m.conversion and not m.conversion.determined
    )
    translated = kept or any((m.values or m.conversion) and m.source in given for m in mapping)
    if unfilled:
        span_type = "interface_rewiring"  # the new interface needs an argument the old call never had
    elif preparatory:
        span_type = "preparatory_step"  # the substitute needs a state another primitive establishes first
    elif translated:
        span_type = "parameter_binding"  # same role, other vocabulary ('z' -> 'down') or units, frame, rotation
    else:
        span_type = "api_substitution"
    conflict = Conflict(
        span=site.span,
        span_type=span_type,
        original=site.name,
        substitute=substitute,
        mapping=tuple(mapping),
        dropped=tuple(dropped),
        unfilled=unfilled,
        preparatory=preparatory,
        preparatory_arguments=arguments if any(arguments) else (),
        kept=kept,
    )
    after = f", after {', '.join(_described(conflict))}" if preparatory else ""
    way = "lower" if pressed > 0 else "higher"
    deeper = (
        f"; its point {abs(pressed) * 1000:g} mm {way}: {robot}'s tool presses as deep as {source}'s" if lowered else ""
    )
    time = "".join(f"; {name}={value}: the seconds {site.name} gave its motion" for name, value in kept)
    return replace(conflict, reason=f"no {site.name}; use {substitute.name} (same effects){after}{deeper}{time}")


def _time_kept(original: PrimitiveSpec, substitute: PrimitiveSpec, given: dict) -> tuple[tuple[str, str], ...]:
    """The time the original call gave its motion, where the substitute's default gives less: the
    skill's moves were written for that time (a Franka Hand's 31 cm sweep within its move's 6 s; a
    UR5e's move gives up after 3 s, 1 cm short). A timeout the call states is mapped like any other
    argument, and a substitute's longer default is left as it is (a slower arm keeps its own)."""
    target, source = substitute.by_role(TIMEOUT_ROLE), original.by_role(TIMEOUT_ROLE)
    allowed = original.time_allowed()
    if target is None or allowed is None or (source is not None and source.name in given):
        return ()
    if isinstance(target.default, int | float) and allowed <= target.default:
        return ()
    return ((target.name, repr(float(allowed))),)


def _pressed_deeper(onto: Ontology, source: str, robot: str, sites: Sequence[CallSite]) -> float:
    """Metres the target's tool must go lower than the source's grip site went, to touch where the
    source's closed fingertips touched: where the skill closes the hand only to push or press with,
    and the target's tool takes no shape (the call is dropped), each declaring how far its lowest
    point lies below its grip site. 0 where either is undeclared, or nothing is dropped so."""
    source_api, target_api = onto.api(source), onto.api(robot)
    if source_api.tool_tip_m is None or target_api.tool_tip_m is None:
        return 0.0
    for site in sites:
        original, target = source_api.get(site.name), target_api.get(site.name)
        if original is None or (target is not None and _same_signature(original, target)):
            continue  # not a call of the source's, or one the target makes as it is
        candidates = onto.substitutes(source, site.name, robot)
        if candidates and _shaping_only(source_api, original, candidates, sites):
            return round(source_api.tool_tip_m - target_api.tool_tip_m, 4)
    return 0.0


def _pressed_point(expression: str | None, names: PositionNames, deeper: float) -> Conversion | None:
    """A point straight over a named object (``[cap_pos[0], cap_pos[1], cap_pos[2] + 0.01]``), its
    height ``deeper`` lower: a fist brought down onto an object presses it with its lowest point, and
    a tool whose lowest point sits nearer its grip site must go that much lower to press as deep.
    Points beside an object (a sweep's start, a push's goal) keep their height. The conversion is
    the whole new argument (a template with no hole for the source's)."""
    node = parse_expression(expression)
    if node is None or "\n" in expression or names.straight_over(node) is None:
        return None
    end = node.elts[2].end_col_offset
    sign = "-" if deeper > 0 else "+"
    return Conversion(f"{expression[:end]} {sign} {abs(deeper):g}{expression[end:]}")


def _described(conflict: Conflict) -> list[str]:
    """Each preparatory call in words for a hint: ``move_gripper_to over what place's target_pos names``.
    Written as a call (``move_gripper_to(obj_name=target_pos)``), the 1.5B copied ``target_pos``, a
    parameter of the original, not a variable of the skill."""
    arguments = conflict.preparatory_arguments or ((),) * len(conflict.preparatory)
    out = []
    for name, args in zip(conflict.preparatory, arguments, strict=True):
        sources = [m.source for m in args if m.source]
        out.append(name + (f" over what {conflict.original}'s {' and '.join(sources)} names" if sources else ""))
    return out


# Closing the fingers with nothing opened or released anywhere in the skill shapes the hand for contact
# (a fist that pushes, presses or sweeps): no object is held. An end effector whose counterpart engages
# objects on contact instead (suction) has no shape to take, and making that call would pick up what the
# push touches.
SHAPES_HAND = "close_fingers"
ENGAGES_ON_CONTACT = "activate_suction"
LETS_GO = frozenset({"open_fingers", "release_object", "detach_object", "deactivate_suction"})


def _shaping_only(
    source_api: ApiSpec, original: PrimitiveSpec, candidates: list[PrimitiveSpec], sites: Sequence[CallSite]
) -> bool:
    """Whether the call only shapes the hand (see ``SHAPES_HAND``), onto a robot whose counterpart
    would grip on contact instead."""
    if SHAPES_HAND not in original.capabilities or original.effects - {"end_effector_engaged"}:
        return False
    if not all(ENGAGES_ON_CONTACT in c.capabilities and SHAPES_HAND not in c.capabilities for c in candidates):
        return False
    called = (source_api.get(s.name) for s in sites)
    return not any(spec is not None and spec.capabilities & LETS_GO for spec in called)


OMITTED = "pass"  # how a dropped call is rendered: a statement, so that any block around it stays one


def _path_conflict(
    onto: Ontology, site: CallSite, original: PrimitiveSpec, move: PrimitiveSpec, robot: str
) -> Conflict:
    """No primitive does what the call does, but the robot can move its end effector along the
    call's path: one move per waypoint and one call per actuation step (a pick closes the hand
    between its descent and its lift), after the steps that establish the call's other robot-state
    effects (a closed hand for a push) where those are decidable before execution."""
    api, point = onto.api(robot), move.by_role(PATH_ROLE)
    steps = tuple(
        PathStep("", actuate=api.actuator(w.effect).name) if w.actuation else _path_step(source, w.offset, point)
        for w in original.path
        if w.actuation or (source := original.by_role(w.role)) is not None
    )
    actuated = set().union(*(api.actuator(w.effect).effects for w in original.path if w.actuation))
    undetermined = any(s.conversion and not s.conversion.determined for s in steps)
    decidable = [
        p
        for p in onto.api(robot).primitives
        if not any(q.required for q in p.parameters)
        and all(onto.conditions[c].kind == "robot" for c in p.preconditions)
    ]
    missing = sorted(c for c in original.effects - move.effects - actuated if onto.conditions[c].kind == "robot")
    preparatory = tuple(
        dict.fromkeys(p.name for c in missing if (p := next((q for q in decidable if c in q.effects), None)))
    )
    used = {s.source for s in steps if not s.actuate}
    # a path that only actuates (a handle let go where the hand is) is that actuator's call
    substitute = move if used or not steps else api.get(steps[-1].actuate)
    return Conflict(
        span=site.span,
        span_type="path_tracing",
        original=site.name,
        substitute=substitute,
        dropped=tuple(p.name for p in original.parameters if p.name not in used),
        preparatory=preparatory,
        path=steps,
        unfilled=(point.name,) if undetermined else (),
        reason=f"no primitive with the effects of {site.name}; trace its path with {substitute.name}"
        + (f", after {', '.join(preparatory)}" if preparatory else ""),
    )


def _path_step(source: ParameterSpec, offset: tuple[float, float, float], point: ParameterSpec) -> PathStep:
    """A move to the source argument's point plus ``offset``: a name is looked up first (the offset is
    in the world), then the point converted to what the move takes."""
    if source.type == OBJECT_NAME:
        return PathStep(source.name, offset, conversion(WORLD_POSITION, point), lookup=NAME_LOOKUP)
    return PathStep(source.name, offset, conversion(source, point))


def _approach_warning(onto: Ontology, site: CallSite, conflict: Conflict) -> Warning:
    """A traced path is several statements: the object may move while the hand approaches it, and
    between those statements that can be checked — before each one up to the contact point."""
    contact = next((i for i, step in enumerate(conflict.path) if not step.actuate and not any(step.offset)), 0)
    spec = onto.conditions["object_at_target"]
    message = "the object may move while the hand approaches it along the traced path"
    through = len(conflict.preparatory) + contact
    return Warning(
        "object_at_target", site.span, conflict.substitute.name, spec.check, spec.observation, message, through=through
    )


def _traced_warnings(onto, site, original, conflict, source, robot, sites, bindings) -> list[Warning]:
    """A pick or place traced as moves and gripper calls still has the original call's preconditions
    to check (fingers clear of a neighbour, the target clear): before each move up to the contact
    point, reading the move's point as the original's grasp or release target. A traced grasp's
    hold is read once its last statement (the lift) has run, as a pick's is: traced on a KRL arm, a
    grasp that closed on nothing went unnoticed until the task's end."""
    contact = next((i for i, step in enumerate(conflict.path) if not step.actuate and not any(step.offset)), None)
    if contact is None:
        return []  # a path that never reaches its target point: nothing there to check
    point, role = conflict.substitute.by_role(PATH_ROLE), original.parameter(conflict.path[contact].source).role
    through = len(conflict.preparatory) + contact
    lifted, last = (
        len(conflict.preparatory) + len(conflict.path) - 1,
        conflict.path[-1].actuate or conflict.substitute.name,
    )
    kept = {"object_at_target"}  # the approach warning checks that one already
    out = []
    for w in _warnings(onto, site, original, original, source, robot, sites, bindings):
        if w.phase == "before" and w.kind not in kept:
            kept.add(w.kind)
            out.append(replace(w, primitive=conflict.substitute.name, through=through, roles=((point.name, role),)))
        elif w.phase == "after" and w.kind == GRASPED:  # a traced place's outcome is the skill's placements'
            out.append(replace(w, primitive=last, through=lifted))
    return out


def _preparatory_steps(
    onto: Ontology,
    original: PrimitiveSpec,
    substitute: PrimitiveSpec,
    robot: str,
    dropped: list[str],
    given: dict[str, str],
    names: PositionNames,
) -> tuple[tuple[str, ...], tuple[tuple[ParameterMapping, ...], ...]]:
    """Robot-state preconditions the substitute adds, each with a target primitive whose effects
    establish it, and the original call's arguments that primitive takes: each required parameter
    from an argument the substitute dropped, of a type that becomes it (a receptacle's name for a
    move over it). One that nothing gives stays open, for the LM."""
    steps, arguments = [], []
    for cond in sorted(substitute.preconditions - original.preconditions):
        if onto.conditions[cond].kind != "robot":
            continue  # runtime conditions become warnings instead
        provider = next((p for p in onto.api(robot).primitives if cond in p.effects and p is not substitute), None)
        if provider is None:
            continue
        mapping = []
        for param in (q for q in provider.parameters if q.required):
            source = next(
                (
                    s
                    for s in (original.parameter(n) for n in dropped)
                    if s is not None and s.name in given and {s.type, param.type} <= _POINTS_OR_NAMES
                ),
                None,
            )
            if source is None:
                mapping.append(ParameterMapping("", param.name, param.role, (), Conversion(f"<{param.type}>")))
            else:
                converted = _converted(source, param, given, names)
                mapping.append(ParameterMapping(source.name, param.name, param.role, (), converted))
        steps.append(provider.name)
        arguments.append(tuple(mapping))
    return tuple(steps), tuple(arguments)


_POINTS_OR_NAMES = {OBJECT_NAME, "position", "pose"}  # what designates where something is


def _converted(
    source: ParameterSpec, target: ParameterSpec, given: dict[str, str], names: PositionNames
) -> Conversion | None:
    """How the argument becomes the target's value: as the two parameters convert, except that a
    position read from the task (``obj_pos = task.get_object_position(obj)``), or a point placed by
    one such position alone (``[bin_pos[0], bin_pos[1], bin_pos[2] + 0.1]``), names its object,
    where the target takes a name."""
    converted = conversion(source, target)
    if target.type == OBJECT_NAME and source.type == "position" and (name := names.of(given.get(source.name))):
        return Conversion(name)
    return converted


GRASPED = "object_grasped"  # the effect a grasp leaves: the object held (checked as object_held)
# preconditions on positions a skill read: uncertain once the robot moved after the read (the object may have too)
MOVABLE_READS = frozenset({"object_at_target", "support_unmoved"})
TARGET_UNMOVED = "target_unmoved"  # a move's: only at the read's first use after a motion (_first_use_after_motion)
RELEASE_POINT = "release_target"  # the role of the point a place lets go at


def _refused(site: CallSite, reason: str) -> Conflict:
    """A call this robot cannot make in any form: no substitute, no path to trace (named before anything runs)."""
    return Conflict(span=site.span, span_type="api_substitution", original=site.name, substitute=None, reason=reason)


def _traced_place(onto: Ontology, site: CallSite, original: PrimitiveSpec, robot: str, why: str) -> Conflict | None:
    """A place whose release point no place by name can keep (a put-back, a corner of the bin),
    traced with the robot's moves and its opening; None where it has no move to trace it with."""
    moves = tracing_moves(onto.api(robot), original)
    if not moves:
        return None
    traced = _path_conflict(onto, site, original, moves[0], robot)
    return replace(traced, reason=f"{why}; trace its path with {moves[0].name}")


def _beside(original: PrimitiveSpec, site: CallSite, names: PositionNames) -> str | None:
    """The object whose position places the call's release point beside, not straight over, its
    centre (:meth:`PositionNames.beside`: one corner of the bin each); None otherwise. A place by
    name lets go over the named object's centre, so it would drop that offset: four objects meant
    for four corners end in one pile in the middle. Where the robot has moves, the place is traced
    with them; else it stays a place by name."""
    point = original.by_role(RELEASE_POINT)
    if point is None or point.type != "position":
        return None
    return names.beside(dict(site.arguments).get(point.name))


def _put_back(
    original: PrimitiveSpec, site: CallSite, names: PositionNames, held: tuple[str, int] | None
) -> str | None:
    """The object the hand holds at ``site`` (``held``, as :func:`held_along` reads it) where the call's
    release point is placed by that object's own position, read before it was picked up (a rake put
    back where it stood); None otherwise. Such a point names no receptacle: a place by name has
    nothing to take."""
    point = original.by_role(RELEASE_POINT)
    if point is None or point.type != "position":
        return None
    named = names.of(dict(site.arguments).get(point.name))
    return named if named is not None and held is not None and named == held[0] else None


def _named_by_point(
    param: ParameterSpec, substitute: PrimitiveSpec, given: dict[str, str], names: PositionNames
) -> ParameterSpec | None:
    """The substitute's name-taking parameter that a point argument of ``param`` names (a place's
    drop point above the bin, for a place that takes the receptacle's name), where the point is
    placed by one object alone (:class:`PositionNames`); None otherwise, and the parameter stays
    for the LM."""
    named = substitute.by_role(NAMED_BY_POINT.get(param.role, ""))
    if named is None or named.type != OBJECT_NAME or param.type != "position":
        return None
    return named if names.of(given.get(param.name)) else None


def _located(
    original: PrimitiveSpec, substitute: PrimitiveSpec, mapping: list[ParameterMapping], given: dict[str, str]
) -> list[ParameterMapping]:
    """The way back from a name to a point: a substitute's point of a role :data:`NAMED_BY_POINT`
    pairs with a name role, which the original call gives by name (a Franka Hand ``place(obj_name=base)``
    onto a place at a point), is that object's position, converted as the point is taken. A release
    point that is a perceived object's own position puts the load onto it (the shared controllers'
    ``release_at``), so the receptacle's position is where to let go, however tall it is."""
    mapped = {m.target for m in mapping}
    found = []
    for param in substitute.parameters:
        named = original.by_role(NAMED_BY_POINT.get(param.role, "")) if param.type in POINTS else None
        if param.name in mapped or named is None or named.type != OBJECT_NAME or named.name not in given:
            continue
        found.append(ParameterMapping(named.name, param.name, param.role, (), conversion(named, param)))
        mapped.add(param.name)
    return found


def _also_named(
    original: PrimitiveSpec,
    substitute: PrimitiveSpec,
    mapping: list[ParameterMapping],
    given: dict[str, str],
    names: PositionNames,
) -> list[ParameterMapping]:
    """A substitute that takes the point *and* the name of what is there (Sawyer's pick:
    ``target_object`` beside ``target_pos``): where the point names one object
    (:class:`PositionNames`), that object is the name, so no LM is asked for it."""
    mapped = {m.target for m in mapping}
    extra = []
    for param in original.parameters:
        if not any(m.source == param.name for m in mapping):
            continue
        if param.type == OBJECT_NAME:  # the original call names the object itself (a Franka Hand pick)
            named = substitute.by_role(NAMED_BY_POINT.get(param.role, ""))
            named = named if named is not None and named.type == OBJECT_NAME else None
            conversion = None
        else:
            named = _named_by_point(param, substitute, given, names)
            conversion = Conversion(names.of(given.get(param.name))) if named is not None else None
        if named is not None and named.name not in mapped:
            extra.append(ParameterMapping(param.name, named.name, named.role, (), conversion))
            mapped.add(named.name)
    return extra


def _warnings(onto, site, original, target, source, robot, sites, bindings) -> list[Warning]:
    """Runtime conditions of the primitive this call will run as, where this robot or this code makes them uncertain."""
    vocab, out = onto.conditions, []

    def warn(cond: str, phase: str = "before") -> None:
        spec = vocab[cond]
        check, observation, message = (
            spec.as_effect if phase == "after" and spec.as_effect else (spec.check, spec.observation, spec.message)
        )
        out.append(Warning(cond, site.span, target.name, check, observation, message, phase))

    for cond in sorted(target.preconditions):
        if vocab[cond].kind != "runtime":
            continue
        if vocab[cond].always:
            warn(cond)  # the world decides, whatever the robot: e.g. something landed on the target
        elif cond not in original.preconditions:
            warn(cond)  # new on this robot: e.g. a suction cup needs a flat, sealable top face
        elif cond in {"target_reachable", "handle_reachable"} and onto.arms[robot].reach < onto.arms[source].reach:
            warn(cond)  # a smaller workspace than the one the skill was validated in
        elif cond == TARGET_UNMOVED and _first_use_after_motion(site, sites, bindings):
            warn(cond)  # a motion target from a read that no step since has used: moved in between?
        elif cond in MOVABLE_READS and _read_before_earlier_motion(site, sites, bindings):
            warn(cond)  # the position was read, then the robot moved: the object may have too
    for cond in sorted(target.effects):
        if vocab[cond].kind != "runtime":
            continue
        if vocab[cond].always or vocab[cond].as_effect:
            warn(cond, phase="after")  # the world decides whether the effect happened: e.g. a push
        elif cond == GRASPED and onto.grippers[robot] != onto.grippers[source]:
            warn(cond, phase="after")  # another end effector: will the grasp hold?
    return out


def _read_before_earlier_motion(site: CallSite, sites: list[CallSite], bindings) -> bool:
    used = [b for name, b in bindings.items() if any(_mentions(text, name) for _, text in site.arguments)]
    return any(_calls_between(b, site, sites) for b in used)


def _calls_between(binding, site: CallSite, sites: list[CallSite]) -> list[CallSite]:
    """The calls that run after ``binding``'s read and before ``site``."""
    return [s for s in sites if binding.offset < s.span.start < site.span.start]


def _first_use_after_motion(site: CallSite, sites: list[CallSite], bindings) -> bool:
    """The call uses a read that calls ran after and that none of them used: the drag's first move
    beyond the cube, after the rake was picked. Its later moves are where the robot itself moves the
    object (the drag, a press, a carry): a drift there is the step's effect, not a stale read."""
    for name, binding in bindings.items():
        if not any(_mentions(text, name) for _, text in site.arguments):
            continue
        between = _calls_between(binding, site, sites)
        if between and not any(_mentions(text, name) for s in between for _, text in s.arguments):
            return True
    return False


def _mentions(text: str, name: str) -> bool:
    return any(token == name for token in _IDENT.findall(text))


_IDENT = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")
