"""Primitive-API metadata files: parsed into typed specs, every error naming file and field."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from lerobot_policy_recent.descriptions.embodiments import read_yaml
from lerobot_policy_recent.descriptions.frames import ARM_BASE, LENGTH_UNITS, WORLD

PATH_CAPABILITY, PATH_ROLE = "cartesian_motion", "motion_target"  # a move to a point, and that point
TIMEOUT_ROLE = "timeout"  # how long a call gives its motion before it fails
PARAM_TYPES = ("position", "quaternion", "rotvec", "euler", "pose", "float", "int", "str", "bool", "object_name")
# what a parameter is for: the ontology pairs a source call's argument with the target's parameter of the same
# role, so a role outside this vocabulary would match nothing (a typo silently changes the grounding)
PARAMETER_ROLES = frozenset(
    {
        "grasp_target", "grasp_object_name", "release_target", "release_receptacle", "motion_target",
        "motion_offset", "motion_axis", "approach_direction", "approach_object_name", "handle_target",
        "push_start", "push_goal", "target_orientation", "yaw_angle", "opening_fraction", "closing_fraction",
        "actuation_speed", "duration_steps", "timeout",
    }
)  # fmt: skip
# What each role of a parameter means, in the words hints and validation messages use.
ROLE_MEANINGS = {
    "grasp_target": "what the hand grasps (or where)",
    "grasp_object_name": "the object the hand grasps",
    "release_target": "where the hand puts down the object it holds (the point it lowers it to; "
    "an object's own position puts it onto that object)",
    "release_receptacle": "what the held object is put on or into",
    "motion_target": "where the hand moves to",
    "approach_object_name": "what the hand moves over (with the object it holds)",
    "handle_target": "the handle the hand takes hold of",
    "push_start": "where the push starts",
    "push_goal": "where the push ends",
    "target_orientation": "the orientation the tool turns to",
}
# A point argument of the first role, placed by one object alone, names that object for a parameter of
# the second: a position-based place's drop point above the bin names the bin a name-based place takes;
# the point a pick grasps at names the object a pick that takes both (Sawyer's) is told to expect.
NAMED_BY_POINT = {"release_target": "release_receptacle", "grasp_target": "grasp_object_name"}
# what a call holds from then on (by name, or the object its point names), what receives a held object,
# and the effects that end a hold: which object the hand holds at each call, read along the skill
HOLDING_ROLES = frozenset({"grasp_target", "grasp_object_name", "handle_target"})
RECEIVING_ROLES = frozenset({"release_receptacle", "approach_object_name"})
RELEASING_EFFECTS = frozenset({"object_released", "end_effector_free"})
# what the vectors of a controller mean (ontology/conversions.py renders between them): lengths in
# m, cm or mm; an axis-angle rotation vector in rad; Euler angles in deg or rad about a named axis
# sequence (scipy's: "ZYX" intrinsic, "xyz" extrinsic); a pose is URScript's [x, y, z, rx, ry, rz]
UNITS = {"position": tuple(LENGTH_UNITS), "pose": tuple(LENGTH_UNITS), "rotvec": ("rad",), "euler": ("deg", "rad")}
DEFAULT_UNITS = {"position": "m", "pose": "m", "rotvec": "rad"}  # Euler angles must say deg or rad
EULER_AXES = frozenset("xyzXYZ")
WORLD_FRAME, FRAME_ORIGINS = WORLD, (WORLD, ARM_BASE)


class SpecError(ValueError):
    """A metadata file is malformed; the message names the file and the field."""

    def __init__(self, path: Path | str, where: str, problem: str):
        super().__init__(f"{path}: {where}: {problem}")
        self.path = str(path)
        self.where = where


@dataclass(frozen=True)
class ParameterSpec:
    name: str
    type: str
    role: str
    required: bool = False
    default: Any = None
    unit: str | None = None
    frame: str | None = None
    range: tuple[float, float] | None = None
    choices: tuple[Any, ...] | None = None
    sequence: str | None = None  # Euler angles: the axis sequence

    def render(self) -> str:
        """``name: type [unit]``, ``name: type = default``, or with the facts a conversion needs:
        ``pose: pose [m, frame base]``, ``abc: euler [deg, ZYX]`` — how hints show a parameter."""
        facts = [f for f in (self.unit, *self.conversion_facts()) if f]
        unit = f" [{', '.join(facts)}]" if facts else ""
        default = "" if self.required else f" = {self.default!r}"
        return f"{self.name}: {self.type}{unit}{default}"

    def conversion_facts(self) -> tuple[str, ...]:
        """What sets this value apart from a world-frame one: its frame, its Euler sequence."""
        frame = (f"frame {self.frame}",) if self.frame and self.frame != WORLD_FRAME else ()
        return frame + ((self.sequence,) if self.sequence else ())


@dataclass(frozen=True)
class Waypoint:
    """One step of the path a primitive moves the end effector along: a position parameter's value
    (named by role) plus a fixed offset in metres, world frame; or, with ``effect``, the robot state
    the hand establishes at that point of the path (a pick closes its fingers between the descent
    and the lift: ``end_effector_engaged``)."""

    role: str = ""
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    effect: str = ""  # an actuation step: a parameterless primitive of the robot with this effect

    @property
    def actuation(self) -> bool:
        return bool(self.effect)


@dataclass(frozen=True)
class PrimitiveSpec:
    name: str
    embodiment: str
    description: str
    parameters: tuple[ParameterSpec, ...]
    capabilities: frozenset[str]
    preconditions: frozenset[str]
    effects: frozenset[str]
    # where the end effector goes, in order: a robot without a primitive of the same effects can
    # trace it with its Cartesian moves (a push is a path, whatever hand pushes)
    path: tuple[Waypoint, ...] = ()
    # how long its motion runs before it fails where no parameter sets that (a Franka Hand's move: 6 s)
    time_limit_s: float | None = None

    def parameter(self, name: str) -> ParameterSpec | None:
        return next((p for p in self.parameters if p.name == name), None)

    def by_role(self, role: str) -> ParameterSpec | None:
        return next((p for p in self.parameters if p.role == role), None)

    def time_allowed(self) -> float | None:
        """How long a call that states no timeout gives its motion: its timeout parameter's default,
        else the limit the primitive declares (None where neither is known)."""
        timeout = self.by_role(TIMEOUT_ROLE)
        if timeout is not None and _number(timeout.default):
            return float(timeout.default)
        return self.time_limit_s

    def signature(self) -> str:
        """Typed signature, e.g. ``ur5_grasp_at(env, task, grasp_pos: position [m], timeout_s: float [s] = 5.0)``."""
        params = ", ".join(["env", "task", *(p.render() for p in self.parameters)])
        return f"{self.name}({params})"


@dataclass(frozen=True)
class FrameSpec:
    """A frame a controller's values are given in: at the world origin or at the arm's base, turned
    by fixed-axis roll, pitch, yaw in degrees (URScript's base frame faces the arm's back: yaw 180)."""

    name: str
    origin: str
    rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ApiSpec:
    embodiment: str
    module: str
    path: Path
    primitives: tuple[PrimitiveSpec, ...] = field(default_factory=tuple)
    frames: tuple[FrameSpec, ...] = ()  # besides the world
    # how far the tool's lowest point lies below its grip site, pointing down (metres; None: not declared):
    # where a fist presses with its tip, another tool keeps that point, not the grip site
    tool_tip_m: float | None = None

    def names(self) -> list[str]:
        return [p.name for p in self.primitives]

    def get(self, name: str) -> PrimitiveSpec | None:
        return next((p for p in self.primitives if p.name == name), None)

    def providing(self, capability: str) -> PrimitiveSpec | None:
        """The first primitive with ``capability`` (the robot's push, its yaw turn), or None."""
        return next((p for p in self.primitives if capability in p.capabilities), None)

    def actuator(self, effect: str) -> PrimitiveSpec | None:
        """A primitive that takes no argument and establishes ``effect`` (a gripper's close or open):
        what performs an actuation step of a traced path. The one with the fewest preconditions: a
        vacuum's switch, not its detach (which needs the cup over a receptacle and lowers the load)."""
        actuators = [p for p in self.primitives if effect in p.effects and not any(q.required for q in p.parameters)]
        return min(actuators, key=lambda p: len(p.preconditions), default=None)

    def point_moves(self) -> list[PrimitiveSpec]:
        """Primitives that move the end effector to a given point: what can trace a declared path."""
        return [p for p in self.primitives if PATH_CAPABILITY in p.capabilities and _point(p) is not None]


@dataclass(frozen=True)
class ConditionSpec:
    name: str
    kind: str  # "robot" (decided before execution) or "runtime" (an undetermined warning)
    check: str | None = None
    observation: str | None = None
    message: str | None = None
    excludes: frozenset[str] = frozenset()
    always: bool = False  # uncertain in any world: warned for every robot, the source robot included
    # as a primitive's effect, checked once it has run, for every robot: (check, observation, message)
    as_effect: tuple[str, str, str] | None = None


CONDITIONS_PATH = Path(__file__).with_name("conditions.yaml")
TOOL_TIP_KEY = "tool_tip_below_site_m"  # an API file's optional top-level key (ApiSpec.tool_tip_m)
MAX_TOOL_TIP_M = 0.3


def load_conditions(path: Path | str = CONDITIONS_PATH) -> dict[str, ConditionSpec]:
    path = Path(path)
    data = _load_yaml(path)
    raw = _require(data, "conditions", dict, path, "top level")
    conditions = {}
    for name, item in raw.items():
        where = f"conditions.{name}"
        if not isinstance(item, dict):
            raise SpecError(path, where, "must be a mapping with at least 'kind'")
        kind = _require(item, "kind", str, path, where)
        if kind not in {"robot", "runtime"}:
            raise SpecError(path, f"{where}.kind", f"must be 'robot' or 'runtime', got {kind!r}")
        if kind == "runtime":
            for key in ("check", "observation", "message"):
                _require(item, key, str, path, where)
        conditions[name] = ConditionSpec(
            name=name,
            kind=kind,
            check=item.get("check"),
            observation=item.get("observation"),
            message=item.get("message"),
            excludes=frozenset(_str_list(item, "excludes", path, where) if "excludes" in item else ()),
            always=_flag(item, "always", path, where),
            as_effect=_as_effect(item, path, where),
        )
    for cond in conditions.values():
        for other in cond.excludes:
            if other not in conditions:
                raise SpecError(path, f"conditions.{cond.name}.excludes", f"unknown condition {other!r}")
            if cond.name not in conditions[other].excludes:
                raise SpecError(
                    path, f"conditions.{cond.name}.excludes", f"{other!r} does not exclude {cond.name!r} back"
                )
    return conditions


def _as_effect(item: dict, path: Path, where: str) -> tuple[str, str, str] | None:
    """``as_effect: {check, observation, message}``: how the condition is checked after a primitive that produces it."""
    if "as_effect" not in item:
        return None
    effect = item["as_effect"]
    if not isinstance(effect, dict):
        raise SpecError(path, f"{where}.as_effect", "must be a mapping with 'check', 'observation' and 'message'")
    return tuple(_require(effect, key, str, path, f"{where}.as_effect") for key in ("check", "observation", "message"))


def _flag(item: dict, key: str, path: Path, where: str) -> bool:
    value = item.get(key, False)
    if not isinstance(value, bool):
        raise SpecError(path, f"{where}.{key}", f"must be true or false, got {value!r}")
    return value


def check_against_vocabulary(api: ApiSpec, conditions: dict[str, ConditionSpec]) -> None:
    """Every condition must be known, and no list may hold two conditions that exclude each other."""
    for i, prim in enumerate(api.primitives):
        for k, step in enumerate(prim.path):
            if step.actuation and step.effect not in conditions:
                raise SpecError(
                    api.path, f"primitives[{i}] ({prim.name}).path[{k}].effect", f"unknown condition {step.effect!r}"
                )
        for field_name in ("preconditions", "effects"):
            values = getattr(prim, field_name)
            where = f"primitives[{i}] ({prim.name}).{field_name}"
            unknown = sorted(values - conditions.keys())
            if unknown:
                raise SpecError(
                    api.path,
                    where,
                    f"unknown condition(s) {unknown}; add them to {CONDITIONS_PATH.name} (known: {', '.join(sorted(conditions))})",
                )
            for name in sorted(values):
                clash = sorted(conditions[name].excludes & values)
                if clash:
                    raise SpecError(api.path, where, f"contradiction: {name!r} and {clash[0]!r} cannot both hold")


def _load_yaml(path: Path) -> dict:
    try:
        data = read_yaml(path)
    except FileNotFoundError:
        raise SpecError(path, "file", "does not exist") from None
    except yaml.YAMLError as exc:
        raise SpecError(path, "file", f"not valid YAML ({exc})") from None
    if not isinstance(data, dict):
        raise SpecError(path, "file", "top level must be a mapping")
    return data


def load_api_spec(path: Path | str) -> ApiSpec:
    path = Path(path)
    data = _load_yaml(path)
    embodiment = _require(data, "embodiment", str, path, "top level")
    module = _require(data, "module", str, path, "top level")
    raw = _require(data, "primitives", list, path, "top level")
    frames = _parse_frames(data.get("frames", {}), path)
    tip = data.get(TOOL_TIP_KEY)
    if tip is not None and not (_number(tip) and 0.0 <= tip <= MAX_TOOL_TIP_M):
        raise SpecError(path, TOOL_TIP_KEY, f"must be metres from 0 to {MAX_TOOL_TIP_M}, got {tip!r}")
    primitives = []
    seen: set[str] = set()
    for i, item in enumerate(raw):
        prim = _parse_primitive(item, embodiment, path, f"primitives[{i}]")
        if prim.name in seen:
            raise SpecError(path, f"primitives[{i}].name", f"duplicate primitive {prim.name!r}")
        seen.add(prim.name)
        primitives.append(prim)
        _check_frames(prim, {f.name for f in frames}, path, f"primitives[{i}] ({prim.name})")
    return ApiSpec(
        embodiment=embodiment,
        module=module,
        path=path,
        primitives=tuple(primitives),
        frames=frames,
        tool_tip_m=None if tip is None else float(tip),
    )


def _parse_frames(raw: Any, path: Path) -> tuple[FrameSpec, ...]:
    """``frames: {base: {origin: arm_base, rpy_deg: [0, 0, 180]}}``."""
    if not isinstance(raw, dict):
        raise SpecError(path, "frames", "must be a mapping of frame name to {origin, rpy_deg}")
    frames = []
    for name, item in raw.items():
        where = f"frames.{name}"
        if name == WORLD_FRAME:
            raise SpecError(path, where, "the world frame is built in; name yours otherwise")
        if not isinstance(item, dict):
            raise SpecError(path, where, "must be a mapping with 'origin' (and an optional 'rpy_deg')")
        origin = _require(item, "origin", str, path, where)
        if origin not in FRAME_ORIGINS:
            raise SpecError(path, f"{where}.origin", f"must be one of {', '.join(FRAME_ORIGINS)}, got {origin!r}")
        rpy = item.get("rpy_deg", [0.0, 0.0, 0.0])
        if not (isinstance(rpy, list) and len(rpy) == 3 and all(_number(v) for v in rpy)):
            raise SpecError(
                path, f"{where}.rpy_deg", f"must be three numbers [roll, pitch, yaw] in degrees, got {rpy!r}"
            )
        frames.append(FrameSpec(str(name), origin, tuple(float(v) for v in rpy)))
    return tuple(frames)


def _check_frames(prim: PrimitiveSpec, declared: set[str], path: Path, where: str) -> None:
    for j, param in enumerate(prim.parameters):
        if param.frame is not None and param.frame != WORLD_FRAME and param.frame not in declared:
            raise SpecError(
                path,
                f"{where}.parameters[{j}].frame",
                f"unknown frame {param.frame!r}: declare it under 'frames:' (declared: {sorted(declared) or 'none'})",
            )


def _euler_sequence(value: Any) -> bool:
    """scipy's rule: three of x, y, z, intrinsic (upper case) or extrinsic (lower), no axis twice in a row."""
    return (
        isinstance(value, str)
        and len(value) == 3
        and set(value) <= EULER_AXES
        and (value.isupper() or value.islower())
        and all(a != b for a, b in zip(value, value[1:], strict=False))
    )


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _parse_primitive(item: Any, embodiment: str, path: Path, where: str) -> PrimitiveSpec:
    if not isinstance(item, dict):
        raise SpecError(path, where, "must be a mapping")
    name = _require(item, "name", str, path, where)
    where = f"{where} ({name})"
    params = []
    for j, raw in enumerate(_require(item, "parameters", list, path, where)):
        params.append(_parse_parameter(raw, path, f"{where}.parameters[{j}]"))
    return PrimitiveSpec(
        name=name,
        embodiment=embodiment,
        description=_require(item, "description", str, path, where),
        parameters=tuple(params),
        capabilities=frozenset(_str_list(item, "capabilities", path, where)),
        preconditions=frozenset(_str_list(item, "preconditions", path, where)),
        effects=frozenset(_str_list(item, "effects", path, where)),
        path=_parse_path(item, params, path, where),
        time_limit_s=_time_limit(item, path, where),
    )


def _time_limit(item: dict, path: Path, where: str) -> float | None:
    """``time_limit_s``: optional, a positive number of seconds."""
    value = item.get("time_limit_s")
    if value is None:
        return None
    if not _number(value) or value <= 0:
        raise SpecError(path, f"{where}.time_limit_s", f"must be a positive number of seconds, got {value!r}")
    return float(value)


def _point(prim: PrimitiveSpec) -> ParameterSpec | None:
    point = prim.by_role(PATH_ROLE)
    return point if point is not None and point.type in ("position", "pose") else None


def _parse_path(item: dict, params: list[ParameterSpec], path: Path, where: str) -> tuple[Waypoint, ...]:
    """``path: [{role: push_start, offset: [0, 0, 0.1]}, ...]``: each role a position parameter of this
    primitive, or an object-name parameter (the point is where that object is)."""
    if "path" not in item:
        return ()
    positions = {p.role for p in params if p.type in ("position", "object_name")}
    waypoints = []
    for k, raw in enumerate(_require(item, "path", list, path, where)):
        at = f"{where}.path[{k}]"
        if not isinstance(raw, dict):
            raise SpecError(path, at, "must be a mapping with 'role' (and an optional 'offset'), or with 'effect'")
        if "effect" in raw:
            if set(raw) != {"effect"}:
                raise SpecError(path, at, "an actuation step has 'effect' alone (the state the hand establishes there)")
            waypoints.append(Waypoint(effect=_require(raw, "effect", str, path, at)))
            continue
        role = _require(raw, "role", str, path, at)
        if role not in positions:
            raise SpecError(
                path,
                f"{at}.role",
                f"{role!r} is not the role of a position or object-name parameter (those are: {sorted(positions)})",
            )
        offset = raw.get("offset", [0.0, 0.0, 0.0])
        if not (
            isinstance(offset, list)
            and len(offset) == 3
            and all(isinstance(v, int | float) and not isinstance(v, bool) for v in offset)
        ):
            raise SpecError(path, f"{at}.offset", f"must be three numbers [dx, dy, dz] in metres, got {offset!r}")
        waypoints.append(Waypoint(role, tuple(float(v) for v in offset)))
    return tuple(waypoints)


def _parse_parameter(raw: Any, path: Path, where: str) -> ParameterSpec:
    if not isinstance(raw, dict):
        raise SpecError(path, where, "must be a mapping")
    name = _require(raw, "name", str, path, where)
    ptype = _require(raw, "type", str, path, f"{where} ({name})")
    if ptype not in PARAM_TYPES:
        raise SpecError(path, f"{where}.type", f"unknown type {ptype!r}; known types: {', '.join(PARAM_TYPES)}")
    required = bool(raw.get("required", False))
    if not required and "default" not in raw:
        raise SpecError(path, f"{where} ({name})", "an optional parameter needs a 'default' (or set required: true)")
    rng = raw.get("range")
    if rng is not None and (not isinstance(rng, list) or len(rng) != 2):
        raise SpecError(path, f"{where}.range", "must be [low, high]")
    choices = raw.get("choices")
    unit = raw.get("unit", DEFAULT_UNITS.get(ptype))
    if ptype in UNITS and unit not in UNITS[ptype]:
        raise SpecError(path, f"{where}.unit", f"a {ptype} takes one of {', '.join(UNITS[ptype])}, got {unit!r}")
    sequence = raw.get("sequence")
    if (ptype == "euler") != (sequence is not None):
        raise SpecError(path, f"{where}.sequence", "Euler angles (and only they) need their axis sequence, e.g. 'ZYX'")
    if sequence is not None and not _euler_sequence(sequence):
        raise SpecError(
            path, f"{where}.sequence", f"three axes, all upper or all lower case, no two in a row, got {sequence!r}"
        )
    role = _require(raw, "role", str, path, f"{where} ({name})")
    if role not in PARAMETER_ROLES:
        raise SpecError(
            path,
            f"{where}.role",
            f"unknown role {role!r} of {name!r}; known roles: {', '.join(sorted(PARAMETER_ROLES))}",
        )
    return ParameterSpec(
        name=name,
        type=ptype,
        role=role,
        required=required,
        default=raw.get("default"),
        unit=unit,
        frame=raw.get("frame"),
        range=tuple(rng) if rng is not None else None,
        choices=tuple(choices) if choices is not None else None,
        sequence=sequence,
    )


def _require(data: dict, key: str, kind: type, path: Path, where: str) -> Any:
    if key not in data:
        raise SpecError(path, f"{where}.{key}", "missing required field")
    value = data[key]
    if not isinstance(value, kind):
        raise SpecError(path, f"{where}.{key}", f"must be a {kind.__name__}, got {type(value).__name__}")
    return value


def _str_list(data: dict, key: str, path: Path, where: str) -> list[str]:
    values = _require(data, key, list, path, where)
    if not all(isinstance(v, str) for v in values):
        raise SpecError(path, f"{where}.{key}", "must be a list of strings")
    return values


def held_along(
    calls: Sequence[tuple[PrimitiveSpec | None, dict[str, str]]], name_of: Callable[[ParameterSpec, str], str | None]
) -> list[tuple[str, int] | None]:
    """What the hand holds as each of a skill's calls (a primitive, or None for any other call, with
    its arguments' source text) starts, in statement order: the object the last grasp took and that
    call's index, until a call that lets go. ``name_of`` reads the object from a holding argument
    (a name, or the object a point names); a grasp whose arguments name none holds something unknown."""
    held: tuple[str, int] | None = None
    out: list[tuple[str, int] | None] = []
    for index, (spec, given) in enumerate(calls):
        out.append(held)
        if spec is None:
            continue
        taken = [name_of(p, given[p.name]) for p in spec.parameters if p.role in HOLDING_ROLES and p.name in given]
        if taken:
            name = next((n for n in taken if n is not None), None)
            held = None if name is None else (name, index)
        if spec.effects & RELEASING_EFFECTS:
            held = None
    return out
