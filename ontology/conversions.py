"""How a value for one parameter becomes the value another parameter of the same role takes.

Real controllers differ in more than names: URScript takes a pose ``[x, y, z, rx, ry, rz]`` in the
robot's base frame with an axis-angle rotation; KRL takes millimetres and Euler angles. The
primitive YAMLs say so (``unit``, ``frame``, ``type``, ``sequence``, and the API's ``frames:``), and
this module turns two such descriptions into the Python expression that converts one into the
other. The expression calls only the task's frame queries and the conversion helpers that skill
code may call (``robosuite_envs/primitives/frames.py``), so the grounded skill stays plain code.

Where the source value determines the target's completely (metres to millimetres, world to base,
a quaternion to axis-angle) the rendering is complete and no LM is asked. Where it does not (a
position-only call becoming a pose: which rotation?) the rendering keeps a ``<type>`` placeholder,
the span is an interface rewiring, and the LM writes that part from the facts the hint gives.
"""

from __future__ import annotations

from dataclasses import dataclass

from lerobot_policy_recent.descriptions.frames import LENGTH_UNITS
from lerobot_policy_recent.ontology.specs import PATH_ROLE, WORLD_FRAME, ApiSpec, ParameterSpec

ROTATIONS = ("quaternion", "rotvec", "euler")
POINTS = ("position", "pose")
OBJECT_NAME = "object_name"
# A name-based API designates a point by the object there: the task query that turns a name into
# that object's position (world frame, metres) determines a position completely. The way back, a
# position into a name, has no such query: what is at a computed point is for the LM to name.
NAME_LOOKUP = "task.get_object_position({})"
# The names the renders call (a test checks each is a task query or a skill helper).
FRAME_QUERIES = ("to_frame", "from_frame", "quat_to_frame", "quat_from_frame", "get_tool_orientation")
HELPERS = ("quat_to_rotvec", "rotvec_to_quat", "quat_to_euler", "euler_to_quat")
SOURCE = "{}"  # where the source expression goes in a template


WORLD_POSITION = ParameterSpec(name="position", type="position", role="", unit="m", frame=WORLD_FRAME)
WORLD_QUATERNION = ParameterSpec(name="orientation", type="quaternion", role="", frame=WORLD_FRAME)
TOOL_ORIENTATION = "task.get_tool_orientation()"  # the task query for the tool's world quaternion


@dataclass(frozen=True)
class Conversion:
    """A template over the source expression (``{}``); ``determined`` when it has no placeholder."""

    template: str

    @property
    def determined(self) -> bool:
        return "<" not in self.template

    def apply(self, expression: str) -> str:
        return self.template.replace(SOURCE, expression)


def conversion(source: ParameterSpec, target: ParameterSpec) -> Conversion | None:
    """The conversion from ``source``'s value to ``target``'s, None when the value passes as it is.

    Types that cannot become one another (a position into a quaternion) render the target's
    placeholder: nothing in the source determines the value."""
    if _same_representation(source, target):
        return None
    if source.type == OBJECT_NAME and target.type in POINTS:
        rest = conversion(WORLD_POSITION, target)
        return Conversion(NAME_LOOKUP if rest is None else rest.apply(NAME_LOOKUP))
    if source.type in POINTS and target.type in POINTS:
        return Conversion(_point(source, target))
    if source.type in ROTATIONS and target.type in ROTATIONS:
        return Conversion(_rotation(source, target, SOURCE))
    return Conversion(f"<{target.type}>")


def api_notes(api: ApiSpec) -> tuple[str, ...]:
    """For an API that takes anything but world-frame metres and quaternions: its frames, and the
    queries and helpers that convert into them (what a whole-program prompt lists besides the
    signatures). Empty for the others, whose prompts stay as they were."""
    params = [p for prim in api.primitives for p in prim.parameters]
    if not any(p.type in ("rotvec", "euler", "pose") or p.conversion_facts() or p.unit in ("cm", "mm") for p in params):
        return ()
    frames = "; ".join(
        f"{f.name}: at the {f.origin.replace('_', ' ')}, turned {list(f.rpy_deg)} deg (roll, pitch, yaw)"
        for f in api.frames
    )
    queries = ", ".join([*(f"task.{q}(...)" for q in FRAME_QUERIES), *(f"{h}(...)" for h in HELPERS)])
    return (
        *((f"Frames: {frames}",) if frames else ()),
        f"Conversions: {queries}",
        "Positions the scene queries return are metres in the world frame",
    )


def facts(param: ParameterSpec) -> str:
    """What a value of ``param`` is, in words: what a hint tells the LM instead of a finished call."""
    where = f"in frame {param.frame!r}" if param.frame and param.frame != WORLD_FRAME else "in the world frame"
    if param.type == "pose":
        return (
            f"[x, y, z, rx, ry, rz]: position in {param.unit} {where}, rotation as an axis-angle vector (rad) {where}"
        )
    if param.type == "position":
        return f"[x, y, z] in {param.unit} {where}"
    if param.type == "euler":
        return f"Euler angles in {param.unit} about the axes {param.sequence} ({_order(param.sequence)}) {where}"
    if param.type == "rotvec":
        return f"axis-angle vector (rad) {where}"
    if param.type == "quaternion":
        return f"quaternion [x, y, z, w] {where}"
    return param.type


