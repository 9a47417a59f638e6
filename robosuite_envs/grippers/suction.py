"""A suction (vacuum) gripper for robosuite: an adhesion actuator on a cup body.

The command passes straight through: robosuite's gripper controller already maps [-1, 1] onto
the actuator's [0, 1] range, and a second rescale would leave suction half on, never released.
"""

from __future__ import annotations

import numpy as np
from robosuite.models.grippers import register_gripper
from robosuite.models.grippers.gripper_model import GripperModel

from lerobot_policy_recent.descriptions.embodiments import BUNDLED_DIR

ASSET = BUNDLED_DIR / "assets" / "suction_gripper.xml"  # a robot description: the ontology reads it too


@register_gripper
class SuctionGripper(GripperModel):
    """-1 releases, +1 sucks. Holding needs the cup in contact with a surface it can seal on."""

    def __init__(self, idn=0):
        super().__init__(str(ASSET), idn=idn)

    def format_action(self, action):
        return np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)

    @property
    def speed(self):
        return 1.0

    @property
    def init_qpos(self):
        return np.zeros(0)

    @property
    def _important_geoms(self):
        return {
            "left_finger": [],
            "right_finger": [],
            "left_fingerpad": [],
            "right_fingerpad": [],
            "cup": ["cup_collision"],
        }
