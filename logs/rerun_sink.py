"""Rerun sink: one ``.rrd`` per episode with a blueprint, on the ``step`` and ``sim_time`` timelines.

Layout: the 3D view holds ``world/objects`` (each object a box at its perceived pose, with its
perceived extents), ``world/eef`` (the end effector, a box as wide as the gripper is open) and
``world/eef_path`` (where it has been); ``action``, ``gripper`` and ``joints``
(the arm's joint positions, radians) are time series,
``grounding/lm_seconds`` (latency of every infiller call), ``events`` (text log by level),
``skill/code`` (the skill as it stands, with the last patch as a diff, in markdown) and
``camera/front`` when a camera is logged. Per-step streams are buffered and sent as columns, so
logging a step costs a few list appends; the buffer is sent and flushed to disk at every event,
every ``BATCH`` steps and at least every ``FLUSH_S`` seconds, so the file of a killed process
lacks at most the steps of its last ``FLUSH_S`` (and never an event). Recovery does not depend on
this bound: ``recent logs verify --recover`` rebuilds the recording from the episode's MCAP, which
is flushed every step (``logs/replay.py``). When an episode ends its recording is compacted
(``rerun rrd optimize``: the many small chunks that flushing made become a few large ones), so
viewers and tools open it fast; if that fails, the file is left as written.
"""

from __future__ import annotations

import importlib.util
import logging
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from lerobot_policy_recent.descriptions.embodiments import arm_dof
from lerobot_policy_recent.logs.events import EpisodeStarted, InfillCall, PatchApplied, Stamped, Step
from lerobot_policy_recent.logs.layout import episode_name
from lerobot_policy_recent.robosuite_envs.observation import (
    ACTION_NAMES,
    GRIPPER_SENSORS,
    JOINT_POS_NAMES,
    JOINTS_AT,
    MAX_ARM_DOF,
    SENSORS_AT,
    SLOT_DIM,
)
from lerobot_policy_recent.robosuite_envs.primitives.session import CONTROL_FREQ

log = logging.getLogger(__name__)

BATCH = 64  # steps buffered before they are sent as one column chunk
MIN_HALF_SIZE = 0.01  # an object whose extents are unknown (a recording rebuilt from MCAP) is drawn 2 cm wide
FINGER_SPAN = 0.04  # the end effector's drawn half-width at gripper opening 1
EEF_COLOR = (255, 140, 0)
PATH_EVERY = 10  # steps between two drawings of the end effector's path so far
PATH_POINTS = 200  # points in one drawing of it
FLUSH_S = 0.25  # wall-clock bound on how long a step waits in the buffer
_LEVELS = {"debug": rr.TextLogLevel.DEBUG, "info": rr.TextLogLevel.INFO, "warning": rr.TextLogLevel.WARN}


def blueprint() -> rrb.Blueprint:
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                # world/truth: the simulator's exact poses, hidden until a user ticks it on
                rrb.Spatial3DView(
                    name="robot and objects",
                    origin="world",
                    overrides={"world/truth": rrb.EntityBehavior(visible=False)},
                ),
                rrb.Spatial2DView(name="camera", origin="camera"),
                row_shares=[3, 1],
            ),
            rrb.Vertical(
                rrb.TimeSeriesView(name="actions", origin="action"),
                rrb.TimeSeriesView(name="gripper", origin="gripper"),
                rrb.TimeSeriesView(name="gripper sensors", origin="gripper_sensors"),
                rrb.TimeSeriesView(name="arm joints (rad)", origin="joints"),
                rrb.TimeSeriesView(name="LM latency (s)", origin="grounding"),
            ),
            rrb.Vertical(
                rrb.TextDocumentView(name="skill code", origin="skill"),
                rrb.TextLogView(name="events", origin="events"),
            ),
            column_shares=[3, 2, 3],
        ),
        rrb.TimePanel(timeline="step"),
        collapse_panels=True,
    )


@dataclass
class _Episode:
    rec: rr.RecordingStream
    object_names: list[str]
    arm_dof: int
    path: Path
    steps: list[Step] = field(default_factory=list)
    sent_at: float = field(default_factory=time.monotonic)
    eef_path: list[np.ndarray] = field(default_factory=list)


