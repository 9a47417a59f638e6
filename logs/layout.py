"""Where a run's logs live, so every tool (recorder, verify, replay, report, upload) agrees.

```
DIR/mcap/episode_000003.mcap          one MCAP per episode (Foxglove schemas + JSON grounding events)
DIR/rerun/episode_000003.rrd          one Rerun recording per episode, with its blueprint
DIR/dataset/                          the LeRobotDataset (v3) of observations and actions
DIR/grounding_events/episode_000003.parquet   every grounding event of the episode, one row each
DIR/results/episode_000003.parquet    the episode's result row (SR, GC, GO, EI, IT, IGT, failure)
DIR/interrupted/                      files of episodes that never finished (see `recent logs verify --recover`)
DIR/pending/episode_000003.npz        an ended episode whose dataset commit has not finished (the next run commits it)
```
An episode is committed when its ``results`` file exists: that file is written last.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

_EPISODE = re.compile(r"episode_(\d{6})")


@dataclass(frozen=True)
class LogLayout:
    root: Path

    @property
    def mcap_dir(self) -> Path:
        return self.root / "mcap"

    @property
    def rerun_dir(self) -> Path:
        return self.root / "rerun"

    @property
    def dataset_dir(self) -> Path:
        return self.root / "dataset"

    @property
    def events_dir(self) -> Path:
        return self.root / "grounding_events"

    @property
    def results_dir(self) -> Path:
        return self.root / "results"

    @property
    def interrupted_dir(self) -> Path:
        return self.root / "interrupted"

    @property
    def pending_dir(self) -> Path:
        return self.root / "pending"

    def journal(self, episode: int) -> Path:
        return self.pending_dir / f"{episode_name(episode)}.npz"  # data only (logs/journal.py)

    def mcap(self, episode: int) -> Path:
        return self.mcap_dir / f"{episode_name(episode)}.mcap"

    def rrd(self, episode: int) -> Path:
        return self.rerun_dir / f"{episode_name(episode)}.rrd"

    def events(self, episode: int) -> Path:
        return self.events_dir / f"{episode_name(episode)}.parquet"

    def results(self, episode: int) -> Path:
        return self.results_dir / f"{episode_name(episode)}.parquet"

    def committed(self) -> list[int]:
        """Episodes whose results were written: the ones that finished."""
        return sorted(episode_number(p) for p in self.results_dir.glob("episode_*.parquet"))

    def next_episode(self) -> int:
        committed = self.committed()
        return committed[-1] + 1 if committed else 0


def log_roots(paths: list[str | Path]) -> list[Path]:
    """Each path that is a log directory, or the log directories below it (older ``recent bench`` runs wrote one per episode)."""
    roots: list[Path] = []
    for path in map(Path, paths):
        if (path / "results").is_dir() or (path / "mcap").is_dir():
            roots.append(path)
        else:
            roots += sorted({p.parent for p in path.rglob("results") if p.is_dir()})
    return roots


def episode_name(episode: int) -> str:
    return f"episode_{episode:06d}"


def episode_number(path: Path) -> int:
    match = _EPISODE.search(path.name)
    if match is None:
        raise ValueError(f"{path} is not an episode file (expected a name like episode_000003.*)")
    return int(match.group(1))


def write_atomically(path: Path, write: Callable[[Path], object]) -> None:
    """``write(tmp)`` to a temporary name beside ``path``, then rename: the file is whole or absent, never half written."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    write(tmp)
    os.replace(tmp, path)


def write_parquet_atomically(rows: list[dict], path: Path) -> None:
    write_atomically(path, lambda tmp: pq.write_table(pa.Table.from_pylist(rows), tmp))
