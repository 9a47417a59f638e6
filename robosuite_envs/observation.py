"""The flat observation vectors shared by the env (encoder) and the policy (decoder).

Both hold only what a real robot's sensors give (``docs/world.md`` names the sensor behind each entry):

``agent_pos``         = eef position (3), grip-site quaternion xyzw (4) from the arm's forward
                        kinematics; gripper opening (1); contact on the left and on the right
                        finger pad (2, 0/1: pad tactile sensors); the gripper's object detection
                        (1, 0/1: fingers stopped on something while closing, or a vacuum drawn);
                        vacuum level (1, 0 = atmospheric .. 1 = sealed; 0 without a cup); an
                        end-effector contact event (1, 0/1: the wrist's force/torque beyond the
                        load in the grip); then the arm's joint positions (7, radians) and
                        velocities (7, rad/s), as its encoders report them; an arm with fewer joints
                        (UR5e: 6) leaves the last entries 0
``environment_state`` = per object slot, from perception: position (3), quaternion xyzw (4),
                        present (1), bounding-box extents in metres along x, y and z (3: width,
                        depth, height), state (1): what a camera sees of the object's articulation
                        or progress (drawer opening in metres, lid angle in radians, button lit
                        0/1, fraction of a wipe area clean)

Slots follow the order of the task's objects; unused slots are zero with present=0. Which object is
held, and which the hand touches, is never an entry: the simulator's answers (:class:`GroundTruth`)
stay with the env's success predicates and its logs, and the policy infers a grasp from its
sensors and geometry (:meth:`Observation.held`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

MAX_ARM_DOF = 7  # Panda and Sawyer have 7 arm joints, UR5e 6; shorter arms are zero-padded
GRIPPER_SENSORS = ("finger_contact_left", "finger_contact_right", "object_detected", "vacuum", "eef_contact")
SENSORS_AT = 8  # agent_pos index of the first gripper sensor
JOINTS_AT = SENSORS_AT + len(GRIPPER_SENSORS)  # agent_pos index of the first joint position
AGENT_POS_DIM = JOINTS_AT + 2 * MAX_ARM_DOF
MAX_OBJECTS = 12  # a paper-length scene: four objects to clear, three buttons, bin, plate, zone and an obstacle
SLOT_DIM = 12
ENV_STATE_DIM = MAX_OBJECTS * SLOT_DIM
ACTION_DIM = 7  # OSC_POSE delta (6) + gripper (1): -1 opens, +1 closes
POSITION_SIGMA = 0.004  # metres, per axis: the object perception's stated accuracy (1 sigma)
GRIP_MARGIN = 0.03  # metres beyond an object's box the grip site may be and still hold it (a lid by its knob)

# What each entry of the vectors is (LeRobot dataset feature names, the Rerun series names).
JOINT_POS_NAMES = tuple(f"joint{i}_pos" for i in range(MAX_ARM_DOF))
JOINT_VEL_NAMES = tuple(f"joint{i}_vel" for i in range(MAX_ARM_DOF))
AGENT_POS_NAMES = (
    ("eef_x", "eef_y", "eef_z", "eef_qx", "eef_qy", "eef_qz", "eef_qw", "gripper_opening")
    + GRIPPER_SENSORS
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
    "size_x",
    "size_y",
    "height",
    "state",
)
ENV_STATE_NAMES = tuple(f"slot{slot}_{name}" for slot in range(MAX_OBJECTS) for name in SLOT_NAMES)
ACTION_NAMES = ("dx", "dy", "dz", "dax", "day", "daz", "gripper")


@dataclass(frozen=True)
class ObjectState:
    """One object as perception reports it."""

    pos: np.ndarray
    quat: np.ndarray
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
class GroundTruth:
    """What only the simulator knows: which object the gripper holds (robosuite's both-pads check, or
    the cup's seal) and which ones it touches. For success predicates and logs; never encoded."""

    held: frozenset[str] = frozenset()
    touching: frozenset[str] = frozenset()


@dataclass(frozen=True)
class Observation:
    """What primitives see: the robot's end effector and gripper sensors, and the objects perception reports."""

    eef_pos: np.ndarray
    eef_quat: np.ndarray
    gripper_opening: float
    objects: dict[str, ObjectState]
    joint_pos: np.ndarray = field(default_factory=lambda: np.zeros(0))  # the arm's joints, radians
    joint_vel: np.ndarray = field(default_factory=lambda: np.zeros(0))  # rad/s
    finger_contact: tuple[bool, bool] = (False, False)  # left, right pad: touching anything
    object_detected: bool = False  # the gripper's own report: fingers stopped on an object, or a vacuum drawn
    vacuum: float = 0.0  # 0 (atmospheric) .. 1 (sealed); a gripper without a cup reads 0
    eef_contact: bool = False  # the end effector touches something besides what it holds (a wrist F/T event)
    truth: GroundTruth | None = None  # the simulator's own answers (env side only): dropped by ``encode``

    def held(self) -> str | None:
        """The object in the grip, as a robot infers it: the gripper detects one, and the grip site lies
        within (or just beyond, ``GRIP_MARGIN``) that object's perceived box; the nearest such box wins."""
        if not self.object_detected:
            return None
        near = self._near_hand()
        return near[0] if near else None

    def in_contact(self) -> list[str]:
        """The objects the end effector may be touching, nearest first: those whose perceived box lies
        within ``GRIP_MARGIN`` of the grip site, while the contact sensor fires (never the held one)."""
        if not self.eef_contact:
            return []
        held = self.held()
        return [name for name in self._near_hand() if name != held]

    def _near_hand(self) -> list[str]:
        """Objects whose box lies within ``GRIP_MARGIN`` of the grip site: closest box first, then closest centre."""
        keyed = []
        for name, state in self.objects.items():
            half = np.asarray(state.size, dtype=float) / 2
            outside = np.maximum(np.abs(self.eef_pos - np.asarray(state.pos)) - half, 0.0)
            if np.all(outside <= GRIP_MARGIN):
                keyed.append((float(np.linalg.norm(outside)), float(np.linalg.norm(self.eef_pos - state.pos)), name))
        return [name for *_, name in sorted(keyed)]

    def encode(self, object_names: list[str]) -> tuple[np.ndarray, np.ndarray]:
        sensors = [*map(float, self.finger_contact), float(self.object_detected), self.vacuum, float(self.eef_contact)]
        agent = np.concatenate(
            [
                self.eef_pos,
                self.eef_quat,
                [self.gripper_opening],
                sensors,
                _padded(self.joint_pos),
                _padded(self.joint_vel),
            ]
        ).astype(np.float32)
        env_state = np.zeros(ENV_STATE_DIM, dtype=np.float32)
        for slot, name in enumerate(object_names):
            state = self.objects.get(name)
            if state is None:  # not in view (e.g. an obstacle that has not appeared yet): present = 0
                continue
            row = [*state.pos, *state.quat, 1.0, *state.size, state.state]
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
                    size=row[8:11].copy(),
                    state=float(row[11]),
                )
        sensors, joints = agent_pos[SENSORS_AT:JOINTS_AT], JOINTS_AT
        return cls(
            eef_pos=agent_pos[0:3].copy(),
            eef_quat=agent_pos[3:7].copy(),
            gripper_opening=float(agent_pos[7]),
            objects=objects,
            joint_pos=agent_pos[joints : joints + MAX_ARM_DOF].copy(),
            joint_vel=agent_pos[joints + MAX_ARM_DOF : AGENT_POS_DIM].copy(),
            finger_contact=(bool(sensors[0] > 0.5), bool(sensors[1] > 0.5)),
            object_detected=bool(sensors[2] > 0.5),
            vacuum=float(sensors[3]),
            eef_contact=bool(sensors[4] > 0.5),
        )


def _padded(values: np.ndarray) -> np.ndarray:
    """An arm's joint vector in the fixed-width slot (shorter arms zero-padded)."""
    values = np.asarray(values, dtype=np.float64).ravel()
    if values.size > MAX_ARM_DOF:
        raise ValueError(f"an arm with {values.size} joints does not fit the observation (at most {MAX_ARM_DOF})")
    return np.pad(values, (0, MAX_ARM_DOF - values.size))
