"""What one benchmark episode is (a :class:`Job` of a :class:`BenchConfig`) and how a worker runs it.

A worker process holds one :class:`EpisodeRunner`: it loads the LM once and shares it between the
agents of all methods, so every method runs on the same backend and model (a ``method@model`` row
on the model it names, loaded once too). Its record of an
episode is the episode's own record (``recent run --json``) plus the job; an error that breaks an
episode off is a record too (a ``crash``). The episode's logs are captured in memory and handed
back with the record (an :class:`Outcome`): the driver alone writes them, into one log directory
and one LeRobotDataset per run, wherever the worker ran.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from urllib.parse import quote

from lerobot_policy_recent.descriptions.embodiments import EMBODIMENTS
from lerobot_policy_recent.evaluation.methods import settings_for
from lerobot_policy_recent.logs.recorder import CapturedEpisode, Recorder
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.failures import FailureCategory
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.robosuite_envs.splits import SPLITS, no_test_split, split_of
from lerobot_policy_recent.robosuite_envs.suites import SEEDS, SUITES, get_suite

SUITE_TARGETS = {
    suite + version: targets
    for suite, targets in (("kinematic", ("UR5e", "Sawyer")), ("end_effector", ("Robotiq85", "Suction")))
    for version in ("", "-v1")
}


@dataclass(frozen=True)
class Job:
    method: str
    suite: str
    task_id: str
    target: str
    seed: int

    def record_path(self, out: Path) -> Path:
        task = self.task_id.split("/")[-1]
        row = quote(self.method, safe="@+-._")  # a row on a GGUF path: one directory, not a path
        return out / "episodes" / row / self.target / f"{task}__s{self.seed}.json"


def log_dir(out: Path) -> Path:
    """A run's one log directory (MCAP, Rerun, the LeRobotDataset, events and results of every episode)."""
    return out / "logs"


@dataclass
class BenchConfig:
    out: Path
    suites: tuple[str, ...] = ("kinematic",)
    targets: tuple[str, ...] = ()  # empty: each suite's own targets (SUITE_TARGETS)
    methods: tuple[str, ...] = ("recent",)
    seeds: tuple[int, ...] = SEEDS
    tasks: tuple[str, ...] = ()  # task names or ids within the suites; empty: all
    variations: str = "mix"  # every variation in play, each in its stated share of episodes (variations.MIX_SHARES)
    workers: int = 0  # Ray workers (each holds one LM); 0: as many as the cluster's CPUs hold
    cpus_per_worker: float | None = None  # CPUs a worker reserves (None: 2, or the CPUs shared by `workers`)
    gpus_per_worker: float | None = None  # GPUs a worker reserves (None: 1 for a transformers LM on a GPU cluster)
    ray_address: str | None = None  # an existing Ray cluster (None: $RAY_ADDRESS, else a local instance)
    log_sinks: tuple[str, ...] = ("mcap", "rerun", "dataset")  # the driver's sinks; empty: no logs
    retry_crashed: bool = False  # run again the episodes whose record says an error broke them off
    split: str = "all"  # all, or only the dev or the held-out test episodes (robosuite_envs/splits.py)
    agent: RecentSettings = field(default_factory=RecentSettings)
    extra: tuple[Job, ...] = ()  # episodes named one by one, after the suites' (the transfer matrix's cells)

    def jobs(self) -> list[Job]:
        """Every episode of the run, episode by episode with every method on each in turn: a run
        stopped part way leaves every method on the same episodes, ready for paired comparison.
        (A worker keeps each method's groundings across episodes, so this order grounds no more.)"""
        if self.split not in ("all", *SPLITS):
            raise ValueError(f"unknown split {self.split!r}; choose from all, {', '.join(SPLITS)}")
        if self.split == "test" and no_test_split():
            raise ValueError(f"--split test: {no_test_split()}")
        jobs = []
        for suite in self.suites:
            specs = get_suite(suite)
            chosen = [s for s in specs if not self.tasks or {s.task_id, s.task_id.split("/")[-1]} & set(self.tasks)]
            for spec in chosen:
                for target in self.targets or SUITE_TARGETS[suite]:
                    for seed in self.seeds:
                        if self.split in ("all", split_of(spec.task_id, seed)):
                            jobs += [Job(method, suite, spec.task_id, target, seed) for method in self.methods]
        jobs += [job for job in self.extra if self.split in ("all", split_of(job.task_id, job.seed))]
        robots = [t for t in self.targets if t not in EMBODIMENTS]
        if robots:
            raise ValueError(f"unknown target(s) {', '.join(robots)}; known robots: {', '.join(EMBODIMENTS)}")
        known = {t for suite in self.suites for s in get_suite(suite) for t in (s.task_id, s.task_id.split("/")[-1])}
        unknown = sorted(set(self.tasks) - known)
        if unknown:
            elsewhere = sorted(
                {
                    name
                    for name, specs in SUITES.items()
                    for s in specs
                    for t in unknown
                    if t in (s.task_id, s.task_id.split("/")[-1])
                }
            )
            hint = f" (they are in --suite {','.join(elsewhere)})" if elsewhere else ""
            raise ValueError(f"unknown task(s) {', '.join(unknown)} in suite(s) {', '.join(self.suites)}{hint}")
        return jobs


