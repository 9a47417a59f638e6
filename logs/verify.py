"""``recent logs verify``: every file readable, the three logs agreeing episode by episode; recovery.

For each committed episode (one with a results row) the MCAP, the Rerun recording, the
grounding-event table and the LeRobotDataset must hold the same number of events and steps, and
that number must be the env's own count of the episode's steps where it reported one
(``env_steps``: a batched ``lerobot-eval`` must not log frames of an auto-reset episode).
Journals of episodes whose commit is pending must be data this version wrote.
``recover`` salvages the MCAP and Rerun files of episodes a crash interrupted: an MCAP cut short
is rewritten, record by record up to the cut, into a valid file with its summary. The Rerun
recording is rebuilt from that episode's MCAP, which is flushed after every step, so it loses at
most the step in flight (the live ``.rrd`` may lack its last quarter second of buffered steps);
without an MCAP it is re-encoded as far as it goes with ``rerun rrd merge --continue-on-error``.
"""

from __future__ import annotations

import os
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

from lerobot_policy_recent.logs import journal
from lerobot_policy_recent.logs.layout import LogLayout, episode_number
from lerobot_policy_recent.logs.readers import dataset_lengths, read_mcap, read_rrd, read_table, salvage_mcap_records
from lerobot_policy_recent.logs.replay import replay_mcap
from lerobot_policy_recent.logs.rerun_sink import rerun_executable


@dataclass
class EpisodeCheck:
    episode: int
    steps: dict[str, int] = field(default_factory=dict)  # log -> control steps it holds
    events: dict[str, int] = field(default_factory=dict)  # log -> grounding events it holds
    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems


@dataclass
class VerifyReport:
    root: Path
    episodes: list[EpisodeCheck] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)  # not tied to one committed episode
    recovered: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems and all(e.ok for e in self.episodes)


def verify(root: str | Path) -> VerifyReport:
    layout = LogLayout(Path(root))
    report = VerifyReport(layout.root)
    if not layout.root.is_dir():
        report.problems.append(f"{layout.root} is not a directory")
        return report
    try:
        lengths = dataset_lengths(layout.dataset_dir)
    except Exception as exc:  # noqa: BLE001 - an unreadable dataset is a finding, not a crash
        report.problems.append(f"dataset {layout.dataset_dir}: unreadable ({type(exc).__name__}: {exc})")
        lengths = {}
    for episode in layout.committed():
        report.episodes.append(_check_episode(layout, episode, lengths))
    for path in interrupted_files(layout):
        salvaged = recovered_path(path)
        if salvaged.exists():
            report.recovered.append(f"{path.name}: recovered as {salvaged}")
        else:
            report.problems.append(f"{path}: episode never finished (`--recover` salvages it)")
    for path in journal.journals(layout.pending_dir):
        try:
            journal.load(path)  # data only: reading it runs nothing
        except journal.JournalError as exc:
            report.problems.append(str(exc))
        else:
            report.recovered.append(
                f"{path.name}: ended, its commit pending (the next run into {layout.root} commits it)"
            )
    if not report.episodes and not report.problems and not report.recovered:
        report.problems.append(f"{layout.root} holds no logged episode (a log directory has results/, mcap/ or rerun/)")
    return report


def interrupted_files(layout: LogLayout) -> list[Path]:
    """MCAP and Rerun files of episodes that never committed (crashed runs), wherever they are."""
    committed = set(layout.committed())
    found = [
        p
        for folder in (layout.mcap_dir, layout.rerun_dir)
        if folder.exists()
        for p in sorted(folder.glob("episode_*"))
        if episode_number(p) not in committed
    ]
    if layout.interrupted_dir.exists():
        found += sorted(p for p in layout.interrupted_dir.glob("*") if p.suffix in (".mcap", ".rrd"))
    return [p for p in found if ".recovered." not in p.name]


def recovered_path(path: Path) -> Path:
    return path.with_name(f"{path.stem}.recovered{path.suffix}")


