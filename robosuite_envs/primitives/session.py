"""What a primitive is handed: the robot session (``env``) and the task context (``task``).

Primitives never see the simulator. The executor writes the newest observation into the session
before it advances a primitive by one control step, and reads back the action it yields.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from lerobot_policy_recent.descriptions.frames import WORLD
from lerobot_policy_recent.robosuite_envs.calibration import Calibration, Nominal
from lerobot_policy_recent.robosuite_envs.observation import Observation
from lerobot_policy_recent.robosuite_envs.primitives.frames import WORLD_AT_ORIGIN, Frame

CONTROL_FREQ = 20  # Hz; one yielded action = one env step
TRACK_FRAMES = 10  # observations a position read combines (half a second at CONTROL_FREQ)
TRACK_JUMP = 0.02  # metres an earlier sighting may lie from the newest and still be the same resting place


class PrimitiveFailure(RuntimeError):
    """A primitive could not do what it promised. ``kind`` follows the paper's failure taxonomy."""

    KINDS = (
        "unreachable",
        "out_of_workspace",
        "waypoint_blocked",
        "misaligned",
        "timeout",
        "object_not_found",
        "grasp_lost",
        "cannot_track",  # the arm stopped short of a goal it was sent to: its control, not the skill's code
    )

    def __init__(self, kind: str, message: str):
        if kind not in self.KINDS:
            raise ValueError(f"unknown failure kind {kind!r}; known: {self.KINDS}")
        super().__init__(f"{kind}: {message}")
        self.kind, self.message = kind, message


@dataclass
class RobotSession:
    """The robot as primitives see it: latest observation plus state that persists across steps."""

    embodiment: str
    obs: Observation
    calibration: Calibration | Nominal = field(default_factory=Nominal)  # what the controllers know of the arm
    gripper_command: float = -1.0  # robosuite convention: -1 open, +1 closed
    hold_quat: np.ndarray = field(default=None)  # type: ignore[assignment]
    hold_yaw: bool = False  # set once a primitive aligns the gripper; until then only the tool axis is held
    frames: dict[str, Frame] = field(default_factory=lambda: {WORLD: WORLD_AT_ORIGIN})  # those its API declares
    seen: deque[Observation] = field(default_factory=lambda: deque(maxlen=TRACK_FRAMES))  # the latest, newest last

    def frame(self, name: str) -> Frame:
        """A frame of this robot's API by name, or a ValueError that lists the frames it has."""
        if name not in self.frames:
            raise ValueError(f"{self.embodiment} has no frame {name!r}; its frames: {', '.join(sorted(self.frames))}")
        return self.frames[name]

    def __post_init__(self) -> None:
        if self.hold_quat is None:
            self.hold_quat = np.array(self.obs.eef_quat, dtype=np.float64)
        self.seen.append(self.obs)

    def update(self, obs: Observation) -> None:
        if not self.seen or obs is not self.seen[-1]:  # the first frame is handed over twice (session, then step)
            self.seen.append(obs)
        self.obs = obs

    def tracked_position(self, name: str) -> np.ndarray | None:
        """Where ``name`` is, as a tracker estimates it from the latest sightings: the per-axis median of
        the newest run of observations that lie within ``TRACK_JUMP`` of the newest one (one frame's read
        errs by the perception's noise; an object that moved starts a new run). None where not in view."""
        newest = self.obs.objects.get(name)
        if newest is None:
            return None
        run = []
        for obs in reversed(self.seen):
            state = obs.objects.get(name)
            if state is None or np.linalg.norm(np.asarray(state.pos) - newest.pos) > TRACK_JUMP:
                break
            run.append(np.asarray(state.pos, dtype=np.float64))
        return np.median(run, axis=0) if run else np.asarray(newest.pos, dtype=np.float64)


class TaskContext:
    """Read-only queries about the scene that skill code may call (``task.get_object_position``)."""

    QUERIES = ("get_object_position", "get_object_state", "get_object_names", "is_grasped")
    # for robots whose API takes other frames or rotations (prompts list them for such a robot only)
    FRAME_QUERIES = ("get_tool_orientation", "to_frame", "from_frame", "quat_to_frame", "quat_from_frame")

    def __init__(self, session: RobotSession):
        self._session = session
        self.position_reads: list[tuple[str, list[float]]] = []  # (object, the list returned): run-time checks
        # compare what the skill planned with against what is observed now (not a skill query)

    def get_object_names(self) -> list[str]:
        return sorted(self._session.obs.objects)

    def get_object_position(self, name: str) -> list[float]:
        """Where the object is (metres, world): the perception's track of it, not one noisy frame."""
        self._state(name)
        position = [float(v) for v in self._session.tracked_position(name)]
        self.position_reads.append((name, position))
        return position

    def get_object_state(self, name: str) -> float:
        """Articulation or progress: drawer opening (m), lid angle (rad), button pressed (0/1)."""
        return float(self._state(name).state)

    def _state(self, name: str):
        state = self._session.obs.objects.get(name)
        if state is None:
            raise PrimitiveFailure(
                "object_not_found", f"object {name!r} not found in scene; objects: {self.get_object_names()}"
            )
        return state

    def get_tool_orientation(self) -> list[float]:
        """The tool's orientation in the world, quaternion ``[x, y, z, w]`` (the arm's forward kinematics)."""
        return [float(v) for v in self._session.obs.eef_quat]

    # A robot whose API takes another frame (its base, as URScript does) declares it in its YAML;
    # the ontology renders these calls where a world value must become that frame's, and back.
    def to_frame(self, position: list[float], frame: str) -> list[float]:
        """A world position (metres), in this robot's frame ``frame`` (metres)."""
        return self._session.frame(frame).to_frame(position)

    def from_frame(self, position: list[float], frame: str) -> list[float]:
        """A position in this robot's frame ``frame`` (metres), in the world."""
        return self._session.frame(frame).from_frame(position)

    def quat_to_frame(self, quat: list[float], frame: str) -> list[float]:
        """A world orientation ``[x, y, z, w]``, relative to the axes of this robot's frame ``frame``."""
        return self._session.frame(frame).quat_to_frame(quat)

    def quat_from_frame(self, quat: list[float], frame: str) -> list[float]:
        """An orientation given in this robot's frame ``frame``, in the world."""
        return self._session.frame(frame).quat_from_frame(quat)

    def is_grasped(self, name: str) -> bool:
        """The gripper detects an object in its grip, and perception puts ``name`` there."""
        return self._session.obs.held() == name
