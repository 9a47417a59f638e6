"""MCAP sink: one file per episode, readable by Foxglove, Lichtblick and Rerun.

Foxglove protobuf schemas where one fits — ``/tf`` (``FrameTransforms``: end effector and every
object in ``world``, as perceived; ``/tf_truth``: the simulator's exact object poses, where the run had the
simulator), ``/log`` (``Log``: every event, by level), ``/joint_states`` (``JointStates``:
the arm's joint positions and velocities, and the gripper opening), ``/camera/front`` (``CompressedImage``) — and JSON schemas with stable names
(``recent.<event>``) for grounding events on ``/recent/<event>``, the action on ``/action`` and the
gripper's sensors (finger contacts, object detection, vacuum, end-effector contact) on ``/gripper_sensors``.
While an episode runs, records are written unchunked and the file is flushed after every step
and event, so a killed process loses at most the step in flight; ``recent logs verify --recover``
rewrites such a file with its summary. When the episode ends, the file is rewritten in large
zstd-compressed chunks with the chunk and message indexes readers seek by (:func:`rewrite_mcap`):
smaller, and quick for Foxglove and ``mcap`` readers to open. (Chunks cut after every step would
keep the kill bound too, but hundreds of kilobyte-sized chunks read slower than no chunks at all:
BENCHMARKS.md, "Safe runtime and logs".)
"""

from __future__ import annotations

import io
import json
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.JointState_pb2 import JointState
from foxglove_schemas_protobuf.JointStates_pb2 import JointStates
from foxglove_schemas_protobuf.Log_pb2 import Log
from google.protobuf.timestamp_pb2 import Timestamp
from mcap.writer import CompressionType, Writer
from mcap_protobuf.schema import build_file_descriptor_set

from lerobot_policy_recent.descriptions.embodiments import arm_dof
from lerobot_policy_recent.logs.events import EVENT_TYPES, Stamped, Step, json_schema
from lerobot_policy_recent.logs.layout import LogLayout
from lerobot_policy_recent.logs.readers import salvage_mcap_records
from lerobot_policy_recent.robosuite_envs.observation import (
    GRIPPER_SENSORS,
    JOINTS_AT,
    MAX_ARM_DOF,
    SENSORS_AT,
    SLOT_DIM,
)

log = logging.getLogger(__name__)

LIBRARY = "lerobot_policy_recent"
CHUNK_BYTES = 256 * 1024  # uncompressed bytes per chunk of a finished file (a partial copy keeps its whole chunks)
LOG_LEVELS = {"debug": Log.DEBUG, "info": Log.INFO, "warning": Log.WARNING, "error": Log.ERROR}
ACTION_SCHEMA = {
    "title": "recent.action",
    "type": "object",
    "properties": {"frame_index": {"type": "integer"}, "action": {"type": "array"}, "sim_time": {"type": "number"}},
}
SENSORS_SCHEMA = {
    "title": "recent.gripper_sensors",
    "type": "object",
    "properties": {name: {"type": "number"} for name in GRIPPER_SENSORS},
}


@dataclass
class _EpisodeFile:
    stream: IO[bytes]
    writer: Writer
    object_names: list[str]
    arm_dof: int
    channels: dict[str, int] = field(default_factory=dict)
    schemas: dict[str, int] = field(default_factory=dict)  # one schema record per message type, shared by topics
    sequence: int = 0


