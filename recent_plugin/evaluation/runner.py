"""Run the benchmark's episodes: one JSON record per (method, task, target, seed), resumable, on Ray.

Each finished episode is written to ``DIR/episodes/<method>/<target>/<task>__s<seed>.json`` as
soon as it ends (atomically), so a restarted run skips what is done. Episodes run on Ray
(:mod:`.ray_engine`): each worker loads the LM once (an :class:`EpisodeRunner`) and shares it
between the agents of all methods, so every method runs on the same backend and model. Episodes
are logged as ``recent run`` logs them, one log directory per episode under ``DIR/logs/``
(MCAP, Rerun, LeRobotDataset, grounding events).
"""

from __future__ import annotations

import gzip
import json
import os
import platform
import shutil
import time
from collections.abc import Callable
from dataclasses import asdict, astuple, dataclass, field, replace
from pathlib import Path

from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.evaluation.methods import settings_for
from lerobot_policy_recent.recent_plugin.evaluation.metrics import crashed
from lerobot_policy_recent.recent_plugin.failures import FailureCategory
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.robosuite_envs.embodiments import EMBODIMENTS
from lerobot_policy_recent.robosuite_envs.suites import SEEDS, get_suite

SUITE_TARGETS = {"kinematic": ("UR5e", "Sawyer"), "end_effector": ("Robotiq85", "Suction")}


@dataclass(frozen=True)
class Job:
    method: str
    suite: str
    task_id: str
    target: str
    seed: int

    def record_path(self, out: Path) -> Path:
        task = self.task_id.split("/")[-1]
        return out / "episodes" / self.method / self.target / f"{task}__s{self.seed}.json"

    def log_dir(self, out: Path) -> Path:
        task = self.task_id.split("/")[-1]
        return out / "logs" / self.method / self.target / f"{task}__s{self.seed}"


@dataclass
class BenchConfig:
    out: Path
    suites: tuple[str, ...] = ("kinematic",)
    targets: tuple[str, ...] = ()  # empty: each suite's own targets (SUITE_TARGETS)
    methods: tuple[str, ...] = ("recent",)
    seeds: tuple[int, ...] = SEEDS
    tasks: tuple[str, ...] = ()  # task names or ids within the suites; empty: all
    variations: str = "on"
    workers: int = 0  # Ray workers (each holds one LM); 0: as many as the cluster's CPUs hold
    cpus_per_worker: float | None = None  # CPUs a worker reserves (None: 2, or the CPUs shared by `workers`)
    gpus_per_worker: float | None = None  # GPUs a worker reserves (None: 1 for a transformers LM on a GPU cluster)
    ray_address: str | None = None  # an existing Ray cluster (None: $RAY_ADDRESS, else a local instance)
    log_sinks: tuple[str, ...] = ("mcap", "rerun", "dataset")  # empty: no logs
    retry_crashed: bool = False  # run again the episodes whose record says an error broke them off
    agent: RecentSettings = field(default_factory=RecentSettings)

    def jobs(self) -> list[Job]:
        """Every episode of the run, grouped by method then target so each worker reuses its groundings."""
        jobs = []
        for method in self.methods:
            for suite in self.suites:
                specs = get_suite(suite)
                chosen = [s for s in specs if not self.tasks or {s.task_id, s.task_id.split("/")[-1]} & set(self.tasks)]
                for target in self.targets or SUITE_TARGETS[suite]:
                    for spec in chosen:
                        for seed in self.seeds:
                            jobs.append(Job(method, suite, spec.task_id, target, seed))
        robots = [t for t in self.targets if t not in EMBODIMENTS]
        if robots:
            raise ValueError(f"unknown target(s) {', '.join(robots)}; known robots: {', '.join(EMBODIMENTS)}")
        known = {t for suite in self.suites for s in get_suite(suite) for t in (s.task_id, s.task_id.split("/")[-1])}
        unknown = sorted(set(self.tasks) - known)
        if unknown:
            raise ValueError(f"unknown task(s) {', '.join(unknown)} in suite(s) {', '.join(self.suites)}")
        return jobs


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


