"""Ray as the engine of ``recent bench``: one episode a Ray task, on a local instance or a cluster.

Each worker is a Ray actor that loads the LM once and keeps it (and its agents' grounding caches)
across episodes; it reserves the CPUs its LM threads and simulator use, and a GPU for a
``transformers`` LM when asked. The driver keeps every worker busy with one episode at a time and
hands each record back as it ends, so the caller writes it at once: a killed driver loses only
the episodes in flight. A worker that dies (its process or its node) is dropped and its episode
goes back to the queue, up to :data:`MAX_ATTEMPTS` times; after that the episode is a ``crash``
record that ``--retry_crashed`` runs again.
"""

from __future__ import annotations

import os
import time
from collections import Counter, deque
from collections.abc import Callable, Iterator
from dataclasses import replace

from lerobot_policy_recent.evaluation.jobs import BenchConfig, EpisodeRunner, Job, Outcome, crash_record
from lerobot_policy_recent.recent_plugin.extras import optional

MAX_ATTEMPTS = 3  # an episode whose worker died this often is recorded as a crash, not retried for ever
DEFAULT_CPUS_PER_WORKER = 2  # the protocol's LM threads (the paper's timings are for 2 threads)
WORKER_NICENESS_ENV = "RAY_worker_niceness"  # read by Ray when it starts a local instance's workers
# Forwarded to a cluster's workers (a local instance inherits the whole environment anyway).
FORWARDED_ENV = ("RECENT_", "MUJOCO_GL", "PYOPENGL_PLATFORM", "HF_", "XDG_CACHE_HOME")


class EpisodeWorker:
    """The Ray actor: one process, one loaded LM, episodes one after another."""

    def __init__(self, config: BenchConfig, env: dict[str, str]) -> None:
        os.environ.update(env)  # the driver's RECENT_* settings, before anything reads them
        self.error: Exception | None = None
        try:
            self.runner = EpisodeRunner(config)
        except Exception as exc:  # noqa: BLE001 - handed to the driver by ready(), with its own type
            self.error = exc

    def ready(self) -> Exception | None:
        """None once the LM is loaded; else what stopped it (a missing model, a bad setting)."""
        return self.error

    def run(self, job: Job) -> Outcome:
        import ray

        if self.error is not None:  # a replacement worker whose LM did not load: the driver says why
            raise self.error
        started = time.perf_counter()
        outcome = self.runner.run(job)
        outcome.record["worker_seconds"] = round(time.perf_counter() - started, 4)
        outcome.record["node"] = ray.get_runtime_context().get_node_id()[:12]
        outcome.record["worker_niceness"] = os.nice(0)  # the CPU priority the episode ran at
        return outcome


