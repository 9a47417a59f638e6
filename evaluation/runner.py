"""Run the benchmark's episodes: one JSON record per (method, task, target, seed), resumable, on Ray.

Each finished episode is written to ``DIR/episodes/<method>/<target>/<task>__s<seed>.json`` as
soon as it ends (atomically), so a restarted run skips what is done. Episodes run on Ray
(:mod:`.ray_engine`), each on a worker that holds one :class:`~.jobs.EpisodeRunner`. Workers
capture each episode's logs and hand them back; the driver writes them, as ``recent run`` would,
into the run's one log directory ``DIR/logs/`` (an MCAP and a Rerun recording per episode, one
LeRobotDataset, the grounding-event and result tables). A record names its episode there
(``log_dir``, ``log_episode``); the log is written before the record, so a record never points
at a log that is not there.
"""

from __future__ import annotations

import gzip
import json
import os
import platform
import shutil
from collections.abc import Callable, Mapping
from contextlib import nullcontext
from dataclasses import astuple, dataclass, replace
from pathlib import Path

from lerobot_policy_recent.evaluation.jobs import SUITE_TARGETS, BenchConfig, Job, log_dir
from lerobot_policy_recent.evaluation.metrics import crashed
from lerobot_policy_recent.evaluation.ray_engine import RayEngine
from lerobot_policy_recent.logs.layout import write_atomically
from lerobot_policy_recent.logs.recorder import Recorder

__all__ = ["SUITE_TARGETS", "BenchConfig", "BenchRun", "Job", "load_records", "machine", "pending", "run_bench"]


