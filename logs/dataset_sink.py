"""Dataset sink: a LeRobotDataset of the frames, plus grounding-event and result tables, per episode.

Frames and events of an episode are held in memory until it ends; then the episode is written
to the LeRobotDataset, its events to ``grounding_events/`` and, last, its result row to
``results/``. An episode is therefore whole in all three tables or absent from all of them. The
tables join on ``episode_index`` (and events on ``frame_index``).

A commit is atomic, so a kill at any moment loses nothing that had ended:

1. an episode is journalled to ``pending/episode_N.npz`` (written, then renamed) as it ends, on
   the caller's thread, before anything is queued; a journal holds data only
   (:mod:`~lerobot_policy_recent.logs.journal`), since a log directory can come from anywhere;
2. they are written into ``dataset.staging/``, a copy of the dataset (files hard-linked; the few
   that LeRobot rewrites in place, ``meta/*.json`` and ``meta/tasks.parquet``, copied), which is
   renamed to ``dataset.ready/`` once finalized, and then swapped in for ``dataset/``;
3. the event and result rows are written and the journal deleted.

The next recorder on the directory (:func:`recover_pending`) finishes a swap that was cut short
and commits every journalled episode that has no result row yet; ``meta/recent_episodes.json`` in
the dataset says which log episodes it holds, so none is written twice.
"""

from __future__ import annotations

import json
import logging
import os
import queue
import shutil
import threading
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lerobot_policy_recent.logs import journal
from lerobot_policy_recent.logs.events import EpisodeStarted, Stamped, Step
from lerobot_policy_recent.logs.layout import LogLayout, write_atomically, write_parquet_atomically
from lerobot_policy_recent.robosuite_envs.observation import (
    ACTION_DIM,
    ACTION_NAMES,
    AGENT_POS_DIM,
    AGENT_POS_NAMES,
    ENV_STATE_DIM,
    ENV_STATE_NAMES,
)
from lerobot_policy_recent.robosuite_envs.primitives.session import CONTROL_FREQ

log = logging.getLogger(__name__)

REPO_ID = "local/recent_episodes"  # the dataset's id until it is uploaded under a real one
VIDEO_BACKEND = "pyav"  # naming a decoder skips LeRobot's torchcodec probe
CAMERA_KEY = "observation.images.front"
LOG_EPISODES = "meta/recent_episodes.json"  # the log episode index of each dataset episode, in order
os.environ.setdefault("SVT_LOG", "1")  # the AV1 encoder would print its whole configuration per episode


def features(camera_shape: tuple[int, int, int] | None) -> dict:
    """The dataset's features, each entry named; ``next.*`` mark the last frame (and its success) as LeRobot's own datasets do."""
    out = {
        "observation.state": {"dtype": "float32", "shape": (AGENT_POS_DIM,), "names": list(AGENT_POS_NAMES)},
        "observation.environment_state": {
            "dtype": "float32",
            "shape": (ENV_STATE_DIM,),
            "names": list(ENV_STATE_NAMES),
        },
        "action": {"dtype": "float32", "shape": (ACTION_DIM,), "names": list(ACTION_NAMES)},
        "next.reward": {"dtype": "float32", "shape": (1,), "names": None},
        "next.done": {"dtype": "bool", "shape": (1,), "names": None},
        "next.success": {"dtype": "bool", "shape": (1,), "names": None},
    }
    if camera_shape is not None:  # encoded as video, as LeRobot records cameras
        out[CAMERA_KEY] = {"dtype": "video", "shape": camera_shape, "names": ["height", "width", "channels"]}
    return out


def event_row(stamped: Stamped) -> dict:
    e = stamped.event
    payload = e.payload()
    return {
        "episode_index": stamped.episode_index,
        "frame_index": stamped.frame_index,
        "log_time_ns": stamped.log_time_ns,
        "event": e.name,
        "level": e.level,
        "skill": payload.get("skill", ""),
        "kind": payload.get("kind", ""),
        "category": payload.get("category") or payload.get("failure_category") or "",
        "summary": e.summary(),
        "payload": json.dumps(payload),
    }


def result_row(result: Stamped, start: EpisodeStarted, num_frames: int) -> dict:
    """The episode's row in ``results/``: its EpisodeEnded fields plus how it was run."""
    row = {"episode_index": result.episode_index, "num_frames": num_frames, **result.event.payload()}
    row.update(backend=start.backend, model=start.model, method=start.method, variations=start.variations)
    return row


