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
from dataclasses import dataclass, field

import numpy as np

from logs.events import EpisodeStarted, Stamped, Step
from logs.layout import LogLayout, write_parquet_atomically
from robosuite_envs.observation import ACTION_DIM, AGENT_POS_DIM, ENV_STATE_DIM
from robosuite_envs.primitives.session import CONTROL_FREQ

log = logging.getLogger(__name__)

REPO_ID = "local/recent_episodes"  # the dataset's id until it is uploaded under a real one
CAMERA_KEY = "observation.images.front"


def features(camera_shape: tuple[int, int, int] | None) -> dict:
    out = {
        "observation.state": {"dtype": "float32", "shape": (AGENT_POS_DIM,), "names": None},
        "observation.environment_state": {"dtype": "float32", "shape": (ENV_STATE_DIM,), "names": None},
        "action": {"dtype": "float32", "shape": (ACTION_DIM,), "names": None},
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


@dataclass
class _Episode:
    start: EpisodeStarted
    frames: list[Step] = field(default_factory=list)
    events: list[dict] = field(default_factory=list)


class DatasetSink:
    def __init__(self, layout: LogLayout):
        self.layout = layout
        self._episodes: dict[int, _Episode] = {}

    def begin(self, start: Stamped) -> None:
        self._episodes[start.episode_index] = _Episode(start.event)  # type: ignore[arg-type]
        self.event(start)

    def event(self, stamped: Stamped) -> None:
        self._episodes[stamped.episode_index].events.append(event_row(stamped))

    def step(self, step: Step) -> None:
        self._episodes[step.episode_index].frames.append(step)

    def end(self, result: Stamped) -> None:
        episode = self._episodes.pop(result.episode_index, None)
        if episode is None:
            return
        episode.events.append(event_row(result))
        if episode.frames:
            self._save_frames(result.episode_index, episode)
        write_parquet_atomically(episode.events, self.layout.events(result.episode_index))
        row = {"episode_index": result.episode_index, "num_frames": len(episode.frames), **result.event.payload()}
        row.update(backend=episode.start.backend, model=episode.start.model, mode=episode.start.mode)
        row.update(variations=episode.start.variations)
        write_parquet_atomically([row], self.layout.results(result.episode_index))

    def close(self) -> None:
        """Episodes that never ended are not written: a dataset holds whole episodes only."""
        if self._episodes:
            log.warning("%d unfinished episode(s) not written to the dataset", len(self._episodes))
        self._episodes.clear()

    def _save_frames(self, index: int, episode: _Episode) -> None:
        from lerobot.datasets.lerobot_dataset import LeRobotDataset

        first_image = episode.frames[0].image
        shape = None if first_image is None else tuple(first_image.shape)
        root = self.layout.dataset_dir
        if (root / "meta" / "info.json").exists():
            dataset = LeRobotDataset.resume(REPO_ID, root=root)
            if dataset.meta.total_episodes != index:
                log.warning(
                    "dataset holds %d episodes but this is episode %d; its episode_index will be %d",
                    dataset.meta.total_episodes,
                    index,
                    dataset.meta.total_episodes,
                )
            if (CAMERA_KEY in dataset.features) != (shape is not None):
                raise ValueError(
                    f"{root} was recorded {'with' if shape is None else 'without'} a camera; "
                    "log runs with and without cameras into different directories"
                )
        else:
            dataset = LeRobotDataset.create(
                REPO_ID,
                fps=CONTROL_FREQ,
                features=features(shape),
                root=root,
                robot_type=episode.start.robot,
                use_videos=False,
            )
        for frame in episode.frames:
            values = {
                "observation.state": frame.state,
                "observation.environment_state": frame.environment_state,
                "action": frame.action,
                "task": episode.start.task or f"{episode.start.task_id} on {episode.start.robot}",
            }
            if shape is not None:
                values[CAMERA_KEY] = np.asarray(frame.image, dtype=np.uint8)
            dataset.add_frame(values)
        dataset.save_episode()
        dataset.finalize()