def undetermined_facts(conflict) -> tuple[str, ...]:
    """For a conflict (``ontology.diagnosis.Conflict``) whose conversions leave a value open: what each
    such parameter's value is, and the queries and helpers that read and convert what it needs."""
    conversions = [(m.target, m.conversion) for m in conflict.mapping] + [
        (conflict.substitute.by_role(PATH_ROLE).name, s.conversion) for s in conflict.path if not s.actuate
    ]
    open_params = dict.fromkeys(name for name, c in conversions if c is not None and not c.determined)
    if not open_params:
        return ()
    params = [conflict.substitute.parameter(name) for name in open_params]
    rotation = any(p.type in ("pose", *ROTATIONS) for p in params)  # what the tool's orientation answers
    return (*(f"{p.name}: {facts(p)}" for p in params), *((TOOL_ROTATION,) if rotation else ()))


TOOL_ROTATION = (
    "The original call keeps the tool's orientation: task.get_tool_orientation() (a world quaternion "
    "[x, y, z, w]); task.quat_to_frame(q, frame) turns a world quaternion into a frame's, and "
    "quat_to_rotvec(q) or quat_to_euler(q, seq, degrees) into an axis-angle vector or Euler angles"
)


def _same_representation(a: ParameterSpec, b: ParameterSpec) -> bool:
    return (a.type, a.unit, a.frame or WORLD_FRAME, a.sequence) == (b.type, b.unit, b.frame or WORLD_FRAME, b.sequence)


def _point(source: ParameterSpec, target: ParameterSpec) -> str:
    """A position (or a pose's position) of the source, as the target takes it."""
    expression = SOURCE if source.type == "position" else f"{SOURCE}[:3]"
    source_frame, target_frame = source.frame or WORLD_FRAME, target.frame or WORLD_FRAME
    if source_frame != target_frame:
        expression = _scaled(expression, source.unit, "m")
        if source_frame != WORLD_FRAME:
            expression = f"task.from_frame({expression}, {source_frame!r})"
        if target_frame != WORLD_FRAME:
            expression = f"task.to_frame({expression}, {target_frame!r})"
        expression = _scaled(expression, "m", target.unit)
    else:
        expression = _scaled(expression, source.unit, target.unit)
    if target.type == "position":
        return expression
    rotation = f"{SOURCE}[3:]" if source.type == "pose" else held_rotation(target)
    return f"{expression} + {rotation}"  # two lists, joined (skill code has no starred expressions)


def held_rotation(target: ParameterSpec) -> str:
    """The rotation a position-only call means: the one the tool holds. A call that names no
    rotation (a Panda ``move``, or a ``pick`` approaching top-down along ``z``) never turns the hand,
    so a pose that must carry a rotation carries the tool's own, read when the call runs and put in
    the target's frame; the driver then does not turn the tool either."""
    rotvec = ParameterSpec(name="rotation", type="rotvec", role="", unit="rad", frame=target.frame)
    return _rotation(WORLD_QUATERNION, rotvec, TOOL_ORIENTATION)


def _rotation(source: ParameterSpec, target: ParameterSpec, expression: str) -> str:
    """Through a world-frame quaternion: the source's representation and frame, then the target's."""
    if source.type == "rotvec":
        expression = f"rotvec_to_quat({expression})"
    elif source.type == "euler":
        expression = f"euler_to_quat({expression}, {source.sequence!r}, degrees={source.unit == 'deg'})"
    source_frame, target_frame = source.frame or WORLD_FRAME, target.frame or WORLD_FRAME
    if source_frame != target_frame:
        if source_frame != WORLD_FRAME:
            expression = f"task.quat_from_frame({expression}, {source_frame!r})"
        if target_frame != WORLD_FRAME:
            expression = f"task.quat_to_frame({expression}, {target_frame!r})"
    if target.type == "rotvec":
        return f"quat_to_rotvec({expression})"
    if target.type == "euler":
        return f"quat_to_euler({expression}, {target.sequence!r}, degrees={target.unit == 'deg'})"
    return expression


def _scaled(expression: str, unit: str | None, to: str | None) -> str:
    factor = LENGTH_UNITS.get(unit or "m", 1.0) / LENGTH_UNITS.get(to or "m", 1.0)
    if factor == 1.0:
        return expression
    return f"[{factor:g} * v for v in {expression}]"


def _order(sequence: str | None) -> str:
    if not sequence:
        return ""
    kind = "intrinsic" if sequence.isupper() else "extrinsic"
    return f"{kind}, in that order"