def _check_episode(layout: LogLayout, episode: int, lengths: dict[int, int]) -> EpisodeCheck:
    check = EpisodeCheck(episode)
    readers = {
        "results": lambda: read_table(layout.results(episode)),
        "events": lambda: read_table(layout.events(episode)),
        "mcap": lambda: read_mcap(layout.mcap(episode)),
        "rerun": lambda: read_rrd(layout.rrd(episode)),
    }
    contents = {}
    for name, read in readers.items():
        try:
            contents[name] = read()
        except FileNotFoundError:
            continue  # that sink was off for the run
        except Exception as exc:  # noqa: BLE001
            check.problems.append(f"{name}: unreadable ({type(exc).__name__}: {exc})")
    if "results" in contents:
        row = contents["results"][0]
        check.steps["results"] = int(row["num_frames"])
        env_steps = row.get("env_steps")
        if env_steps is not None and int(env_steps) != check.steps["results"]:
            check.problems.append(
                f"the env ended this episode after {int(env_steps)} steps, but {check.steps['results']} frames were "
                "logged (frames of another episode, or missing ones)"
            )
    if "events" in contents:
        check.events["events"] = len(contents["events"])
    if "mcap" in contents:
        check.steps["mcap"], check.events["mcap"] = contents["mcap"].steps, len(contents["mcap"].events)
        if not contents["mcap"].complete:
            check.problems.append("mcap: no summary/footer")
    if "rerun" in contents:
        check.steps["rerun"], check.events["rerun"] = contents["rerun"].steps, contents["rerun"].events
    if episode in lengths:
        check.steps["dataset"] = lengths[episode]
    elif lengths:
        check.problems.append("dataset: episode missing")
    for what, counts in (("steps", check.steps), ("events", check.events)):
        if len(set(counts.values())) > 1:
            check.problems.append(f"{what} disagree: " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    return check


# ---------------------------------------------------------------------------------------- recovery
@dataclass(frozen=True)
class Salvaged:
    """One recovered file: where from, where to, how, and what it holds (read back from the copy)."""

    source: str
    target: str
    steps: int
    events: int
    how: str = "rewritten"  # rewritten (MCAP) | rebuilt from MCAP | re-encoded (Rerun, no MCAP)

    def __str__(self) -> str:
        return f"{self.source} -> {self.target} ({self.how}: {self.steps} steps, {self.events} events)"


def recover(root: str | Path) -> list[Salvaged]:
    """Salvage the MCAP and Rerun files of interrupted episodes into ``*.recovered.*`` beside them."""
    layout = LogLayout(Path(root))
    out = []
    for path in interrupted_files(layout):
        target = recovered_path(path)
        if path.suffix == ".mcap":
            recover_mcap(path, target)
            contents = read_mcap(target)
            out.append(Salvaged(str(path), str(target), contents.steps, len(contents.events)))
        elif path.suffix == ".rrd":
            how = recover_rrd(path, target, mcap=partner_mcap(layout, path))
            rrd = read_rrd(target)
            out.append(Salvaged(str(path), str(target), rrd.steps, rrd.events, how))
    return out


def partner_mcap(layout: LogLayout, rrd: Path) -> Path | None:
    """The MCAP the same episode wrote beside a Rerun recording, if that sink was on."""
    path = layout.mcap(episode_number(rrd)) if rrd.parent == layout.rerun_dir else rrd.with_suffix(".mcap")
    return path if path.exists() else None


def recover_mcap(source: Path, target: Path) -> int:
    """Copy every intact schema, channel and message into a new, finished MCAP; returns the messages kept."""
    from lerobot_policy_recent.logs.mcap_sink import rewrite_mcap

    return rewrite_mcap(salvage_mcap_records(source), target, library="lerobot_policy_recent (recovered)")


def recover_rrd(source: Path, target: Path, *, mcap: Path | None = None) -> str:
    """Recover a recording cut short: rebuilt from the episode's ``mcap`` where there is one (every
    step but the one in flight), else re-encoded as far as Rerun can still decode it. Returns how."""
    if mcap is not None:
        try:
            replay_mcap(mcap, target)
            return "rebuilt from MCAP"
        except ValueError:  # not an episode's MCAP (its first event is gone): fall back to the recording
            pass
    subprocess.run(
        [rerun_executable(), "rrd", "merge", "--continue-on-error", "-o", str(target), str(source)],
        check=True,
        capture_output=True,
        env={**os.environ, "RUST_LOG": "error"},
    )
    return "re-encoded"