# ---------------------------------------------------------------------------------------------- one worker
class EpisodeRunner:
    """Runs episodes of one bench config in one process: loads each model once (the run's at the
    start, a ``method@model`` row's at its first episode); the agents on one model share it."""

    def __init__(self, config: BenchConfig) -> None:
        self.config = config
        # by backend settings; the run's own LM is loaded now, so a worker that cannot load it says so at start
        self.infillers: dict[str, Infiller] = {
            repr(config.agent.infiller): config.agent.infiller.build(config.agent.lm_seed)
        }
        self.agents: dict[str, RecentAgent] = {}

    def agent(self, row: str) -> RecentAgent:
        if row not in self.agents:
            shared = next(iter(self.agents.values()), None)
            settings = settings_for(row, self.config.agent)
            key = repr(settings.infiller)
            if key not in self.infillers:
                self.infillers[key] = settings.infiller.build(settings.lm_seed)
            self.agents[row] = RecentAgent(
                settings, infiller=self.infillers[key], ontology=shared.ontology if shared else None
            )
        return self.agents[row]

    def run(self, job: Job) -> Outcome:
        """One episode of ``job``: its record (a failure to run is a record too) and its captured logs."""
        from lerobot_policy_recent.recent_plugin.episode import run_episode

        config = self.config
        recorder = Recorder.in_memory() if config.log_sinks else None
        started = time.perf_counter()
        try:
            agent = self.agent(job.method)
            result = run_episode(
                agent,
                job.task_id,
                agent.source_robot(job.task_id) if agent.settings.method.on_source else job.target,
                seed=job.seed,
                variations=config.variations,
                recorder=recorder,
            )
            record = episode_record(job, result)
        except Exception as exc:  # noqa: BLE001 - a crashed episode is a failed record, the run goes on
            record = crash_record(job, f"{type(exc).__name__}: {exc}", time.perf_counter() - started)
        captured = recorder.captured if recorder is not None else []
        return Outcome(record, captured[0] if captured else None)


@dataclass
class Outcome:
    """What a worker hands back for one job: the record, and the episode's logs for the driver to write
    (None without logs, or where the worker was lost mid-episode)."""

    record: dict
    log: CapturedEpisode | None = None


def crash_record(job: Job, reason: str, seconds: float = 0.0) -> dict:
    """The record of an episode that an error broke off: no result (``recent bench --retry_crashed`` reruns it)."""
    return {
        **asdict(job),
        "split": split_of(job.task_id, job.seed),
        "success": False,
        "gc": 0.0,
        "crashed": reason,
        "failure_category": str(FailureCategory.CRASH),
        "wall_seconds": seconds,
    }


def episode_record(job: Job, result) -> dict:
    """One bench record: the job, then the episode's own record (the same one ``recent run --json`` prints)."""
    record = {**asdict(job), "split": split_of(job.task_id, job.seed), **result.to_record()}
    record["success"] = bool(record["success"])
    record["gc"] = float(record["gc"] or 0.0)
    return record
