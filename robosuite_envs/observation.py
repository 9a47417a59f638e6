"""The flat observation vectors shared by the env (encoder) and the policy (decoder).

``agent_pos``         = eef position (3), grip-site quaternion xyzw (4), gripper opening (1), then
                        the arm's joint positions (7, radians) and velocities (7, rad/s), as its
                        encoders report them; an arm with fewer joints (UR5e: 6) leaves the last
                        entries 0
``environment_state`` = per object slot: position (3), quaternion xyzw (4), present (1), grasped (1),
                        touched by the end effector (1), bounding-box extents in metres along x, y
                        and z (3: width, depth, height), state (1): the articulation or progress of
                        the object (drawer opening in metres, lid angle in radians, button pressed
                        0/1, fraction of a wipe area wiped)

Slots follow the order of the task's objects; unused slots are zero with present=0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

MAX_ARM_DOF = 7  # Panda and Sawyer have 7 arm joints, UR5e 6; shorter arms are zero-padded
AGENT_POS_DIM = 8 + 2 * MAX_ARM_DOF
MAX_OBJECTS = 8
SLOT_DIM = 14
ENV_STATE_DIM = MAX_OBJECTS * SLOT_DIM
ACTION_DIM = 7  # OSC_POSE delta (6) + gripper (1): -1 opens, +1 closes
POSITION_SIGMA = 0.004  # metres, per axis: the object perception's stated accuracy (1 sigma)

# What each entry of the vectors is (LeRobot dataset feature names, the Rerun series names).
JOINT_POS_NAMES = tuple(f"joint{i}_pos" for i in range(MAX_ARM_DOF))
JOINT_VEL_NAMES = tuple(f"joint{i}_vel" for i in range(MAX_ARM_DOF))
AGENT_POS_NAMES = (
    ("eef_x", "eef_y", "eef_z", "eef_qx", "eef_qy", "eef_qz", "eef_qw", "gripper_opening")
    + JOINT_POS_NAMES
    + JOINT_VEL_NAMES
)
SLOT_NAMES = (
    "x",
    "y",
    "z",
    "qx",
    "qy",
    "qz",
    "qw",
    "present",
    "grasped",
    "touched",
    "size_x",
    "size_y",
    "height",
    "state",
)
ENV_STATE_NAMES = tuple(f"slot{slot}_{name}" for slot in range(MAX_OBJECTS) for name in SLOT_NAMES)
ACTION_NAMES = ("dx", "dy", "dz", "dax", "day", "daz", "gripper")


@dataclass(frozen=True)
class ObjectState:
    pos: np.ndarray
    quat: np.ndarray
    grasped: bool
    touching: bool = False
    size: np.ndarray = field(default_factory=lambda: np.zeros(3))  # bounding-box extents x, y, z (perception)
    state: float = 0.0

    @property
    def height(self) -> float:
        return float(self.size[2])

    @property
    def top(self) -> np.ndarray:
        """Centre of the object's upper face (where a suction cup seals)."""
        return self.pos + np.array([0.0, 0.0, self.height / 2])


@dataclass(frozen=True)
class Observation:
    """What primitives see: the robot's end effector and the named objects of the task."""

    eef_pos: np.ndarray
    eef_quat: np.ndarray
    gripper_opening: float
    objects: dict[str, ObjectState]
    joint_pos: np.ndarray = field(default_factory=lambda: np.zeros(0))  # the arm's joints, radians
    joint_vel: np.ndarray = field(default_factory=lambda: np.zeros(0))  # rad/s

    def encode(self, object_names: list[str]) -> tuple[np.ndarray, np.ndarray]:
        agent = np.concatenate(
            [self.eef_pos, self.eef_quat, [self.gripper_opening], _padded(self.joint_pos), _padded(self.joint_vel)]
        ).astype(np.float32)
        env_state = np.zeros(ENV_STATE_DIM, dtype=np.float32)
        for slot, name in enumerate(object_names):
            state = self.objects.get(name)
            if state is None:  # not in view (e.g. an obstacle that has not appeared yet): present = 0
                continue
            row = [*state.pos, *state.quat, 1.0, float(state.grasped), float(state.touching), *state.size, state.state]
            env_state[slot * SLOT_DIM : (slot + 1) * SLOT_DIM] = row
        return agent, env_state

    @classmethod
    def decode(cls, agent_pos: np.ndarray, env_state: np.ndarray, object_names: list[str]) -> Observation:
        agent_pos = np.asarray(agent_pos, dtype=np.float64)
        env_state = np.asarray(env_state, dtype=np.float64)
        objects = {}
        for slot, name in enumerate(object_names):
            row = env_state[slot * SLOT_DIM : (slot + 1) * SLOT_DIM]
            if row[7] > 0.5:
                objects[name] = ObjectState(
                    pos=row[0:3].copy(),
                    quat=row[3:7].copy(),
                    grasped=bool(row[8] > 0.5),
                    touching=bool(row[9] > 0.5),
                    size=row[10:13].copy(),
                    state=float(row[13]),
                )
        return cls(
            eef_pos=agent_pos[0:3].copy(),
            eef_quat=agent_pos[3:7].copy(),
            gripper_opening=float(agent_pos[7]),
            objects=objects,
            joint_pos=agent_pos[8 : 8 + MAX_ARM_DOF].copy(),
            joint_vel=agent_pos[8 + MAX_ARM_DOF : AGENT_POS_DIM].copy(),
        )


def _padded(values: np.ndarray) -> np.ndarray:
    """An arm's joint vector in the fixed-width slot (shorter arms zero-padded)."""
    values = np.asarray(values, dtype=np.float64).ravel()
    if values.size > MAX_ARM_DOF:
        raise ValueError(f"an arm with {values.size} joints does not fit the observation (at most {MAX_ARM_DOF})")
    return np.pad(values, (0, MAX_ARM_DOF - values.size))
