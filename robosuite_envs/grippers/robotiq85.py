"""Robotiq 2F-85 with its four-bar linkage closed, so it grasps like the real gripper.

robosuite 1.5's ``Robotiq85Gripper`` actuates the two outer knuckles and leaves the inner
knuckles and fingers passive with no coupling; under MuJoCo 3.x the passive links collide with
the fingers and the jaw stalls ~6 cm open (a 4.5 cm cube is never touched). The real gripper's
linkage makes the passive joints mimic the driven ones; we say exactly that with joint
equalities, and drop contacts between links of the same gripper.
"""

from __future__ import annotations

from robosuite.models.grippers import register_gripper
from robosuite.models.grippers.robotiq_85_gripper import Robotiq85Gripper
from robosuite.utils.mjcf_utils import new_element

# (follower, driver, ratio): follower = ratio * driver, as the 2F-85's mimic joints.
_MIMIC = (
    ("left_inner_knuckle_joint", "finger_joint", 1.0),
    ("left_inner_finger_joint", "finger_joint", -1.0),
    ("right_inner_knuckle_joint", "right_outer_knuckle_joint", 1.0),
    ("right_inner_finger_joint", "right_outer_knuckle_joint", -1.0),
)


@register_gripper
class LinkedRobotiq85Gripper(Robotiq85Gripper):
    def __init__(self, idn=0):
        super().__init__(idn=idn)
        prefix = self.naming_prefix
        for follower, driver, ratio in _MIMIC:
            self.equality.append(
                new_element(
                    "joint",
                    name=None,
                    joint1=prefix + follower,
                    joint2=prefix + driver,
                    polycoef=f"0 {ratio} 0 0 0",
                    solref="0.005 1",
                )
            )
        bodies = [b.get("name") for b in self.worldbody.iter("body") if b.get("name")]
        for i, first in enumerate(bodies):
            for second in bodies[i + 1 :]:
                self.contact.append(new_element("exclude", name=None, body1=first, body2=second))
