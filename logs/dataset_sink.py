"""Dataset sink: a LeRobotDataset of the frames, plus grounding-event and result tables, per episode.

Frames and events of an episode are held in memory until it ends; then the episode is written
to the LeRobotDataset (``save_episode`` + ``finalize``, so the dataset on disk is always
complete), its events to ``grounding_events/`` and, last, its result row to ``results/``. An
episode is therefore whole in all three tables or absent from all of them. The tables join on
``episode_index`` (and events on ``frame_index``).
"""

from __future__ import annotations

import json
import logging
import queue
import threading
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from lerobot_policy_recent.logs.events import EpisodeStarted, Stamped, Step
from lerobot_policy_recent.logs.layout import LogLayout, write_parquet_atomically
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
VIDEO_BACKEND = "pyav"  # frames are stored as images, never video; naming one skips LeRobot's torchcodec probe
CAMERA_KEY = "observation.images.front"


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
    if camera_shape is not None:
        out[CAMERA_KEY] = {"dtype": "image", "shape": camera_shape, "names": ["height", "width", "channels"]}
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
        self._ready = None  # the LeRobotDataset opened for the next episode, if one exists on disk
        self._jobs: queue.Queue = queue.Queue()
        self._error: BaseException | None = None
        self._writer = threading.Thread(target=self._work, name="recent-dataset-writer", daemon=True)
        self._writer.start()
        self._jobs.put([])  # first job: open the existing dataset

    def _work(self) -> None:
        while (job := self._jobs.get()) is not None:
            try:
                self._commit(job)
            except BaseException as exc:  # noqa: BLE001 - reported to the recorder on the next call
                log.exception("writing episodes to %s failed", self.layout.root)
                self._error = exc

    def _raise_pending(self) -> None:
        if self._error is not None:
            error, self._error = self._error, None
            raise error

    def _prepare(self) -> None:
        """Open the existing dataset now, not when the next episode ends.

        Opening reads its metadata with worker threads, and the last episode of a ``lerobot-eval``
        run is committed while the interpreter exits, when no thread can start; writing into an
        already opened dataset needs none.
        """
        self._ready = None
        if (self.layout.dataset_dir / "meta" / "info.json").exists():
            from lerobot.datasets.lerobot_dataset import LeRobotDataset

            try:
                with _quiet_progress():
                    self._ready = LeRobotDataset.resume(
                        REPO_ID, root=self.layout.dataset_dir, video_backend=VIDEO_BACKEND
                    )
            except RuntimeError as exc:  # the interpreter is exiting: the next write reopens it, if any
                log.debug("could not open %s ahead of the next episode: %s", self.layout.dataset_dir, exc)

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
        self._ended.append((result, episode))
        if not self._episodes:
            ended, self._ended = self._ended, []
            self._jobs.put(ended)
        self._raise_pending()

    def _commit(self, ended: list[tuple[Stamped, _Episode]]) -> None:
        if not ended:
            self._prepare()
            return
        self._save_frames([(r, e) for r, e in ended if e.frames])
        for r, e in ended:  # the results row last: it marks the episode committed
            write_parquet_atomically(joined_to_frames(e.events, len(e.frames)), self.layout.events(r.episode_index))
            write_parquet_atomically([result_row(r, e.start, len(e.frames))], self.layout.results(r.episode_index))

    def close(self) -> None:
        """Wait for the writer; episodes that never ended are not written (whole episodes only)."""
        if self._episodes:
            log.warning("%d unfinished episode(s) not written to the dataset", len(self._episodes))
        self._episodes.clear()
        if self._writer.is_alive():
            self._jobs.put(None)
            self._writer.join()
        self._raise_pending()

    def _save_frames(self, episodes: list[tuple[Stamped, _Episode]]) -> None:
        if not episodes:
            return
        first_image = episodes[0][1].frames[0].image
        shape = None if first_image is None else tuple(first_image.shape)
        dataset = self._open(episodes[0][0].episode_index, episodes[0][1], shape)
        with _quiet_progress():
            for result, episode in episodes:
                self._write(dataset, episode, shape, success=bool(result.event.success))
            dataset.finalize()
        self._prepare()

    def _open(self, index: int, episode: _Episode, shape: tuple[int, int, int] | None):
        from lerobot.datasets.lerobot_dataset import LeRobotDataset

        root = self.layout.dataset_dir
        dataset, self._ready = self._ready, None
        if dataset is None and (root / "meta" / "info.json").exists():
            dataset = LeRobotDataset.resume(REPO_ID, root=root, video_backend=VIDEO_BACKEND)
        if dataset is None:
            return LeRobotDataset.create(
                REPO_ID,
                fps=CONTROL_FREQ,
                features=features(shape),
                root=root,
                robot_type=episode.start.robot,
                use_videos=False,
                video_backend=VIDEO_BACKEND,
            )
        if dataset.meta.total_episodes != index:
            log.warning(
                "dataset holds %d episodes but this is episode %d; its episode_index will be %d",
                dataset.meta.total_episodes,
                index,
                dataset.meta.total_episodes,
            )
        if "next.done" not in dataset.features:
            raise ValueError(
                f"{root} was written by an older version (no next.done/next.success); log into a new directory"
            )
        if (CAMERA_KEY in dataset.features) != (shape is not None):
            raise ValueError(
                f"{root} was recorded {'with' if shape is None else 'without'} a camera; "
                "log runs with and without cameras into different directories"
            )
        return dataset

    @staticmethod
    def _write(dataset, episode: _Episode, shape, *, success: bool) -> None:
        last = len(episode.frames) - 1
        for i, frame in enumerate(episode.frames):
            done = i == last
            values = {
                "observation.state": frame.state,
                "observation.environment_state": frame.environment_state,
                "action": frame.action,
                "next.reward": np.array(
                    [1.0 if done and success else 0.0], dtype=np.float32
                ),  # sparse: success at the end
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