def machine() -> dict[str, object]:
    """The machine the numbers come from (they are only comparable on the same one)."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform()}


# ---------------------------------------------------------------------------------------------- the run
def pending(config: BenchConfig) -> tuple[list[Job], list[Job]]:
    """(all jobs, the ones without a record yet): what a restarted run still has to do."""
    jobs = config.jobs()
    done = {
        record_key(r)
        for r in load_records(config.out)
        if not (config.retry_crashed and crashed(r))  # a crash is no result: --retry_crashed runs it again
    }
    return jobs, [j for j in jobs if astuple(j) not in done]


def run_bench(
    config: BenchConfig,
    *,
    on_record: Callable[[dict], None] | None = None,
    on_retry: Callable[[Job, str], None] | None = None,
    stamp: Mapping[str, object] | None = None,
) -> BenchRun:
    """Run every pending episode on Ray; the records of all episodes of ``config`` (old and new).

    ``stamp`` goes into every record this call writes: ``recent bench`` stamps the commit the code
    came from, so a directory filled over several sessions says episode by episode what ran it."""

    jobs, todo = pending(config)
    config.out.mkdir(parents=True, exist_ok=True)
    config = replace(config, out=config.out.resolve())  # workers may start elsewhere (a cluster's nodes)
    ran = []
    recorder = Recorder(log_dir(config.out), config.log_sinks) if config.log_sinks and todo else None
    with RayEngine(config) as engine, recorder or nullcontext():
        for outcome in engine.run(todo, on_retry=on_retry):
            record = {**outcome.record, **(stamp or {})}
            if recorder is not None and outcome.log is not None:
                record.update(log_dir=str(recorder.layout.root), log_episode=recorder.write(outcome.log))
            write_json(Job(*record_key(record)).record_path(config.out), record)
            ran.append(record)
            if on_record is not None:
                on_record(record)
    wanted = {astuple(j) for j in jobs}
    return BenchRun([r for r in load_records(config.out) if record_key(r) in wanted], ran, engine.plan)


@dataclass
class BenchRun:
    """What a ``run_bench`` call leaves: every record of its grid, the ones it ran now, and how it ran them."""

    records: list[dict]
    ran: list[dict]
    plan: dict


def write_json(path: Path, data: object) -> None:
    """Write whole or not at all: a killed run never leaves half a record behind."""
    text = json.dumps(data, indent=1, default=str)
    write_atomically(path, lambda tmp: tmp.write_text(text))


def load_record(path: Path) -> dict:
    return json.loads(path.read_text())


PACKED = "episodes.jsonl.gz"  # a committed run's records, one file instead of one JSON per episode


def record_key(record: dict) -> tuple:
    """The episode a record is of: (method, suite, task id, target, seed), a :class:`Job` as a tuple."""
    return tuple(record[f] for f in ("method", "suite", "task_id", "target", "seed"))


def load_records(out: Path) -> list[dict]:
    """Every episode record of a benchmark directory: its packed file, and its ``episodes/`` files,
    which win where both hold an episode (a packed run's crash, run again with ``--retry_crashed``)."""
    records: dict[tuple, dict] = {}
    if (out / PACKED).is_file():
        with gzip.open(out / PACKED, "rt") as packed:
            records.update((record_key(r), r) for r in map(json.loads, filter(str.strip, packed)))
    records.update((record_key(r), r) for r in map(load_record, sorted((out / "episodes").glob("*/*/*.json"))))
    return list(records.values())


def has_records(out: Path) -> bool:
    return (out / "episodes").is_dir() or (out / PACKED).is_file()


LM_CALLS = "lm_calls.jsonl.gz"  # what each LM was asked and answered, and what validation said, for review
LM_EVENTS = ("infill_call", "validation_verdict", "patch_applied")


def lm_call_rows(out: Path) -> list[dict]:
    """Every prompt, answer, verdict and patch of a run, each with its episode (method, task, robot,
    seed), in episode and event order: from its logs (``DIR/logs/grounding_events``), and for the
    episodes whose logs are gone, from its packed ``lm_calls.jsonl.gz``.

    A committed run extended without its logs (copied without ``logs/``, then run on) keeps the rows
    its file already had for episodes the logs no longer hold. A log counts for the record that
    points at it only where its first event names the same task, robot and seed: the extension's
    logs are numbered from 0 again, and must not be read as the old episodes."""
    from lerobot_policy_recent.logs.layout import LogLayout, episode_number
    from lerobot_policy_recent.logs.readers import read_table

    claims: dict[int, list[dict]] = {}
    for record in load_records(out):
        if record.get("log_episode") is not None:
            claims.setdefault(record["log_episode"], []).append(record)
    rows, logged = [], set()
    for path in sorted(LogLayout(log_dir(out)).events_dir.glob("*.parquet")):
        events = read_table(path)
        started = next((json.loads(e["payload"]) for e in events if e["event"] == "episode_started"), {})
        seen = (started.get("task_id"), started.get("robot"), started.get("seed"))
        owners = [r for r in claims.get(episode_number(path), []) if (r["task_id"], r["target"], r["seed"]) == seen]
        if len(owners) != 1:
            continue  # no record of that episode (crashed and not run again), or none that can be told apart
        record = owners[0]
        episode = {"method": record["method"], "task_id": record["task_id"], "robot": record["target"]}
        logged.add(lm_call_episode({**episode, "seed": record["seed"]}))
        for order, row in enumerate(events):
            if row["event"] in LM_EVENTS:
                rows.append({**episode, "seed": record["seed"], "order": order, "event": row["event"]})
                rows[-1].update(json.loads(row["payload"]))
    if (out / LM_CALLS).is_file():  # what an earlier pack kept, for the episodes whose logs are gone
        with gzip.open(out / LM_CALLS, "rt") as packed:
            earlier = [json.loads(line) for line in packed if line.strip()]
        rows += [row for row in earlier if lm_call_episode(row) not in logged]
    rows.sort(key=lambda r: (r["method"], r["task_id"], r["robot"], str(r["seed"]), r["order"]))
    return rows


def pack_lm_calls(out: Path) -> int:
    """``lm_call_rows`` of a run into one compressed file a reviewer can read without the logs: why a
    method's program failed. How many rows (0 where there are none, and no file)."""
    rows = lm_call_rows(out)
    if not rows:
        return 0
    with open(out / LM_CALLS, "wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", mtime=0) as packed:
        packed.write("".join(json.dumps(r, sort_keys=True, default=str) + "\n" for r in rows).encode())
    return len(rows)


def lm_call_episode(row: dict) -> tuple:
    """The episode a row of ``lm_calls.jsonl.gz`` belongs to: (method, task id, robot, seed)."""
    return row["method"], row["task_id"], row["robot"], row["seed"]


def pack_records(out: Path) -> int:
    """Move every episode record of ``out`` into its packed file (for committing a finished run); how many."""
    records = load_records(out)
    key = ("method", "suite", "task_id", "target", "seed")
    records.sort(key=lambda r: tuple(str(r.get(k)) for k in key))
    tmp = out / (PACKED + ".tmp")
    with open(tmp, "wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", mtime=0) as packed:  # same bytes each time
        packed.write("".join(json.dumps(r, sort_keys=True, default=str) + "\n" for r in records).encode())
    os.replace(tmp, out / PACKED)
    if (out / "episodes").is_dir():
        shutil.rmtree(out / "episodes")
    return len(records)
