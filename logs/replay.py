"""``recent replay``: rebuild an episode's Rerun recording from its other logs.

From a log directory, the frames come from the LeRobotDataset and the events from
``grounding_events/`` (this works for datasets downloaded from the Hub). From an MCAP file, both
come from its messages: the poses on ``/tf``, the joints on ``/joint_states``, the actions on
``/action``, the camera on ``/camera/front`` and the events on ``/recent/<event>``. The MCAP is
flushed after every step, so this is also how ``recent logs verify --recover`` rebuilds the Rerun
recording of a killed episode with every step but the one in flight. Either way the steps and
events are fed through the same :class:`~lerobot_policy_recent.logs.rerun_sink.RerunSink` a live
run uses, so a rebuilt recording has the live one's blueprint and entity layout.
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from lerobot_policy_recent.logs.dataset_sink import CAMERA_KEY, REPO_ID, VIDEO_BACKEND, dataset_episode
from lerobot_policy_recent.logs.events import EVENT_TYPES, Stamped, Step
from lerobot_policy_recent.logs.layout import LogLayout, episode_name
from lerobot_policy_recent.logs.readers import mcap_messages, read_table
from lerobot_policy_recent.logs.rerun_sink import RerunSink, rerun_executable
from lerobot_policy_recent.robosuite_envs.observation import (
    AGENT_POS_DIM,
    ENV_STATE_DIM,
    GRIPPER_SENSORS,
    JOINTS_AT,
    MAX_ARM_DOF,
    SENSORS_AT,
    SLOT_DIM,
)


def replay_episode(root: str | Path, episode: int, out: Path) -> Path:
    """Write ``out`` (an ``.rrd``) for ``episode`` of the run logged under ``root``."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    layout = LogLayout(Path(root))
    if not layout.events(episode).exists():
        raise FileNotFoundError(
            f"{layout.events(episode)} does not exist: episode {episode} of {root} was not committed "
            f"(episodes there: {layout.committed() or 'none'})"
        )
    rows = read_table(layout.events(episode))
    stamped = [
        Stamped(
            EVENT_TYPES[r["event"]](**_fields(json.loads(r["payload"]))), episode, r["frame_index"], r["log_time_ns"]
        )
        for r in rows
    ]
    dataset = LeRobotDataset(
        REPO_ID,
        root=layout.dataset_dir,
        episodes=[dataset_episode(layout.dataset_dir, episode)],
        video_backend=VIDEO_BACKEND,
    )
    frames = dataset.hf_dataset.with_format("numpy")[:]
    start_ns = stamped[0].log_time_ns
    images = None
    if CAMERA_KEY in dataset.meta.video_keys:  # decoded from the episode's video, frame by frame
        images = [dataset[i][CAMERA_KEY].numpy() for i in range(len(frames["frame_index"]))]
    steps = [
        Step(
            episode,
            int(frames["frame_index"][i]),
            float(frames["timestamp"][i]),
            start_ns + int(1e9 * float(frames["timestamp"][i])),
            frames["observation.state"][i],
            frames["observation.environment_state"][i],
            frames["action"][i],
            None if images is None else _hwc(images[i]),
        )
        for i in range(len(frames["frame_index"]))
    ]
    return write_recording(out, stamped, steps, ended=True)


def write_recording(out: Path, stamped: list[Stamped], steps: list[Step], *, ended: bool) -> Path:
    """Feed events and steps, interleaved as they happened, through a live run's Rerun sink into ``out``.

    ``ended``: the last event is the episode's end (an episode cut short has none)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    sink = RerunSink(lambda _index: out)
    sink.begin(stamped[0])
    pending = iter(stamped[1:-1] if ended else stamped[1:])
    event = next(pending, None)
    for step in steps:
        while event is not None and event.frame_index <= step.frame_index:
            sink.event(event)
            event = next(pending, None)
        sink.step(step)
    while event is not None:
        sink.event(event)
        event = next(pending, None)
    if ended:
        sink.end(stamped[-1])
    else:
        sink.close()
    return out


def replay_mcap(path: Path, out: Path) -> Path:
    """Write ``out`` (an ``.rrd``) from one episode's MCAP, finished or cut short by a crash."""
    stamped, steps = mcap_episode(path)
    return write_recording(out, stamped, steps, ended=stamped[-1].event.name == "episode_ended")


