"""``recent replay``: rebuild an episode's Rerun recording from the LeRobotDataset and its grounding events.

The frames come from the dataset, the events from ``grounding_events/``; both are fed through the
same :class:`~lerobot_policy_recent.logs.rerun_sink.RerunSink` a live run uses, so a replayed recording has the live
one's blueprint and entity layout (and works for datasets downloaded from the Hub).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from lerobot_policy_recent.logs.dataset_sink import CAMERA_KEY, REPO_ID, VIDEO_BACKEND, dataset_episode
from lerobot_policy_recent.logs.events import EVENT_TYPES, Stamped, Step
from lerobot_policy_recent.logs.layout import LogLayout, episode_name
from lerobot_policy_recent.logs.readers import read_table
from lerobot_policy_recent.logs.rerun_sink import RerunSink
from lerobot_policy_recent.logs.verify import rerun_executable


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
    out.parent.mkdir(parents=True, exist_ok=True)
    sink = RerunSink(lambda _index: out)
    sink.begin(stamped[0])
    pending = iter(stamped[1:-1])
    event = next(pending, None)
    for step in steps:  # events and steps interleaved as they happened
        while event is not None and event.frame_index <= step.frame_index:
            sink.event(event)
            event = next(pending, None)
        sink.step(step)
    while event is not None:
        sink.event(event)
        event = next(pending, None)
    sink.end(stamped[-1])
    return out


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
    return {k: v for k, v in payload.items() if k not in ("episode_index", "frame_index")}


def _hwc(image: np.ndarray) -> np.ndarray:
    """Dataset images come back channel-first floats in [0, 1]; the viewer wants HxWx3 bytes."""
    array = np.asarray(image)
    if array.ndim == 3 and array.shape[0] in (1, 3):
        array = np.moveaxis(array, 0, -1)
    if array.dtype != np.uint8:
        array = (np.clip(array, 0.0, 1.0) * 255).astype(np.uint8)
    return array