class McapSink:
    def __init__(self, layout: LogLayout):
        self.layout = layout
        self._files: dict[int, _EpisodeFile] = {}

    # ------------------------------------------------------------------ sink protocol
    def begin(self, start: Stamped) -> None:
        path = self.layout.mcap(start.episode_index)
        path.parent.mkdir(parents=True, exist_ok=True)
        stream = open(path, "wb")  # noqa: SIM115 - kept open for the episode, closed in end()
        writer = Writer(stream, use_chunking=False)
        writer.start(profile="", library=LIBRARY)
        self._files[start.episode_index] = _EpisodeFile(
            stream, writer, list(start.event.object_names), arm_dof(start.event.robot, MAX_ARM_DOF)
        )
        self.event(start)

    def event(self, stamped: Stamped) -> None:
        f = self._files[stamped.episode_index]
        e = stamped.event
        payload = {"event": e.name, "episode_index": stamped.episode_index, "frame_index": stamped.frame_index}
        payload.update(e.payload())
        self._write(f, f"/recent/{e.name}", "json", json.dumps(payload).encode(), stamped.log_time_ns, e.name)
        message = Log(
            timestamp=_timestamp(stamped.log_time_ns),
            level=LOG_LEVELS[e.level],
            message=e.summary(),
            name=e.name,
        )
        self._write(f, "/log", "protobuf", message.SerializeToString(), stamped.log_time_ns, Log)
        f.stream.flush()

    def step(self, step: Step) -> None:
        f = self._files[step.episode_index]
        t = step.log_time_ns
        stamp = _timestamp(t)
        transforms = [_transform(stamp, "eef", step.state[0:3], step.state[3:7])]
        transforms += _object_transforms(stamp, step.environment_state, f.object_names)
        self._write(
            f, "/tf", "protobuf", FrameTransforms(transforms=transforms).SerializeToString(), t, FrameTransforms
        )
        if step.truth is not None:  # the simulator's exact poses, apart from what the robot perceived
            truth = FrameTransforms(transforms=_object_transforms(stamp, step.truth, f.object_names))
            self._write(f, "/tf_truth", "protobuf", truth.SerializeToString(), t, FrameTransforms)
        joints = JointStates(timestamp=stamp, joints=_joint_states(step.state, f.arm_dof))
        self._write(f, "/joint_states", "protobuf", joints.SerializeToString(), t, JointStates)
        sensors = dict(zip(GRIPPER_SENSORS, step.state[SENSORS_AT:JOINTS_AT].tolist(), strict=True))
        self._write(f, "/gripper_sensors", "json", json.dumps(sensors).encode(), t, "gripper_sensors")
        action = {"frame_index": step.frame_index, "sim_time": step.sim_time, "action": step.action.tolist()}
        self._write(f, "/action", "json", json.dumps(action).encode(), t, "action")
        if step.image is not None:
            image = CompressedImage(timestamp=stamp, frame_id="front", format="png", data=_png(step.image))
            self._write(f, "/camera/front", "protobuf", image.SerializeToString(), t, CompressedImage)
        f.stream.flush()  # a kill loses only the step in flight

    def end(self, result: Stamped) -> None:
        f = self._files.pop(result.episode_index, None)
        if f is None:
            return
        self._files[result.episode_index] = f
        self.event(result)
        del self._files[result.episode_index]
        f.writer.finish()
        f.stream.close()
        compact_mcap(self.layout.mcap(result.episode_index))

    def close(self) -> None:
        """Episodes still open (a run stopped early) are finished as they stand: readable, just shorter."""
        for index, f in self._files.items():
            f.writer.finish()
            f.stream.close()
            compact_mcap(self.layout.mcap(index))
        self._files.clear()

    # ------------------------------------------------------------------ helpers
    def _write(self, f: _EpisodeFile, topic: str, encoding: str, data: bytes, t: int, schema) -> None:
        channel = f.channels.get(topic)
        if channel is None:
            channel = f.channels[topic] = _register(f, topic, encoding, schema)
        f.writer.add_message(channel, log_time=t, data=data, publish_time=t, sequence=f.sequence)
        f.sequence += 1


