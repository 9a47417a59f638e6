"""The recorder: stamps typed events and control steps and fans them out to the sinks.

The agent only ever calls :meth:`EpisodeLog.emit` / :meth:`EpisodeLog.step`; a sink that raises
is reported once and switched off for the rest of the run, so logging can never stop a robot.
Sinks never call back into the agent.

A recorder :meth:`~Recorder.in_memory` keeps its episodes as :class:`CapturedEpisode` s instead of
writing files; :meth:`Recorder.write` logs such an episode into a run's files later, in another
process or on another machine (``recent bench``: Ray workers capture, the driver alone writes one
log directory and one dataset for the whole run).
"""

from __future__ import annotations

import logging
import shutil
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Protocol

import numpy as np

from lerobot_policy_recent.logs.events import EpisodeEnded, EpisodeStarted, Event, Stamped, Step
from lerobot_policy_recent.logs.layout import LogLayout, episode_number, write_parquet_atomically
from lerobot_policy_recent.robosuite_envs.primitives.session import CONTROL_FREQ

log = logging.getLogger(__name__)

SINKS = ("mcap", "rerun", "dataset")


class Sink(Protocol):
    def begin(self, start: Stamped) -> None: ...

    def event(self, stamped: Stamped) -> None: ...

    def step(self, step: Step) -> None: ...

    def end(self, result: Stamped) -> None: ...

    def close(self) -> None: ...


def make_sinks(layout: LogLayout, names: Sequence[str]) -> list[Sink]:
    unknown = sorted(set(names) - set(SINKS))
    if unknown:
        raise ValueError(f"unknown log sink(s) {', '.join(unknown)}; choose from {', '.join(SINKS)}")
    sinks: list[Sink] = []
    if "mcap" in names:
        from lerobot_policy_recent.logs.mcap_sink import McapSink

        sinks.append(McapSink(layout))
    if "rerun" in names:
        from lerobot_policy_recent.logs.rerun_sink import RerunSink

        sinks.append(RerunSink(layout.rrd))
    if "dataset" in names:
        from lerobot_policy_recent.logs.dataset_sink import DatasetSink

        sinks.append(DatasetSink(layout))
    return sinks


@dataclass
class CapturedEpisode:
    """One episode's stamped events and steps, in the order the sinks received them."""

    items: list[tuple[str, Stamped | Step]] = field(default_factory=list)  # (sink method, what it got)

    @property
    def started(self) -> EpisodeStarted:
        return self.items[0][1].event  # type: ignore[union-attr]

    @property
    def steps(self) -> int:
        return sum(1 for method, _ in self.items if method == "step")


class CaptureSink:
    """Keeps each episode in memory until it ends; :attr:`ended` holds the finished ones."""

    def __init__(self) -> None:
        self._open: dict[int, CapturedEpisode] = {}
        self.ended: list[CapturedEpisode] = []

    def begin(self, start: Stamped) -> None:
        self._open[start.episode_index] = CapturedEpisode([("begin", start)])

    def event(self, stamped: Stamped) -> None:
        self._open[stamped.episode_index].items.append(("event", stamped))

    def step(self, step: Step) -> None:
        self._open[step.episode_index].items.append(("step", step))

    def end(self, result: Stamped) -> None:
        episode = self._open.pop(result.episode_index, None)
        if episode is not None:
            episode.items.append(("end", result))
            self.ended.append(episode)

    def close(self) -> None:
        self._open.clear()


