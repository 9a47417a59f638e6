"""Facts read from robosuite MJCF files: arm joints and limits, gripper actuation mechanism."""

from __future__ import annotations

import importlib.util
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from ontology.specs import SpecError


@dataclass(frozen=True)
class JointFact:
    name: str
    lower: float
    upper: float


@dataclass(frozen=True)
class ArmFacts:
    dof: int
    joints: tuple[JointFact, ...]


@dataclass(frozen=True)
class GripperFacts:
    mechanism: str  # "parallel_jaw", "suction", "multi_finger" or "none"
    actuators: int
    joints: int


def resolve_mjcf(path: str) -> Path:
    """A path relative to robosuite's package (``models/assets/...``), or an absolute/relative file path."""
    candidate = Path(path)
    if candidate.is_file():
        return candidate
    spec = importlib.util.find_spec("robosuite")  # locate without importing robosuite (slow)
    if spec is None or not spec.submodule_search_locations:
        raise SpecError(path, "mjcf", "robosuite is not installed, and the path is not a file")
    return Path(spec.submodule_search_locations[0]) / path


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
    return ArmFacts(dof=len(joints), joints=tuple(joints))


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
    return GripperFacts(mechanism=mechanism, actuators=len(actuators), joints=len(joints))
