"""Frames, length units and rotation representations of real controllers, at run time.

A controller that takes poses in its robot's base frame with axis-angle rotation (URScript), or
millimetres with Euler angles (KRL), is described by its YAML alone (``frames:``, and each
parameter's ``unit``, ``frame`` and ``type``). The ontology renders the conversion a call needs as
plain Python (``ontology/conversions.py``); this module is what that Python calls: the task queries
``task.to_frame`` / ``task.quat_to_frame`` (and back), and the pure helpers below. Primitive modules
use the same functions to turn their arguments back into the world-frame metres the shared
controllers take, so each conversion is written once, here.

Quaternions are ``[x, y, z, w]`` (robosuite's and scipy's order). Euler sequences are scipy's:
upper case is intrinsic (``"ZYX"``: KUKA's A, B, C), lower case extrinsic.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from lerobot_policy_recent.descriptions.frames import LENGTH_UNITS, WORLD

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation


@dataclass(frozen=True)
class Frame:
    """A named frame: its origin and orientation in the world."""

    name: str
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)  # xyzw, the frame's axes in the world

    @property
    def rotation(self) -> Rotation:
        return _rotation().from_quat(self.quat)

    @property
    def turned(self) -> bool:
        return tuple(self.quat) != (0.0, 0.0, 0.0, 1.0)

    def to_frame(self, position: Sequence[float]) -> list[float]:
        """A world point, in this frame (metres)."""
        shifted = np.subtract(_vector(position, 3), self.origin)
        return _floats(self.rotation.inv().apply(shifted) if self.turned else shifted)

    def from_frame(self, position: Sequence[float]) -> list[float]:
        """A point of this frame, in the world (metres)."""
        point = _vector(position, 3)
        return _floats((self.rotation.apply(point) if self.turned else point) + np.asarray(self.origin))

    def quat_to_frame(self, quat: Sequence[float]) -> list[float]:
        """A world orientation, relative to this frame's axes."""
        return _floats((self.rotation.inv() * _rotation().from_quat(_vector(quat, 4))).as_quat())

    def quat_from_frame(self, quat: Sequence[float]) -> list[float]:
        """An orientation given in this frame, in the world."""
        return _floats((self.rotation * _rotation().from_quat(_vector(quat, 4))).as_quat())


WORLD_AT_ORIGIN = Frame(WORLD)


def frame_at(name: str, origin: str, rpy_deg: Sequence[float], base_xyz: Sequence[float]) -> Frame:
    """A frame a YAML declares: at the world origin or the arm's base, turned by fixed-axis roll, pitch, yaw."""
    at = (0.0, 0.0, 0.0) if origin == WORLD else tuple(float(v) for v in base_xyz)
    quat = _rotation().from_euler("xyz", list(rpy_deg), degrees=True).as_quat()
    return Frame(name, at, tuple(float(v) for v in quat))  # type: ignore[arg-type]


def frames_for(declared, base_xyz: Sequence[float]) -> dict[str, Frame]:
    """The world and the frames an API declares (``ontology.specs.FrameSpec``: name, origin, rpy_deg)."""
    return {WORLD: WORLD_AT_ORIGIN, **{f.name: frame_at(f.name, f.origin, f.rpy_deg, base_xyz) for f in declared}}


def scale(values: Sequence[float], unit: str, to: str) -> list[float]:
    """Lengths in ``unit``, in ``to`` (``scale([1, 2, 3], "m", "mm")`` is ``[1000, 2000, 3000]``)."""
    factor = LENGTH_UNITS[unit] / LENGTH_UNITS[to]
    return [float(v) * factor for v in values]


def world_point(value: Sequence[float], kind: str, unit: str | None, frame: Frame) -> np.ndarray:
    """The world point (metres) a ``position`` or ``pose`` argument names: how run-time checks read it."""
    size = 6 if kind == "pose" else 3
    return np.asarray(frame.from_frame(scale(_vector(value, size)[:3], unit or "m", "m")))


def world_rotation(value: Sequence[float], kind: str, frame: Frame, sequence: str | None = None, unit: str = "rad"):
    """The world quaternion a ``pose`` (its rotation part), ``rotvec``, ``euler`` or ``quaternion`` argument names."""
    if kind == "pose":
        quat = rotvec_to_quat(_vector(value, 6)[3:])
    elif kind == "rotvec":
        quat = rotvec_to_quat(value)
    elif kind == "euler":
        quat = euler_to_quat(value, sequence or "ZYX", degrees=unit == "deg")
    else:
        quat = list(_vector(value, 4))
    return frame.quat_from_frame(quat)


def argument_for(point: Sequence[float], kind: str, unit: str | None, frame: Frame, tool_quat: Sequence[float]):
    """A world point (metres) as a ``position`` or ``pose`` argument: what a check writes. A pose keeps
    the tool's orientation, as the position-only moves do."""
    position = scale(frame.to_frame(point), "m", unit or "m")
    if kind != "pose":
        return position
    return position + quat_to_rotvec(frame.quat_to_frame(tool_quat))


# Pure helpers skill code may call (the validator allows exactly these names; the ontology renders them).
def quat_to_rotvec(quat: Sequence[float]) -> list[float]:
    """Axis-angle (a rotation vector, radians) of a quaternion ``[x, y, z, w]``."""
    return _floats(_rotation().from_quat(_vector(quat, 4)).as_rotvec())


def rotvec_to_quat(rotvec: Sequence[float]) -> list[float]:
    """Quaternion ``[x, y, z, w]`` of a rotation vector (radians)."""
    return _floats(_rotation().from_rotvec(_vector(rotvec, 3)).as_quat())


def quat_to_euler(quat: Sequence[float], seq: str = "ZYX", degrees: bool = True) -> list[float]:
    """Euler angles of a quaternion in the axis sequence ``seq`` (``"ZYX"``: intrinsic, KUKA's A, B, C)."""
    return _floats(_rotation().from_quat(_vector(quat, 4)).as_euler(seq, degrees=degrees))


def euler_to_quat(angles: Sequence[float], seq: str = "ZYX", degrees: bool = True) -> list[float]:
    """Quaternion ``[x, y, z, w]`` of Euler angles in the axis sequence ``seq``."""
    return _floats(_rotation().from_euler(seq, _vector(angles, 3), degrees=degrees).as_quat())


SKILL_HELPERS = {f.__name__: f for f in (quat_to_rotvec, rotvec_to_quat, quat_to_euler, euler_to_quat)}


def _rotation() -> type[Rotation]:
    """scipy's rotations, imported on first use: loading a spec must not cost scipy's 1.5 s import."""
    from scipy.spatial.transform import Rotation

    return Rotation


def _vector(values: Sequence[float], size: int) -> np.ndarray:
    """``values`` as ``size`` floats, or the TypeError Python would give a wrong argument."""
    array = np.asarray(values, dtype=np.float64).reshape(-1)
    if array.shape != (size,):
        raise TypeError(f"expected {size} numbers, got {len(array)}: {list(values)!r}")
    return array


def _floats(values: np.ndarray) -> list[float]:
    return [float(v) for v in values]
