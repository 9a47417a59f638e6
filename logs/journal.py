"""An ended episode's journal: what the dataset commit needs, in a file that holds data only.

A log directory can come from anywhere (a cluster's shared folder, a download), and the next run
into it reads its ``pending/`` journals back. So a journal is an ``.npz`` archive read with
``allow_pickle=False``: the frames as numeric arrays, and the events as JSON text rebuilt into
the typed events of :mod:`~lerobot_policy_recent.logs.events` by name. A file this module did not
write (another format, a truncated write, an unknown event, a pickle from an earlier version) is
refused with :class:`JournalError` naming it; nothing in it runs.
"""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np

from lerobot_policy_recent.logs.events import EVENT_TYPES, EpisodeStarted, Event, Stamped, Step

FORMAT = "recent-journal/1"
SUFFIX = ".npz"
LEGACY_SUFFIX = ".pkl"  # written before journals were data only; never loaded
_STEP_ARRAYS = ("frame_index", "sim_time", "log_time_ns", "state", "environment_state", "action")


class JournalError(ValueError):
    """A journal that this version will not read; the message names the file and why."""


def _stamped_json(stamped: Stamped) -> dict:
    return {
        "event": stamped.event.name,
        "payload": stamped.event.payload(),
        "episode_index": stamped.episode_index,
        "frame_index": stamped.frame_index,
        "log_time_ns": stamped.log_time_ns,
    }


def _event(record: dict) -> Event:
    kind = EVENT_TYPES.get(record.get("event"))
    if kind is None:
        raise ValueError(f"unknown event {record.get('event')!r}")
    return kind(**record["payload"])


def _stamped(record: dict) -> Stamped:
    return Stamped(_event(record), int(record["episode_index"]), int(record["frame_index"]), int(record["log_time_ns"]))


def dumps(result: Stamped, start: EpisodeStarted, frames: list[Step], events: list[dict]) -> bytes:
    """The journal of an ended episode: its result, start event, frames and event rows."""
    meta = {"format": FORMAT, "result": _stamped_json(result), "start": start.payload(), "events": events}
    arrays: dict[str, np.ndarray] = {"meta": np.array(json.dumps(meta))}
    if frames:
        arrays.update(
            frame_index=np.array([f.frame_index for f in frames], dtype=np.int64),
            sim_time=np.array([f.sim_time for f in frames], dtype=np.float64),
            log_time_ns=np.array([f.log_time_ns for f in frames], dtype=np.int64),
            state=np.stack([np.asarray(f.state, dtype=np.float32) for f in frames]),
            environment_state=np.stack([np.asarray(f.environment_state, dtype=np.float32) for f in frames]),
            action=np.stack([np.asarray(f.action, dtype=np.float32) for f in frames]),
        )
        if frames[0].image is not None:
            arrays["image"] = np.stack([np.asarray(f.image, dtype=np.uint8) for f in frames])
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def load(path: Path) -> tuple[Stamped, EpisodeStarted, list[Step], list[dict]]:
    """Read a journal written by :func:`dumps`; :class:`JournalError` for anything else."""
    if path.suffix == LEGACY_SUFFIX:
        raise JournalError(
            f"{path}: a journal of an earlier version (pickle), which this version never loads since a pickle can "
            "run code; commit it with the version that wrote it, or delete the file to drop that episode"
        )
    try:
        with np.load(path, allow_pickle=False) as archive:
            meta = json.loads(str(archive["meta"]))
            if meta.get("format") != FORMAT:
                raise ValueError(f"format {meta.get('format')!r}, expected {FORMAT!r}")
            arrays = {name: archive[name] for name in archive.files if name != "meta"}
        result = _stamped(meta["result"])
        start = _event({"event": EpisodeStarted.name, "payload": meta["start"]})
        if not isinstance(start, EpisodeStarted) or not isinstance(meta["events"], list):
            raise ValueError("malformed metadata")
        count = len(arrays.get("frame_index", ()))
        missing = [name for name in _STEP_ARRAYS if count and name not in arrays]
        if missing:
            raise ValueError(f"frames without {', '.join(missing)}")
        images = arrays.get("image")
        frames = [
            Step(
                result.episode_index,
                int(arrays["frame_index"][i]),
                float(arrays["sim_time"][i]),
                int(arrays["log_time_ns"][i]),
                arrays["state"][i],
                arrays["environment_state"][i],
                arrays["action"][i],
                None if images is None else images[i],
            )
            for i in range(count)
        ]
    except (OSError, ValueError, KeyError, TypeError, IndexError, zipfile.BadZipFile, json.JSONDecodeError) as exc:
        raise JournalError(f"{path}: not a journal written by this version ({type(exc).__name__}: {exc})") from None
    return result, start, frames, meta["events"]


def journals(pending_dir: Path) -> list[Path]:
    """The journals in a ``pending/`` folder, in episode order (legacy ones too, so they are refused by name)."""
    if not pending_dir.is_dir():
        return []
    return sorted(p for p in pending_dir.glob("episode_*") if p.suffix in (SUFFIX, LEGACY_SUFFIX))