def joined_to_frames(rows: list[dict], num_frames: int) -> list[dict]:
    """Event rows with every ``frame_index`` on a frame of the episode: events after its last action
    (the final subtask success, the result) join the last frame, where ``next.done`` is set."""
    last = max(0, num_frames - 1)
    return [{**row, "frame_index": min(row["frame_index"], last)} for row in rows]


@dataclass
class _Episode:
    start: EpisodeStarted
    frames: list[Step] = field(default_factory=list)
    events: list[dict] = field(default_factory=list)


WRITER_NICENESS = 19  # the least CPU priority: the writer runs where the robot and its LM leave a core idle


def _yield_the_cpu() -> None:
    """Put the calling thread (and the threads it starts: the video encoder's) at :data:`WRITER_NICENESS`.

    A commit encodes the episode's video and writes its files, seconds of one core per episode. At
    the default priority, on a 2-core host, it slows the next episode's LM calls, whose timings are
    measurements (IT, IGT). Linux sets a thread's own
    priority this way; elsewhere it raises and the writer keeps the process's.
    """
    try:
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), WRITER_NICENESS)
    except (OSError, AttributeError) as exc:
        log.debug("the dataset writer keeps its priority: %s", exc)


class DatasetSink:
    """Writes ended episodes on a writer thread, so the robot never waits for parquet files.

    The thread is started with the sink (threads cannot start while the interpreter exits, when a
    ``lerobot-eval`` run's last episodes are committed); ``close()`` waits for it to finish. An
    error on the thread switches the sink off at the next call.
    """

    def __init__(self, layout: LogLayout):
        self.layout = layout
        self._episodes: dict[int, _Episode] = {}
        self._ended: list[tuple[Stamped, _Episode]] = []  # waiting for the episodes still open
        self._ready = None  # the staging copy of the dataset, opened for the next commit
        self._jobs: queue.Queue = queue.Queue()
        self._error: BaseException | None = None
        self._writer = threading.Thread(target=self._work, name="recent-dataset-writer", daemon=True)
        self._writer.start()
        self._jobs.put([])  # first job: stage the existing dataset

    def _work(self) -> None:
        _yield_the_cpu()
        while (job := self._jobs.get()) is not None:
            try:
                if job:
                    commit(self.layout, job, self._take_ready())
            except BaseException as exc:  # noqa: BLE001 - reported to the recorder on the next call
                log.exception("writing episodes to %s failed", self.layout.root)
                self._error = exc
            try:  # open the next commit's copy now: opening needs threads, which cannot start at exit
                self._ready = _stage(self.layout.dataset_dir)
            except RuntimeError as exc:  # the interpreter is exiting: a next commit, if any, stages its own
                log.debug("could not stage %s ahead of the next episode: %s", self.layout.dataset_dir, exc)
        self._ready = None
        _discard_staging(self.layout.dataset_dir)  # the copy staged for a commit that never came

    def _take_ready(self):
        ready, self._ready = self._ready, None
        return ready

    def _raise_pending(self) -> None:
        if self._error is not None:
            error, self._error = self._error, None
            raise error

    def begin(self, start: Stamped) -> None:
        self._raise_pending()
        self._episodes[start.episode_index] = _Episode(start.event)  # type: ignore[arg-type]
        self.event(start)

    def event(self, stamped: Stamped) -> None:
        self._episodes[stamped.episode_index].events.append(event_row(stamped))

    def step(self, step: Step) -> None:
        self._episodes[step.episode_index].frames.append(step)

    def end(self, result: Stamped) -> None:
        """Queue the episode; once no other episode is open, write the queue in one dataset session.

        Batched episodes (one per env of a vectorised ``lerobot-eval``) end together, at the
        policy's ``reset()``; writing them in one session opens the dataset once.
        """
        episode = self._episodes.pop(result.episode_index, None)
        if episode is None:
            return
        episode.events.append(event_row(result))
        _journal(self.layout, result, episode)  # from here on a kill cannot lose it
        self._ended.append((result, episode))
        if not self._episodes:
            ended, self._ended = self._ended, []
            self._jobs.put(ended)
        self._raise_pending()

    def close(self) -> None:
        """Wait for the writer; episodes that never ended are not written (whole episodes only)."""
        if self._episodes:
            log.warning("%d unfinished episode(s) not written to the dataset", len(self._episodes))
        self._episodes.clear()
        if self._writer.is_alive():
            self._jobs.put(None)
            self._writer.join()
        self._raise_pending()


