"""The vocabulary of frames and length units a robot file may use (``frames:``, a parameter's ``unit``).

The ontology checks and renders conversions with these names; the simulator's primitives
(``robosuite_envs/primitives/frames.py``) compute with them.
"""

from __future__ import annotations

LENGTH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}  # metres per unit
WORLD = "world"
ARM_BASE = "arm_base"  # a frame's origin: where the arm's base body sits (the calibration's base_xyz)
