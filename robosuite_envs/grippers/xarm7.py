"""UFactory xArm gripper with its finger pads named as its MJCF names them.

robosuite 1.5's ``XArm7Gripper`` lists ``finger1_pad_collision`` / ``finger2_pad_collision`` as its
pads, names its MJCF does not have (there: ``left_finger_pad_1`` … ``right_finger_pad_2``), so any
grasp check over them fails to build. This is the same gripper with the pads it really has.
"""

from __future__ import annotations

from robosuite.models.grippers import register_gripper
from robosuite.models.grippers.xarm7_gripper import XArm7Gripper


@register_gripper
class XArm7PadGripper(XArm7Gripper):
    @property
    def _important_geoms(self):
        left = ["left_finger_pad_1", "left_finger_pad_2"]
        right = ["right_finger_pad_1", "right_finger_pad_2"]
        return {"left_finger": left, "right_finger": right, "left_fingerpad": left, "right_fingerpad": right}