class RerunSink:
    """``path_of(episode_index)``: where each episode's recording goes (``LogLayout.rrd`` in a run)."""

    def __init__(self, path_of: Callable[[int], Path]):
        self.path_of = path_of
        self._episodes: dict[int, _Episode] = {}

    def begin(self, start: Stamped) -> None:
        event: EpisodeStarted = start.event  # type: ignore[assignment]
        path = self.path_of(start.episode_index)
        path.parent.mkdir(parents=True, exist_ok=True)
        rec = rr.RecordingStream("recent", recording_id=f"{episode_name(start.episode_index)}-{start.log_time_ns}")
        rec.save(path, default_blueprint=blueprint())
        rec.send_recording_name(f"{event.task_id} on {event.robot} (seed {event.seed})")
        joints = arm_dof(event.robot, MAX_ARM_DOF)
        rec.log("action", rr.SeriesLines(names=list(ACTION_NAMES)), static=True)
        rec.log("joints", rr.SeriesLines(names=list(JOINT_POS_NAMES[:joints])), static=True)
        rec.log("gripper_sensors", rr.SeriesLines(names=list(GRIPPER_SENSORS)), static=True)
        self._episodes[start.episode_index] = _Episode(rec, list(event.object_names), joints, path)
        self.event(start)

    def event(self, stamped: Stamped) -> None:
        episode = self._episodes[stamped.episode_index]
        self._send_steps(episode)  # the steps before the event land first
        rec, e = episode.rec, stamped.event
        rec.set_time("step", sequence=stamped.frame_index)
        rec.set_time("sim_time", duration=stamped.frame_index / CONTROL_FREQ)
        rec.log("events", rr.TextLog(e.summary(), level=_LEVELS.get(e.level, rr.TextLogLevel.ERROR)))
        if isinstance(e, InfillCall):
            rec.log(f"grounding/{e.kind}", rr.Scalars(e.seconds))
        if isinstance(e, PatchApplied):
            rec.log("skill/code", rr.TextDocument(_code_markdown(e), media_type=rr.MediaType.MARKDOWN))
        rec.flush()
        episode.sent_at = time.monotonic()

    def step(self, step: Step) -> None:
        episode = self._episodes[step.episode_index]
        episode.steps.append(step)
        if step.image is not None:
            episode.rec.set_time("step", sequence=step.frame_index)
            episode.rec.set_time("sim_time", duration=step.sim_time)
            episode.rec.log("camera/front", rr.Image(step.image))
        if len(episode.steps) >= BATCH or time.monotonic() - episode.sent_at >= FLUSH_S:
            self._send_steps(episode)
            episode.rec.flush()
            episode.sent_at = time.monotonic()

    def end(self, result: Stamped) -> None:
        if result.episode_index not in self._episodes:
            return
        self.event(result)
        self._finish(self._episodes.pop(result.episode_index))

    def close(self) -> None:
        for episode in self._episodes.values():
            self._finish(episode)
        self._episodes.clear()

    def _finish(self, episode: _Episode) -> None:
        self._send_steps(episode)
        if episode.eef_path:
            _log_path(episode.rec, episode.eef_path, len(episode.eef_path) - 1)
        episode.rec.flush()
        episode.rec.disconnect()
        compact(episode.path)

    def _send_steps(self, episode: _Episode) -> None:
        steps, episode.steps = episode.steps, []
        if not steps:
            return
        rec = episode.rec
        frames = np.array([s.frame_index for s in steps])
        index = [rr.TimeColumn("step", sequence=frames), rr.TimeColumn("sim_time", duration=frames / CONTROL_FREQ)]
        states = np.stack([s.state for s in steps])
        rec.send_columns("action", index, rr.Scalars.columns(scalars=np.stack([s.action for s in steps])))
        rec.send_columns("gripper", index, rr.Scalars.columns(scalars=states[:, 7]))
        rec.send_columns("gripper_sensors", index, rr.Scalars.columns(scalars=states[:, SENSORS_AT:JOINTS_AT]))
        rec.send_columns(
            "joints", index, rr.Scalars.columns(scalars=states[:, JOINTS_AT : JOINTS_AT + episode.arm_dof])
        )
        eef = states[:, 0:3]
        opening = np.clip(states[:, 7], 0.0, 1.0)
        half = np.stack(
            [MIN_HALF_SIZE / 2 + FINGER_SPAN * opening, np.full(len(steps), 0.01), np.full(len(steps), 0.02)], 1
        )
        rec.send_columns(
            "world/eef",
            index,
            rr.Boxes3D.columns(
                centers=eef, half_sizes=half, quaternions=states[:, 3:7], colors=np.tile(EEF_COLOR, (len(steps), 1))
            ),
        )
        for step, point in zip(steps, eef, strict=True):  # the path so far, every PATH_EVERY steps: batching-free
            episode.eef_path.append(point)
            if (step.frame_index + 1) % PATH_EVERY == 0:
                _log_path(rec, episode.eef_path, step.frame_index)
        _send_boxes(rec, "world/objects", index, [s.environment_state for s in steps], episode.object_names)
        if all(s.truth is not None for s in steps):
            _send_boxes(rec, "world/truth/objects", index, [s.truth for s in steps], episode.object_names)