class Recorder:
    """One run's logs under ``root``; episodes are numbered on from the ones already committed there."""

    def __init__(self, root: str | Path | None, sinks: Sequence[str] = SINKS):
        """``root=None``: write nothing and keep each ended episode in :attr:`captured` (see :meth:`in_memory`)."""
        self.failed: dict[str, str] = {}  # sink class -> the error that switched it off
        self.layout = None if root is None else LogLayout(Path(root))
        if self.layout is None:
            self._next = self._first = 0
            self.sinks: list[Sink] = [CaptureSink()]
            return
        self.layout.root.mkdir(parents=True, exist_ok=True)
        if self.layout.pending_dir.is_dir() or "dataset" in sinks:  # whichever sinks this run uses
            from lerobot_policy_recent.logs.dataset_sink import recover_pending

            recover_pending(self.layout)  # episodes that ended but whose commit a kill cut short
        self._next = self._first = self.layout.next_episode()
        set_aside_interrupted(self.layout, self._next)
        self.sinks = make_sinks(self.layout, sinks)

    @classmethod
    def in_memory(cls) -> Recorder:
        """A recorder that writes nothing: its episodes wait in :attr:`captured` for another's :meth:`write`."""
        return cls(None)

    @property
    def captured(self) -> list[CapturedEpisode]:
        """The ended episodes of an :meth:`in_memory` recorder."""
        return [e for s in self.sinks if isinstance(s, CaptureSink) for e in s.ended]

    def write(self, episode: CapturedEpisode) -> int:
        """Log a captured episode as this run's next one, with its own stamps; its index here."""
        index = self._next
        self._next += 1
        for method, item in episode.items:
            self._fan_out(method, replace(item, episode_index=index))
        self._commit(replace(episode.items[-1][1], episode_index=index), episode.started, episode.steps)
        return index

    @property
    def last_episode(self) -> int | None:
        """Index of the most recently started episode (None before the first)."""
        return self._next - 1 if self._next > self._first else None

    def _commit(self, result: Stamped, started: EpisodeStarted, frames: int) -> None:
        """Write the result row that commits an ended episode, unless a sink (the dataset's) does."""
        if self.layout is None or any(type(s).__name__ in ("DatasetSink", "CaptureSink") for s in self.sinks):
            return
        from lerobot_policy_recent.logs.dataset_sink import result_row

        write_parquet_atomically([result_row(result, started, frames)], self.layout.results(result.episode_index))

    def start_episode(self, started: EpisodeStarted) -> EpisodeLog:
        episode = EpisodeLog(self, self._next, started)
        self._next += 1
        self._fan_out("begin", episode.stamp(started))
        return episode

    def _fan_out(self, method: str, item: Stamped | Step | None = None) -> None:
        for sink in list(self.sinks):
            try:
                getattr(sink, method)(*(() if item is None else (item,)))
            except Exception as exc:  # noqa: BLE001 - a broken sink must never stop the robot
                name = type(sink).__name__
                self.failed[name] = f"{type(exc).__name__}: {exc}"
                log.exception("log sink %s failed in %s and is switched off for this run", name, method)
                self.sinks.remove(sink)

    def close(self) -> None:
        self._fan_out("close")

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class EpisodeLog:
    """The handle the agent's loop holds for one episode: ``emit`` events, ``step`` frames, ``end``."""

    def __init__(self, recorder: Recorder, index: int, started: EpisodeStarted):
        self.recorder = recorder
        self.index = index
        self.started = started
        self.frame_index = 0
        self.ended = False

    def stamp(self, event: Event) -> Stamped:
        return Stamped(event, self.index, self.frame_index, time.time_ns())

    def emit(self, event: Event) -> None:
        self.recorder._fan_out("event", self.stamp(event))

    def step(
        self, state: np.ndarray, environment_state: np.ndarray, action: np.ndarray, image=None, truth=None
    ) -> None:
        """Record the observation acted on and the action taken; the next events belong to the next step.

        ``truth``: the objects' exact poses (simulator truth, ``environment_state``'s layout), where the
        caller has the simulator; logs show it apart from what the robot perceived, and no policy reads it."""
        self.recorder._fan_out(
            "step",
            Step(
                self.index,
                self.frame_index,
                self.frame_index / CONTROL_FREQ,
                time.time_ns(),
                np.asarray(state, dtype=np.float32),
                np.asarray(environment_state, dtype=np.float32),
                np.asarray(action, dtype=np.float32),
                image,
                None if truth is None else np.asarray(truth, dtype=np.float32),
            ),
        )
        self.frame_index += 1

    def end(self, result: EpisodeEnded) -> None:
        if not self.ended:
            self.ended = True
            stamped = self.stamp(result)
            self.recorder._fan_out("end", stamped)
            self.recorder._commit(stamped, self.started, self.frame_index)


def set_aside_interrupted(layout: LogLayout, next_episode: int) -> list[Path]:
    """Move files of episodes that never committed out of the way, so new episodes do not overwrite them."""
    moved = []
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for folder in (layout.mcap_dir, layout.rerun_dir, layout.events_dir):
        for path in sorted(folder.glob("episode_*")) if folder.exists() else []:
            if episode_number(path) >= next_episode:
                target = layout.interrupted_dir / f"{stamp}_{path.name}"
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.move(path, target)
                moved.append(target)
    if moved:
        log.warning(
            "%d file(s) of interrupted episodes moved to %s; `recent logs verify %s --recover` salvages them",
            len(moved),
            layout.interrupted_dir,
            layout.root,
        )
    return moved