def rewrite_mcap(records: list, target: Path, library: str = LIBRARY) -> int:
    """Write the schemas, channels and messages among ``records`` (an MCAP's, in file order) into a new
    MCAP at ``target``: zstd chunks of up to ``CHUNK_BYTES``, indexed, with its summary. Returns the messages."""
    kinds = {"Schema": [], "Channel": [], "Message": []}
    for record in records:
        kinds.get(type(record).__name__, []).append(record)
    with open(target, "wb") as stream:
        writer = Writer(stream, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        writer.start(profile="", library=library)
        # a file cut short while its summary was written repeats schemas and channels there: each once
        schemas = {s.id: s for s in kinds["Schema"]}.values()
        channels = {c.id: c for c in kinds["Channel"]}.values()
        schema_ids = {s.id: writer.register_schema(s.name, s.encoding, s.data) for s in schemas}
        channel_ids = {
            c.id: writer.register_channel(c.topic, c.message_encoding, schema_ids.get(c.schema_id, 0), c.metadata)
            for c in channels
        }
        for m in kinds["Message"]:
            if m.channel_id in channel_ids:
                writer.add_message(channel_ids[m.channel_id], m.log_time, m.data, m.publish_time, m.sequence)
        writer.finish()
    return len(kinds["Message"])


def compact_mcap(path: Path) -> None:
    """Rewrite a finished episode's MCAP in compressed, indexed chunks (whole or not at all: write, then rename)."""
    tmp = path.with_name(path.name + ".compact")
    try:
        rewrite_mcap(salvage_mcap_records(path), tmp)
        os.replace(tmp, path)
    except OSError as exc:  # a full disk costs the compaction, not the episode: the file stays as written
        log.warning("could not compact %s (%s); it stays as written", path, exc)
        tmp.unlink(missing_ok=True)


def _register(f: _EpisodeFile, topic: str, encoding: str, schema) -> int:
    name = schema.DESCRIPTOR.full_name if encoding == "protobuf" else schema
    if name not in f.schemas:
        if encoding == "protobuf":
            data = build_file_descriptor_set(schema).SerializeToString()
            f.schemas[name] = f.writer.register_schema(name=name, encoding="protobuf", data=data)
        else:
            fixed = {"action": ACTION_SCHEMA, "gripper_sensors": SENSORS_SCHEMA}
            body = fixed[schema] if schema in fixed else json_schema(EVENT_TYPES[schema])
            f.schemas[name] = f.writer.register_schema(
                name=body["title"], encoding="jsonschema", data=json.dumps(body).encode()
            )
    return f.writer.register_channel(topic=topic, message_encoding=encoding, schema_id=f.schemas[name])


def _timestamp(ns: int) -> Timestamp:
    return Timestamp(seconds=ns // 1_000_000_000, nanos=ns % 1_000_000_000)


def _transform(stamp: Timestamp, child: str, pos: np.ndarray, quat_xyzw: np.ndarray) -> FrameTransform:
    t = FrameTransform(timestamp=stamp, parent_frame_id="world", child_frame_id=child)
    t.translation.x, t.translation.y, t.translation.z = (float(v) for v in pos)
    t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w = (float(v) for v in quat_xyzw)
    return t


def _object_transforms(stamp: Timestamp, environment_state: np.ndarray, names: list[str]) -> list[FrameTransform]:
    """Each present object's pose in ``world``."""
    out = []
    for slot, name in enumerate(names):
        row = environment_state[slot * SLOT_DIM : (slot + 1) * SLOT_DIM]
        if row[7] > 0.5:  # present
            out.append(_transform(stamp, name, row[0:3], row[3:7]))
    return out


def _joint_states(state: np.ndarray, arm_dof: int) -> list[JointState]:
    """The arm's joints (``joint0`` .. in the robot's order) and the gripper, from the state vector."""
    joints = [
        JointState(
            name=f"joint{i}", position=float(state[JOINTS_AT + i]), velocity=float(state[JOINTS_AT + MAX_ARM_DOF + i])
        )
        for i in range(min(arm_dof, MAX_ARM_DOF))
    ]
    return [*joints, JointState(name="gripper", position=float(state[7]))]


def _png(image: np.ndarray) -> bytes:
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(np.asarray(image, dtype=np.uint8)).save(buffer, format="PNG", compress_level=1)
    return buffer.getvalue()
