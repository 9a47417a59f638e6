"""``recent logs verify``: every file readable, the three logs agreeing episode by episode; recovery.

For each committed episode (one with a results row) the MCAP, the Rerun recording, the
grounding-event table and the LeRobotDataset must hold the same number of events and steps.
``recover`` salvages the MCAP and Rerun files of episodes a crash interrupted: an MCAP cut short
is rewritten, record by record up to the cut, into a valid file with its summary; a Rerun
recording is re-encoded with ``rerun rrd merge --continue-on-error``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from lerobot_policy_recent.logs.layout import LogLayout, episode_number
from lerobot_policy_recent.logs.readers import dataset_lengths, read_mcap, read_rrd, read_table, salvage_mcap_records


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
        check.steps["results"] = int(contents["results"][0]["num_frames"])
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
    """One recovered file: where from, where to, and what it holds (read back from the copy)."""

    source: str
    target: str
    steps: int
    events: int

    def __str__(self) -> str:
        return f"{self.source} -> {self.target} ({self.steps} steps, {self.events} events)"


def recover(root: str | Path) -> list[Salvaged]:
    """Salvage the MCAP and Rerun files of interrupted episodes into ``*.recovered.*`` beside them."""
    out = []
    for path in interrupted_files(LogLayout(Path(root))):
        target = recovered_path(path)
        if path.suffix == ".mcap":
            recover_mcap(path, target)
            contents = read_mcap(target)
            out.append(Salvaged(str(path), str(target), contents.steps, len(contents.events)))
        elif path.suffix == ".rrd":
            recover_rrd(path, target)
            rrd = read_rrd(target)
            out.append(Salvaged(str(path), str(target), rrd.steps, rrd.events))
    return out


def recover_mcap(source: Path, target: Path) -> int:
    """Copy every intact schema, channel and message into a new, finished MCAP; returns the messages kept."""
    from mcap.writer import Writer

    records = salvage_mcap_records(source)
    kinds = {"Schema": [], "Channel": [], "Message": []}
    for record in records:
        kinds.get(type(record).__name__, []).append(record)
    with open(target, "wb") as stream:
        writer = Writer(stream, use_chunking=False)
        writer.start(profile="", library="lerobot_policy_recent (recovered)")
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


def recover_rrd(source: Path, target: Path) -> None:
    """Re-encode what Rerun can still decode of a recording cut short."""
    subprocess.run(
        [rerun_executable(), "rrd", "merge", "--continue-on-error", "-o", str(target), str(source)],
        check=True,
        capture_output=True,
        env={**os.environ, "RUST_LOG": "error"},
    )


def rerun_executable() -> str:
    """The ``rerun`` CLI installed with rerun-sdk in this environment."""
    beside = Path(sys.executable).parent / "rerun"
    found = str(beside) if beside.exists() else shutil.which("rerun")
    if found is None:
        raise FileNotFoundError("the `rerun` command was not found; it comes with rerun-sdk (pip install rerun-sdk)")
    return found