def _log_path(rec: rr.RecordingStream, points: list[np.ndarray], frame: int) -> None:
    """The path so far, at most ``PATH_POINTS`` points (every k-th, and the last): a long episode's
    recording grows linearly with its steps, not with their square."""
    stride = max(1, len(points) // PATH_POINTS)
    points = points[::stride] + ([points[-1]] if (len(points) - 1) % stride else [])
    rec.set_time("step", sequence=frame)
    rec.set_time("sim_time", duration=frame / CONTROL_FREQ)
    rec.log("world/eef_path", rr.LineStrips3D([np.stack(points)], colors=[EEF_COLOR], radii=0.002))


def _send_boxes(rec: rr.RecordingStream, entity: str, index: list, states: list[np.ndarray], names: list[str]) -> None:
    """Each present object of each step a box: its pose, and half its extents (2 cm where unknown)."""
    centers, halves, quats, labels, counts = [], [], [], [], []
    for state in states:
        slots = np.asarray(state).reshape(-1, SLOT_DIM)
        present = [i for i in range(len(names)) if slots[i, 7] > 0.5]
        for i in present:
            centers.append(slots[i, 0:3])
            quats.append(slots[i, 3:7] if np.linalg.norm(slots[i, 3:7]) > 0.5 else np.array([0, 0, 0, 1.0]))
            halves.append(np.maximum(slots[i, 8:11] / 2, MIN_HALF_SIZE))
            labels.append(names[i])
        counts.append(len(present))
    if centers:
        rec.send_columns(
            entity,
            index,
            rr.Boxes3D.columns(
                centers=np.stack(centers), half_sizes=np.stack(halves), quaternions=np.stack(quats), labels=labels
            ).partition(counts),
        )


def rerun_executable() -> str:
    """The ``rerun`` CLI installed with rerun-sdk in this environment: the binary itself where it is found
    (the ``rerun`` script starts a Python interpreter only to launch it), else that script."""
    spec = importlib.util.find_spec("rerun_cli")
    if spec is not None and spec.submodule_search_locations:
        binary = Path(spec.submodule_search_locations[0]) / "rerun"
        if binary.is_file() and os.access(binary, os.X_OK):
            return str(binary)
    beside = Path(sys.executable).parent / "rerun"
    found = str(beside) if beside.exists() else shutil.which("rerun")
    if found is None:
        raise FileNotFoundError("the `rerun` command was not found; it comes with rerun-sdk (pip install rerun-sdk)")
    return found


def compact(path: Path) -> bool:
    """Rewrite a finished recording with its chunks compacted (``rerun rrd optimize``); False if that failed
    (the file is then left as it was written, still whole)."""
    tmp = path.with_name(path.name + ".compact")
    try:
        subprocess.run(
            [rerun_executable(), "rrd", "optimize", "-o", str(tmp), str(path)],
            check=True,
            capture_output=True,
            env={**os.environ, "RUST_LOG": "error"},
            timeout=120,
        )
        os.replace(tmp, path)
        return True
    except (OSError, subprocess.SubprocessError) as exc:
        log.warning("could not compact %s (%s); it stays as written", path, exc)
        tmp.unlink(missing_ok=True)
        return False


def _code_markdown(patch: PatchApplied) -> str:
    return (
        f"## {patch.skill} ({patch.kind} patch)\n\n```python\n{patch.code}\n```\n\n"
        f"### last patch\n\n```diff\n{patch.diff}\n```\n"
    )