# ---------------------------------------------------------------------------------------------- one worker
class EpisodeRunner:
    """Runs episodes of one bench config in one process: loads the LM once; agents of every method share it."""

    def __init__(self, config: BenchConfig) -> None:
        self.config = config
        self.infiller = config.agent.infiller.build(config.agent.lm_seed)
        self.agents: dict[str, RecentAgent] = {}

    def agent(self, method: str) -> RecentAgent:
        if method not in self.agents:
            shared = next(iter(self.agents.values()), None)
            settings = settings_for(method, self.config.agent)
            self.agents[method] = RecentAgent(
                settings, infiller=self.infiller, ontology=shared.ontology if shared else None
            )
        return self.agents[method]

    def run(self, job: Job) -> dict:
        """One episode of ``job``; its record (a failure to run is a record too)."""
        from lerobot_policy_recent.logs.recorder import Recorder
        from lerobot_policy_recent.recent_plugin.episode import run_episode

        config = self.config
        recorder = Recorder(job.log_dir(config.out), config.log_sinks) if config.log_sinks else None
        started = time.perf_counter()
        try:
            result = run_episode(
                self.agent(job.method),
                job.task_id,
                job.target,
                seed=job.seed,
                variations=config.variations,
                recorder=recorder,
            )
        except Exception as exc:  # noqa: BLE001 - a crashed episode is a failed record, the run goes on
            return crash_record(job, f"{type(exc).__name__}: {exc}", time.perf_counter() - started)
        finally:
            if recorder is not None:
                recorder.close()
        return episode_record(job, result, job.log_dir(config.out) if recorder else None)


def crash_record(job: Job, reason: str, seconds: float = 0.0) -> dict:
    """The record of an episode that an error broke off: no result (``recent bench --retry-crashed`` reruns it)."""
    return {
        **asdict(job),
        "success": False,
        "gc": 0.0,
        "crashed": reason,
        "failure_category": str(FailureCategory.CRASH),
        "wall_seconds": seconds,
    }


def episode_record(job: Job, result, log_dir: Path | None) -> dict:
    """One bench record: the job, then the episode's own record (the same one ``recent run --json`` prints)."""
    record = {**asdict(job), **result.to_record(), "log_dir": str(log_dir) if log_dir else None}
    record["success"] = bool(record["success"])
    record["gc"] = float(record["gc"] or 0.0)
    return record


# ---------------------------------------------------------------------------------------------- the run
def pending(config: BenchConfig) -> tuple[list[Job], list[Job]]:
    """(all jobs, the ones without a record yet): what a restarted run still has to do."""
    jobs = config.jobs()
    done = {
        record_key(r)
        for r in load_records(config.out)
        if not (config.retry_crashed and crashed(r))  # a crash is no result: --retry-crashed runs it again
    }
    return jobs, [j for j in jobs if astuple(j) not in done]


def run_bench(
    config: BenchConfig,
    *,
    on_record: Callable[[dict], None] | None = None,
    on_retry: Callable[[Job, str], None] | None = None,
) -> BenchRun:
    """Run every pending episode on Ray; the records of all episodes of ``config`` (old and new)."""
    from lerobot_policy_recent.recent_plugin.evaluation.ray_engine import RayEngine

    jobs, todo = pending(config)
    config.out.mkdir(parents=True, exist_ok=True)
    config = replace(config, out=config.out.resolve())  # workers may start elsewhere (a cluster's nodes)
    ran = []
    with RayEngine(config) as engine:
        for record in engine.run(todo, on_retry=on_retry):
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
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=1, default=str))
    os.replace(tmp, path)


def load_record(path: Path) -> dict:
    return json.loads(path.read_text())


PACKED = "episodes.jsonl.gz"  # a committed run's records, one file instead of one JSON per episode


def record_key(record: dict) -> tuple:
    """The episode a record is of: (method, suite, task id, target, seed), a :class:`Job` as a tuple."""
    return tuple(record[f] for f in ("method", "suite", "task_id", "target", "seed"))


def load_records(out: Path) -> list[dict]:
    """Every episode record of a benchmark directory: its packed file, and its ``episodes/`` files,
    which win where both hold an episode (a packed run's crash, run again with ``--retry-crashed``)."""
    records: dict[tuple, dict] = {}
    if (out / PACKED).is_file():
        with gzip.open(out / PACKED, "rt") as packed:
            records.update((record_key(r), r) for r in map(json.loads, filter(str.strip, packed)))
    records.update((record_key(r), r) for r in map(load_record, sorted((out / "episodes").glob("*/*/*.json"))))
    return list(records.values())


def has_records(out: Path) -> bool:
    return (out / "episodes").is_dir() or (out / PACKED).is_file()


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