# ---------------------------------------------------------------------------------------------- the commit
def commit(layout: LogLayout, ended: list[tuple[Stamped, _Episode]], staged=None) -> None:
    """Commit journalled episodes: the dataset (staged, then swapped in), event rows, result rows.

    ``staged``: the staging copy opened ahead (:func:`_stage`), or None to stage it now.
    """
    in_dataset = set(log_episodes(layout.dataset_dir))
    todo = [(r, e) for r, e in ended if e.frames and r.episode_index not in in_dataset]
    if todo:
        _save_frames(layout.dataset_dir, todo, staged)
    elif staged is not None:
        _discard_staging(layout.dataset_dir)
    for result, episode in ended:  # the results row last: it commits the episode
        write_parquet_atomically(
            joined_to_frames(episode.events, len(episode.frames)), layout.events(result.episode_index)
        )
        write_parquet_atomically(
            [result_row(result, episode.start, len(episode.frames))], layout.results(result.episode_index)
        )
        layout.journal(result.episode_index).unlink(missing_ok=True)


def recover_pending(layout: LogLayout) -> list[int]:
    """Finish what a killed commit left: the dataset swap, then every journalled episode without a
    result row (written once: the dataset says which episodes it holds). The episodes recovered."""
    settle(layout.dataset_dir)
    recovered = []
    for path in journal.journals(layout.pending_dir):
        result, start, frames, events = journal.load(path)  # JournalError: refused by name, nothing runs
        if not layout.results(result.episode_index).exists():
            commit(layout, [(result, _Episode(start, frames, events))])
            recovered.append(result.episode_index)
        path.unlink(missing_ok=True)
    if recovered:
        log.warning(
            "recovered %d episode(s) of %s whose commit was cut short: %s", len(recovered), layout.root, recovered
        )
    return recovered


def log_episodes(dataset_dir: Path) -> list[int]:
    """The log episode index of each episode the dataset holds, in dataset order."""
    path = dataset_dir / LOG_EPISODES
    return json.loads(path.read_text()) if path.exists() else []


def dataset_episode(dataset_dir: Path, log_episode: int) -> int:
    """The dataset's index of a log episode (the same index where the dataset predates the mapping)."""
    held = log_episodes(dataset_dir)
    if not held:
        return log_episode
    if log_episode not in held:
        raise KeyError(f"episode {log_episode} has no frames in {dataset_dir} (it ended before its first step)")
    return held.index(log_episode)


def _journal(layout: LogLayout, result: Stamped, episode: _Episode) -> None:
    data = journal.dumps(result, episode.start, episode.frames, episode.events)
    write_atomically(layout.journal(result.episode_index), lambda tmp: tmp.write_bytes(data))


def _sibling(dataset_dir: Path, state: str) -> Path:
    return dataset_dir.with_name(f"{dataset_dir.name}.{state}")


def settle(dataset_dir: Path) -> None:
    """Finish or undo a swap a kill cut short, and drop a half-written staging copy."""
    ready, old = _sibling(dataset_dir, "ready"), _sibling(dataset_dir, "old")
    if ready.exists():  # finalized but not yet swapped in: it holds everything the dataset does, and more
        if dataset_dir.exists() and old.exists():
            shutil.rmtree(dataset_dir)
        elif dataset_dir.exists():
            os.replace(dataset_dir, old)
        os.replace(ready, dataset_dir)
    elif not dataset_dir.exists() and old.exists():
        os.replace(old, dataset_dir)
    for leftover in (old, _sibling(dataset_dir, "staging")):
        if leftover.exists():
            shutil.rmtree(leftover)


def _discard_staging(dataset_dir: Path) -> None:
    staging = _sibling(dataset_dir, "staging")
    if staging.exists():
        shutil.rmtree(staging, ignore_errors=True)


