"""``recent bench`` on a real Ray cluster on loopback: a head and one worker node, the worker killed mid-run.

Every episode must end exactly once, and the run's outcomes must equal a serial run's (the rule
backend is deterministic and the physics seeded; only timings may differ).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from lerobot_policy_recent.recent_plugin.evaluation.report import results_document
from lerobot_policy_recent.recent_plugin.evaluation.runner import BenchConfig, record_key, run_bench
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.settings import RecentSettings

SLICE = dict(
    suites=("kinematic",),
    targets=("UR5e",),
    methods=("recent", "recent-no-insitu"),
    tasks=("cube_on_plate",),
    seeds=(0, 1, 42),
    log_sinks=(),
    agent=RecentSettings(infiller=RuleConfig()),
)
TIMINGS = {"it", "igt", "igt_cold", "lm_seconds", "wall_seconds"}


@pytest.fixture(scope="module")
def cluster():
    """A head node and a worker node of one CPU each, both on 127.0.0.1 (no other address is used)."""
    mp = pytest.MonkeyPatch()
    mp.setenv("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")  # nodes take the loopback address, not the host's
    mp.setenv("RAY_AUTH_MODE", "disabled")  # a throwaway cluster on loopback: no token to hand around
    mp.setenv("RAY_USAGE_STATS_ENABLED", "0")
    mp.delenv("RAY_ADDRESS", raising=False)
    import ray
    from ray._private import ray_constants
    from ray.cluster_utils import Cluster

    mp.setattr(ray_constants, "ENABLE_RAY_CLUSTER", False)  # in case ray was imported before the env was set
    if ray.is_initialized():
        ray.shutdown()
    head_args = {"num_cpus": 1, "node_ip_address": "127.0.0.1", "include_dashboard": False}
    local = Cluster(initialize_head=True, head_node_args=head_args)
    worker = local.add_node(num_cpus=1, node_ip_address="127.0.0.1")
    yield local, worker
    local.shutdown()
    mp.undo()


def outcomes(records: list[dict]) -> dict:
    """Each episode's record without its timings and placement, by episode."""
    skip = TIMINGS | {"node", "worker_seconds", "ray_overhead_seconds", "grounding_cached", "log_dir"}
    return {record_key(r): {k: v for k, v in r.items() if k not in skip} for r in records}


def aggregates(records: list[dict]) -> dict:
    """results.json's figures that do not measure time."""
    document = results_document(records, {})
    return {
        "episodes": document["episodes"],
        "crashed": document["crashed"],
        "by_setting": {
            s: {k: v for k, v in figures.items() if k not in TIMINGS} for s, figures in document["by_setting"].items()
        },
    }


def test_a_killed_worker_node_loses_no_episode_and_changes_no_outcome(cluster, tmp_path: Path):
    local, worker_node = cluster
    serial = run_bench(
        BenchConfig(out=tmp_path / "serial", workers=1, cpus_per_worker=1, ray_address=local.address, **SLICE)
    )
    assert serial.plan["workers"] == 1 and len(serial.ran) == 6

    ended, retried = [], []

    def on_record(record: dict) -> None:
        ended.append(record_key(record))
        if len(ended) == 1:  # both workers are busy (one episode each): take the worker node away
            local.remove_node(worker_node, allow_graceful=False)

    run = run_bench(
        BenchConfig(out=tmp_path / "ray", workers=2, cpus_per_worker=1, ray_address=local.address, **SLICE),
        on_record=on_record,
        on_retry=lambda job, reason: retried.append((job, reason)),
    )
    assert run.plan["engine"] == "ray" and run.plan["workers"] == 2
    assert retried and all(reason.startswith("worker lost") for _, reason in retried)
    assert len(ended) == len(set(ended)) == 6  # every episode ended exactly once, the lost one included
    assert not any(r.get("crashed") for r in run.records)
    assert outcomes(run.records) == outcomes(serial.records)
    assert aggregates(run.records) == aggregates(serial.records)
    assert all(r["ray_overhead_seconds"] >= 0 for r in run.ran)
