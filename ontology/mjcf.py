"""Facts read from robosuite MJCF files: arm joints and limits, gripper actuation mechanism."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from lerobot_policy_recent.ontology.specs import SpecError


@dataclass(frozen=True)
class JointFact:
    name: str
    lower: float
    upper: float


@dataclass(frozen=True)
class ArmFacts:
    dof: int
    joints: tuple[JointFact, ...]
    reach: float  # metres: summed link offsets along the kinematic chain (an upper bound)


@dataclass(frozen=True)
class GripperFacts:
    mechanism: str  # "parallel_jaw", "suction", "multi_finger" or "none"
    actuators: int
    joints: int
    force_sensor: bool = False
    stroke: float | None = None  # summed travel of the driven finger joints (m or rad), if any


def resolve_mjcf(path: str) -> Path:
    """A path relative to robosuite's package (``models/assets/...``), or an absolute/relative file path."""
    from lerobot_policy_recent.descriptions.embodiments import resolve_model_file

    try:
        return resolve_model_file(path)
    except FileNotFoundError as error:
        raise SpecError(path, "mjcf", str(error)) from None


def _parse(path: str) -> ET.Element:
    resolved = resolve_mjcf(path)
    try:
        return ET.parse(resolved).getroot()
    except FileNotFoundError:
        raise SpecError(resolved, "mjcf", "file does not exist") from None
    except ET.ParseError as exc:
        raise SpecError(resolved, "mjcf", f"not well-formed XML ({exc})") from None


def read_arm(path: str) -> ArmFacts:
    """Hinge/slide joints of the robot body tree; a robot MJCF without any is an error."""
    root = _parse(path)
    joints = []
    for joint in root.iter("joint"):
        if joint.get("type", "hinge") not in {"hinge", "slide"}:
            continue
        lo, hi = (float(v) for v in joint.get("range", "0 0").split())
        joints.append(JointFact(joint.get("name", f"joint{len(joints)}"), lo, hi))
    if not joints:
        raise SpecError(resolve_mjcf(path), "mjcf.joint", "robot model declares no hinge or slide joints")
    return ArmFacts(dof=len(joints), joints=tuple(joints), reach=_chain_length(root))


def _chain_length(root: ET.Element) -> float:
    """Stretched length of the arm: link offsets after the first joint, following the child whose
    subtree holds the most joints (the arm, not a camera or a pedestal)."""
    world = root.find("worldbody")
    body = world.find("body") if world is not None else None
    total, past_first_joint = 0.0, False
    while body is not None:
        children = [b for b in body.findall("body") if any(True for _ in b.iter("joint"))]
        if not children:
            break
        body = max(children, key=lambda b: sum(1 for _ in b.iter("joint")))
        if past_first_joint:
            offset = [float(v) for v in body.get("pos", "0 0 0").split()]
            total += sum(v * v for v in offset) ** 0.5
        past_first_joint = past_first_joint or body.find("joint") is not None
    return round(total, 3)


def read_gripper(path: str) -> GripperFacts:
    """Infer the grasp mechanism: adhesion actuator or weld ⇒ suction; 1–2 finger actuators ⇒ parallel jaw."""
    root = _parse(path)
    actuators = [child for act in root.iter("actuator") for child in act]
    joints = list(root.iter("joint"))
    if any(a.tag == "adhesion" for a in actuators) or any(True for _ in root.iter("weld")):
        mechanism = "suction"
    elif not actuators:
        mechanism = "none"
    elif len(actuators) <= 2 and joints:
        mechanism = "parallel_jaw"
    else:
        mechanism = "multi_finger"
    driven = {a.get("joint") for a in actuators if a.get("joint")}
    ranges = [
        float(j.get("range", "0 0").split()[1]) - float(j.get("range", "0 0").split()[0])
        for j in joints
        if j.get("name") in driven
    ]
    return GripperFacts(
        mechanism=mechanism,
        actuators=len(actuators),
        joints=len(joints),
        force_sensor=any(True for _ in root.iter("force")),
        stroke=round(sum(ranges), 4) if ranges else None,
    )