def _stage(dataset_dir: Path):
    """A writable copy of the dataset, opened for appending (None where there is no dataset yet).

    A resumed LeRobot session writes new data, video and episode-metadata files and rewrites only
    the top-level files of ``meta/``; those are copied, everything else hard-linked.
    """
    settle(dataset_dir)
    if not (dataset_dir / "meta" / "info.json").exists():
        return None
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    staging = _sibling(dataset_dir, "staging")
    for path in sorted(dataset_dir.rglob("*")):
        target = staging / path.relative_to(dataset_dir)
        if path.is_dir():
            target.mkdir(parents=True, exist_ok=True)
        elif path.parent == dataset_dir / "meta":
            shutil.copy2(path, target)
        else:
            os.link(path, target)
    with _quiet_progress():
        return LeRobotDataset.resume(REPO_ID, root=staging, video_backend=VIDEO_BACKEND)


def _save_frames(dataset_dir: Path, episodes: list[tuple[Stamped, _Episode]], staged) -> None:
    """Write the episodes into the staging copy, finalize it, and swap it in for the dataset."""
    first_image = episodes[0][1].frames[0].image
    shape = None if first_image is None else tuple(first_image.shape)
    staging = _sibling(dataset_dir, "staging")
    dataset = staged if staged is not None else _stage(dataset_dir)
    if dataset is None:
        _discard_staging(dataset_dir)
        dataset = _create(staging, episodes[0][1], shape)
    _check_compatible(dataset, dataset_dir, shape)
    held = log_episodes(staging)
    if dataset.meta.total_episodes != len(held):  # a dataset from before the log-episode index existed
        held = list(range(dataset.meta.total_episodes))
    with _quiet_progress():
        for result, episode in episodes:
            _write(dataset, episode, shape, success=bool(result.event.success))
            held.append(result.episode_index)
        dataset.finalize()
    (staging / LOG_EPISODES).write_text(json.dumps(held))
    ready, old = _sibling(dataset_dir, "ready"), _sibling(dataset_dir, "old")
    os.replace(staging, ready)  # complete: from here on a recovery swaps it in
    if dataset_dir.exists():
        os.replace(dataset_dir, old)
    os.replace(ready, dataset_dir)
    shutil.rmtree(old, ignore_errors=True)


def _create(root: Path, episode: _Episode, shape: tuple[int, int, int] | None):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    return LeRobotDataset.create(
        REPO_ID,
        fps=CONTROL_FREQ,
        features=features(shape),
        root=root,
        robot_type=episode.start.robot,
        use_videos=shape is not None,
        video_backend=VIDEO_BACKEND,
    )


def _check_compatible(dataset, dataset_dir: Path, shape: tuple[int, int, int] | None) -> None:
    """Refuse to append to a dataset whose features differ from this version's (older logs, or a camera mismatch)."""
    if (CAMERA_KEY in dataset.features) != (shape is not None):
        raise ValueError(
            f"{dataset_dir} was recorded {'with' if shape is None else 'without'} a camera; "
            "log runs with and without cameras into different directories"
        )
    for key, wanted in features(shape).items():
        have = dataset.features.get(key)
        if have is None or have["dtype"] != wanted["dtype"] or tuple(have["shape"]) != tuple(wanted["shape"]):
            raise ValueError(
                f"{dataset_dir} was written by an older version ({key}: {have and have['dtype']} "
                f"{have and tuple(have['shape'])}, this version writes {wanted['dtype']} {tuple(wanted['shape'])}); "
                "log into a new directory"
            )


def _write(dataset, episode: _Episode, shape, *, success: bool) -> None:
    last = len(episode.frames) - 1
    for i, frame in enumerate(episode.frames):
        done = i == last
        values = {
            "observation.state": frame.state,
            "observation.environment_state": frame.environment_state,
            "action": frame.action,
            "next.reward": np.array([1.0 if done and success else 0.0], dtype=np.float32),  # sparse: success at the end
            "next.done": np.array([done]),
            "next.success": np.array([done and success]),
            "task": episode.start.task or f"{episode.start.task_id} on {episode.start.robot}",
        }
        if shape is not None:
            values[CAMERA_KEY] = np.asarray(frame.image, dtype=np.uint8)
        dataset.add_frame(values)
    dataset.save_episode()


@contextmanager
def _quiet_progress():
    """``datasets`` draws a progress bar per saved episode; a run's own bar is the one to watch."""
    import datasets

    was_disabled = datasets.utils.are_progress_bars_disabled()
    datasets.utils.disable_progress_bars()
    try:
        yield
    finally:
        if not was_disabled:
            datasets.utils.enable_progress_bars()