def mcap_episode(path: Path) -> tuple[list[Stamped], list[Step]]:
    """The events and the whole steps of an episode's MCAP.

    A step is whole once its ``/action`` message is there (``/tf`` and ``/joint_states`` precede it);
    a step cut short by a crash is dropped. The state fields no MCAP topic carries (an object's
    extents and state) are zero: the Rerun recording does not show them.
    """
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
    from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
    from foxglove_schemas_protobuf.JointStates_pb2 import JointStates

    messages, _complete = mcap_messages(path)
    stamped: list[Stamped] = []
    steps: list[Step] = []
    poses: dict[str, tuple[list[float], list[float]]] = {}
    truth: dict[str, tuple[list[float], list[float]]] | None = None  # /tf_truth, where the run had the simulator
    joints: dict[str, tuple[float, float]] = {}
    sensors: dict[str, float] = {}
    objects: list[str] = []
    for m in messages:
        if m.topic.startswith("/recent/"):
            payload = json.loads(m.data)
            event = EVENT_TYPES[payload["event"]](**_fields(payload))
            stamped.append(Stamped(event, payload["episode_index"], payload["frame_index"], m.log_time_ns))
            objects = list(getattr(event, "object_names", objects))
        elif m.topic == "/tf":
            poses = _poses(FrameTransforms.FromString(m.data))
        elif m.topic == "/tf_truth":
            truth = _poses(FrameTransforms.FromString(m.data))
        elif m.topic == "/joint_states":
            joints = {j.name: (j.position, j.velocity) for j in JointStates.FromString(m.data).joints}
        elif m.topic == "/gripper_sensors":
            sensors = json.loads(m.data)
        elif m.topic == "/action" and stamped:
            action = json.loads(m.data)
            state, environment = _state_vectors(poses, joints, sensors, objects)
            steps.append(
                Step(
                    stamped[0].episode_index,
                    int(action["frame_index"]),
                    float(action["sim_time"]),
                    m.log_time_ns,
                    state,
                    environment,
                    np.asarray(action["action"], dtype=np.float32),
                    truth=None if truth is None else _state_vectors(truth, {}, {}, objects)[1],
                )
            )
            truth = None
        elif m.topic == "/camera/front" and steps and steps[-1].log_time_ns == m.log_time_ns:
            steps[-1] = dataclasses.replace(steps[-1], image=_decoded_png(CompressedImage.FromString(m.data).data))
    if not stamped or stamped[0].event.name != "episode_started":
        raise ValueError(f"{path} holds no episode_started event: it is not an episode's MCAP written by this project")
    return stamped, steps


def _poses(transforms) -> dict[str, tuple[list[float], list[float]]]:
    return {
        t.child_frame_id: (
            [t.translation.x, t.translation.y, t.translation.z],
            [t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w],
        )
        for t in transforms.transforms
    }


def _state_vectors(
    poses: dict[str, tuple[list[float], list[float]]],
    joints: dict[str, tuple[float, float]],
    sensors: dict[str, float],
    objects: list[str],
) -> tuple[np.ndarray, np.ndarray]:
    """``agent_pos`` and ``environment_state`` as far as the MCAP's poses, joints and sensors give them."""
    state = np.zeros(AGENT_POS_DIM, dtype=np.float32)
    if "eef" in poses:
        state[0:3], state[3:7] = poses["eef"]
    state[7] = joints.get("gripper", (0.0, 0.0))[0]
    state[SENSORS_AT:JOINTS_AT] = [sensors.get(name, 0.0) for name in GRIPPER_SENSORS]
    for i in range(MAX_ARM_DOF):
        state[JOINTS_AT + i], state[JOINTS_AT + MAX_ARM_DOF + i] = joints.get(f"joint{i}", (0.0, 0.0))
    environment = np.zeros(ENV_STATE_DIM, dtype=np.float32)
    for slot, name in enumerate(objects):
        if name in poses:  # an object is on /tf while it is present
            row = environment[slot * SLOT_DIM : (slot + 1) * SLOT_DIM]
            row[0:3], row[3:7] = poses[name]
            row[7] = 1.0
    return state, environment


def _decoded_png(data: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


def default_output(root: str | Path, episode: int) -> Path:
    return Path(root) / "replay" / f"{episode_name(episode)}.rrd"


class ViewerError(RuntimeError):
    """The Rerun viewer could not be opened (no display, or it exited at once)."""


VIEWER_GRACE_S = 3.0  # a viewer that cannot open a window exits within this


def open_viewer(path: Path, *, env: dict[str, str] | None = None) -> subprocess.Popen:
    """Open a recording (``.rrd`` or ``.mcap``) in the Rerun viewer; it keeps running on its own.

    Raises :class:`ViewerError` where no display is set, or where the viewer exits during its first
    seconds (it did not open), with what it printed.
    """
    env = dict(os.environ if env is None else env)
    if not (env.get("DISPLAY") or env.get("WAYLAND_DISPLAY")) and sys.platform.startswith("linux"):
        raise ViewerError(
            "no display (DISPLAY and WAYLAND_DISPLAY are unset): the Rerun viewer needs one; "
            f"copy {path} to a machine with a display and run `rerun {path.name}` there"
        )
    viewer = subprocess.Popen(
        [rerun_executable(), str(path)], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
    )
    try:
        code = viewer.wait(timeout=VIEWER_GRACE_S)
    except subprocess.TimeoutExpired:
        return viewer  # still running: the window is up
    said = (viewer.stderr.read() if viewer.stderr else "").strip().splitlines()[-3:]
    raise ViewerError(f"the Rerun viewer exited with code {code} without opening {path}: {' | '.join(said)}")


def _fields(payload: dict) -> dict:
    return {k: v for k, v in payload.items() if k not in ("episode_index", "frame_index", "event")}


def _hwc(image: np.ndarray) -> np.ndarray:
    """Dataset images come back channel-first floats in [0, 1]; the viewer wants HxWx3 bytes."""
    array = np.asarray(image)
    if array.ndim == 3 and array.shape[0] in (1, 3):
        array = np.moveaxis(array, 0, -1)
    if array.dtype != np.uint8:
        array = (np.clip(array, 0.0, 1.0) * 255).astype(np.uint8)
    return array