def plan_workers(config: BenchConfig, cluster_cpus: float, cluster_gpus: float) -> dict:
    """How many workers, with which resources: ``--workers`` and ``--cpus_per_worker`` as given, else
    as many 2-CPU workers as the cluster holds (at least one), each LM on as many threads as it reserves."""
    if config.cpus_per_worker is not None:
        cpus = config.cpus_per_worker
    elif config.workers:
        cpus = min(float(DEFAULT_CPUS_PER_WORKER), cluster_cpus / config.workers)  # Ray takes fractions
    else:
        cpus = float(min(DEFAULT_CPUS_PER_WORKER, max(1, cluster_cpus)))
    workers = config.workers or max(1, int(cluster_cpus // cpus))
    if workers * cpus > cluster_cpus + 1e-9:  # the rest would wait for CPUs that never come
        raise ValueError(
            f"{workers} workers x {cpus:g} CPUs need {workers * cpus:g} CPUs; the Ray cluster has {cluster_cpus:g}: "
            "lower --workers or --cpus_per_worker"
        )
    gpus = config.gpus_per_worker
    if gpus is None:
        on_gpu = (
            config.agent.infiller.backend == "transformers" and getattr(config.agent.infiller, "device", None) != "cpu"
        )
        gpus = 1.0 if on_gpu and cluster_gpus >= 1 else 0.0
    return {"engine": "ray", "workers": workers, "cpus_per_worker": cpus, "gpus_per_worker": gpus}


class RayEngine:
    """Connects to Ray (or starts a local instance) for one run, and runs its episodes on workers."""

    def __init__(self, config: BenchConfig) -> None:
        self.config = config
        self.plan: dict = {"engine": "ray"}
        self._owned = False

    def __enter__(self) -> RayEngine:
        address = self.config.ray_address or os.environ.get("RAY_ADDRESS") or None
        if address is None:
            # A local instance listens on loopback only (Ray otherwise binds the host's address for other nodes).
            os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
            # Its workers run the episodes, which are what a run measures: at Ray's default niceness (15)
            # the driver's log writer took half the CPU of an episode's LM calls on a 2-core host.
            os.environ.setdefault(WORKER_NICENESS_ENV, "0")
        os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
        ray = optional("ray", "recent bench")

        if not ray.is_initialized():
            ray.init(
                # "local": a new instance for this run, never whatever cluster was started last on this host
                address=address or "local",
                include_dashboard=False,
                log_to_driver=False,  # workers' output stays in Ray's session logs; records carry the errors
                logging_level="warning",
            )
            self._owned = True
        resources = ray.cluster_resources()
        try:
            self.plan = plan_workers(self.config, resources.get("CPU", 1.0), resources.get("GPU", 0.0))
        except ValueError:
            self.__exit__()  # the instance this run started goes with it
            raise
        self.plan["address"] = address or "local"
        return self

    def __exit__(self, *exc) -> None:
        if self._owned:
            import ray

            ray.shutdown()

    def _settings(self):
        """The agent settings a worker runs with: an LM with no thread count uses the CPUs its worker reserves."""
        agent = self.config.agent
        if getattr(agent.infiller, "n_threads", 0) is None:
            threads = max(1, int(self.plan["cpus_per_worker"]))
            agent = replace(agent, infiller=replace(agent.infiller, n_threads=threads))
        return agent

    def _start_worker(self):
        import ray

        actor = ray.remote(EpisodeWorker).options(
            num_cpus=self.plan["cpus_per_worker"], num_gpus=self.plan["gpus_per_worker"], max_restarts=0
        )
        # The environment travels with the worker (not as a Ray runtime env, which needs the node's
        # runtime-env agent): a cluster's nodes were started from other shells.
        env = {k: v for k, v in os.environ.items() if k.startswith(FORWARDED_ENV)}
        return actor.remote(replace(self.config, agent=self._settings()), env)

    def run(self, jobs: list[Job], *, on_retry: Callable[[Job, str], None] | None = None) -> Iterator[Outcome]:
        """Every job's outcome, in the order they end; lost workers' episodes are run again elsewhere."""
        if not jobs:
            return
        import ray
        from ray.exceptions import ActorDiedError, ActorUnavailableError, NodeDiedError, RayActorError

        lost_worker = (RayActorError, ActorDiedError, ActorUnavailableError, NodeDiedError)
        starting = time.perf_counter()
        workers = [self._start_worker() for _ in range(min(self.plan["workers"], len(jobs)))]
        for error in ray.get([w.ready.remote() for w in workers]):
            if error is not None:
                raise error  # the LM did not load: the same error a single episode would give
        self.plan["start_seconds"] = round(time.perf_counter() - starting, 2)  # processes up, LMs loaded
        queue, attempts = deque(jobs), Counter()
        idle = list(workers)
        in_flight: dict = {}  # ObjectRef -> (worker, job, submitted at)

        def feed() -> None:
            while idle and queue:
                worker, job = idle.pop(), queue.popleft()
                in_flight[worker.run.remote(job)] = (worker, job, time.perf_counter())

        feed()
        while in_flight:
            (ref,), _ = ray.wait(list(in_flight), num_returns=1)
            worker, job, submitted = in_flight.pop(ref)
            try:
                outcome = ray.get(ref)
            except lost_worker as error:
                ray.kill(worker)
                workers.remove(worker)
                attempts[job] += 1
                reason = f"worker lost: {type(error).__name__}"
                if attempts[job] < MAX_ATTEMPTS:
                    queue.appendleft(job)
                    if on_retry is not None:
                        on_retry(job, reason)
                else:
                    yield Outcome(crash_record(job, f"{reason} ({attempts[job]} times)"))
                if not workers and queue:  # every worker is gone: start one (it waits for the cluster's resources)
                    workers.append(self._start_worker())
                    idle.append(workers[-1])
                feed()
                continue
            # what Ray added to the episode: scheduling, transfer and result handling, not the episode itself
            record = outcome.record
            record["ray_overhead_seconds"] = round(time.perf_counter() - submitted - record["worker_seconds"], 4)
            yield outcome
            idle.append(worker)
            feed()
