"""Rerun sink: one ``.rrd`` per episode with a blueprint, on the ``step`` and ``sim_time`` timelines.

Layout: ``world/eef`` and ``world/objects`` (3D view), ``action``, ``gripper`` and ``joints``
(the arm's joint positions, radians) as time series,
``grounding/lm_seconds`` (latency of every infiller call), ``events`` (text log by level),
``skill/code`` (the skill as it stands, with the last patch as a diff, in markdown) and
``camera/front`` when a camera is logged. Per-step streams are buffered and sent as columns, so
logging a step costs a few list appends; the buffer is sent and flushed to disk at every event,
every ``BATCH`` steps and at least every ``FLUSH_S`` seconds, so the file of a killed process
lacks at most the steps of its last ``FLUSH_S`` (and never an event). Recovery does not depend on
this bound: ``recent logs verify --recover`` rebuilds the recording from the episode's MCAP, which
is flushed every step (``logs/replay.py``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from lerobot_policy_recent.logs.events import EpisodeStarted, InfillCall, PatchApplied, Stamped, Step
from lerobot_policy_recent.logs.layout import episode_name
from lerobot_policy_recent.robosuite_envs.embodiments import arm_dof
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

BATCH = 64  # steps buffered before they are sent as one column chunk
FLUSH_S = 0.25  # wall-clock bound on how long a step waits in the buffer
_LEVELS = {"debug": rr.TextLogLevel.DEBUG, "info": rr.TextLogLevel.INFO, "warning": rr.TextLogLevel.WARN}


def blueprint() -> rrb.Blueprint:
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial3DView(name="robot and objects", origin="world"),
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
    steps: list[Step] = field(default_factory=list)
    sent_at: float = field(default_factory=time.monotonic)


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
        self._episodes[start.episode_index] = _Episode(rec, list(event.object_names), joints)
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
        episode.rec.flush()
        episode.rec.disconnect()

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
        rec.send_columns("world/eef", index, rr.Points3D.columns(positions=states[:, 0:3]))
        positions, labels, counts = [], [], []
        for s in steps:
            slots = s.environment_state.reshape(-1, SLOT_DIM)
            present = [i for i, name in enumerate(episode.object_names) if slots[i, 7] > 0.5]
            positions += [slots[i, 0:3] for i in present]
            labels += [episode.object_names[i] for i in present]
            counts.append(len(present))
        if positions:
            rec.send_columns(
                "world/objects",
                index,
                rr.Points3D.columns(positions=np.stack(positions), labels=labels).partition(counts),
            )


def _code_markdown(patch: PatchApplied) -> str:
    return (
        f"## {patch.skill} ({patch.kind} patch)\n\n```python\n{patch.code}\n```\n\n"
        f"### last patch\n\n```diff\n{patch.diff}\n```\n"
    )
