"""The table every scene stands on: one definition for the scenes, the subtask predicates and the
controllers (which send a trapped arm back over its middle)."""

from __future__ import annotations

import numpy as np

TABLE_SIZE = (0.8, 0.8, 0.05)  # robosuite TableArena's full size: x, y, thickness (metres)
TABLE_Z = 0.8  # world height of the table top
TABLE_OFFSET = np.array((0.0, 0.0, TABLE_Z))  # the top's centre in the world (TableArena's table_offset)
