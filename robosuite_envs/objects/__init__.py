"""Object models of the task scenes, one kind per row of :data:`KINDS`.

Simple shapes reuse robosuite's generated objects (``BoxObject``, ``BallObject``, ``Bin``);
fixtures and articulated objects are MJCF files in ``objects/assets`` loaded as
``MujocoXMLObject``. A kind says whether the object is free or fixed to the table, which body is
observed (a drawer is observed at its knob) and which joint, if any, is its articulation state.
"""

from __future__ import annotations

from lerobot_policy_recent.robosuite_envs import runtime  # noqa: F401  (headless GL before robosuite loads)

# isort: split
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from robosuite.models.objects import BallObject, BoxObject, CylinderObject, MujocoObject, MujocoXMLObject
from robosuite.models.objects.composite import Bin

ASSETS = Path(__file__).parent / "assets"


@dataclass(frozen=True)
class ObjectKind:
    name: str
    build: Callable[[str, tuple[float, float, float], tuple[float, float, float, float]], MujocoObject]
    fixed: bool  # welded to the table (placed through the model) rather than on a free joint
    graspable: bool  # can be held: grasp flags are computed for it
    size: tuple[float, float, float] | None = None  # full extents, for kinds whose MJCF fixes them
    body: str | None = None  # observed sub-body (after the object's name prefix); None = root body
    joint: str | None = None  # articulation joint whose position is reported as the object's state
    description: str = ""


def _shape(cls, *, density: float = 400.0, friction: float = 1.5, **kwargs):
    """A builder for one of robosuite's generated shapes (``size`` = full extents)."""

    def build(name, size, rgba):
        if cls is BallObject:
            extents = [size[0] / 2]
        elif cls is CylinderObject:  # upright: x = y = diameter, z = height
            extents = [size[0] / 2, size[2] / 2]
        else:
            extents = np.array(size) / 2
        return cls(
            name=name, size=extents, rgba=list(rgba), density=density, friction=(friction, 0.005, 0.0001), **kwargs
        )

    return build


_box = _shape(BoxObject)
_sphere = _shape(BallObject, friction=1.0)
_slab = _shape(BoxObject, density=600.0, friction=0.6)
_post = _shape(CylinderObject, density=600.0, friction=0.6)
_plate = _shape(BoxObject, friction=1.0, joints=None)
_region = _shape(BoxObject, joints=None, obj_type="visual")


def _bin(name, size, rgba):
    return Bin(
        name=name,
        bin_size=size,
        wall_thickness=0.01,
        transparent_walls=False,
        use_texture=False,
        rgba=rgba,
        density=20000.0,  # heavy enough that a brushing arm does not shove it
    )


class BoltedBin(Bin):
    """robosuite's ``Bin`` without its free joint: a bin bolted to the bench. A free bin's base and four
    walls rest on the table with four contact points each, which the solver resolves every step; a
    fixed one has none (a paper-length scene simulates within the env's speed target with it)."""

    def _get_geom_attrs(self):
        return {**super()._get_geom_attrs(), "joints": None}


def _bolted_bin(name, size, rgba):
    return BoltedBin(
        name=name, bin_size=size, wall_thickness=0.01, transparent_walls=False, use_texture=False, rgba=rgba
    )


def _xml(asset: str, *, free: bool = False):
    def build(name, size, rgba):
        return MujocoXMLObject(str(ASSETS / asset), name=name, joints="default" if free else None, obj_type="all")

    return build


KINDS: dict[str, ObjectKind] = {
    k.name: k
    for k in (
        ObjectKind("box", _box, fixed=False, graspable=True, description="a free cuboid block"),
        ObjectKind("sphere", _sphere, fixed=False, graspable=True, description="a ball (no flat face for suction)"),
        ObjectKind(
            "rake",
            _xml("rake.xml", free=True),
            fixed=False,
            graspable=True,
            size=(0.27, 0.16, 0.07),
            description="a tool held by its raised handle (0.025 m above its centre); the crossbar is 0.13 m ahead",
        ),
        ObjectKind("slab", _slab, fixed=False, graspable=False, description="a flat block wider than any gripper"),
        ObjectKind("crate", _slab, fixed=False, graspable=False, description="a box in the way, not to be picked"),
        ObjectKind("post", _post, fixed=False, graspable=False, description="an upright cylinder in the way"),
        ObjectKind("bin", _bin, fixed=False, graspable=False, description="an open receptacle"),
        ObjectKind(
            "bolted_bin", _bolted_bin, fixed=True, graspable=False, description="an open receptacle bolted down"
        ),
        ObjectKind("plate", _plate, fixed=True, graspable=False, description="a flat plate to place things on"),
        ObjectKind("region", _region, fixed=True, graspable=False, description="a marked area (no collision)"),
        ObjectKind(
            "stain", _region, fixed=True, graspable=False, description="an area to wipe; state = fraction wiped"
        ),
        ObjectKind(
            "lid",
            _xml("lid.xml", free=True),
            fixed=False,
            graspable=True,
            size=(0.11, 0.11, 0.012),
            description="a loose lid with a knob",
        ),
        ObjectKind(
            "button",
            _xml("button.xml"),
            fixed=True,
            graspable=False,
            size=(0.07, 0.07, 0.051),
            body="cap",
            joint="press",
            description="a spring-loaded push button; state = 1 once pressed",
        ),
        ObjectKind(
            "drawer",
            _xml("drawer.xml"),
            fixed=True,
            graspable=False,
            size=(0.18, 0.18, 0.11),
            body="tray",
            joint="slide",
            description="a cabinet drawer observed at its knob; state = opening in metres",
        ),
        ObjectKind(
            "hinged_box",
            _xml("hinged_box.xml"),
            fixed=True,
            graspable=False,
            size=(0.14, 0.14, 0.08),
            joint="hinge",
            description="a box with a hinged lid; state = lid angle in radians",
        ),
        ObjectKind(
            "peg_hole",
            _xml("peg_hole.xml"),
            fixed=True,
            graspable=False,
            size=(0.14, 0.14, 0.05),
            description="a fixture with a 5 cm square hole, observed at the hole",
        ),
        ObjectKind(
            "pen",
            _xml("pen.xml"),
            fixed=True,
            graspable=False,
            size=(0.18, 0.18, 0.03),
            description="three walls open towards the robot, to sweep objects into",
        ),
    )
}


def get_kind(name: str) -> ObjectKind:
    try:
        return KINDS[name]
    except KeyError:
        raise KeyError(f"unknown object kind {name!r}; known kinds: {', '.join(KINDS)}") from None
