"""The Ray cluster scenario of tests/test_ray_cluster.py, run in a fresh process.

A head and a worker node of one CPU each start on 127.0.0.1; a serial run, then a 2-worker run that
loses the worker node after its first episode ends. Prints one JSON line of what happened. (Ray does
not support connecting a process to a second cluster after it shut down its first: the tests' own
process has run local Ray instances by then, so the scenario gets a process of its own.)
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"  # nodes take the loopback address, not the host's
os.environ["RAY_AUTH_MODE"] = "disabled"  # a throwaway cluster on loopback: no token to hand around
os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
os.environ.pop("RAY_ADDRESS", None)

from ray.cluster_utils import Cluster  # noqa: E402

from lerobot_policy_recent.evaluation.compare import compare_records  # noqa: E402
from lerobot_policy_recent.evaluation.report.provenance import results_document  # noqa: E402
from lerobot_policy_recent.evaluation.runner import BenchConfig, record_key, run_bench  # noqa: E402
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig  # noqa: E402
from lerobot_policy_recent.recent_plugin.settings import RecentSettings  # noqa: E402

SLICE = dict(
    suites=("kinematic-v1",),
    targets=("UR5e",),
    methods=("recent", "recent-no-insitu"),
    tasks=("cube_on_plate",),
    seeds=(0, 1, 42),
    log_sinks=(),
    agent=RecentSettings(infiller=RuleConfig()),
)
TIMINGS = {"it", "igt", "igt_cold", "lm_seconds", "wall_seconds"}


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


def main(out: Path) -> None:
    local = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "node_ip_address": "127.0.0.1"})
    worker_node = local.add_node(num_cpus=1, node_ip_address="127.0.0.1")
    try:
        common = dict(cpus_per_worker=1, ray_address=local.address, **SLICE)
        serial = run_bench(BenchConfig(out=out / "serial", workers=1, **common))
        ended, retried = [], []

        def on_record(record: dict) -> None:
            ended.append(str(record_key(record)))
            if len(ended) == 1:  # both workers are busy (one episode each): take the worker node away
                local.remove_node(worker_node, allow_graceful=False)

        run = run_bench(
            BenchConfig(out=out / "ray", workers=2, **common),
            on_record=on_record,
            on_retry=lambda job, reason: retried.append(reason),
        )
    finally:
        local.shutdown()
    print(
        json.dumps(
            {
                "serial_workers": serial.plan["workers"],
                "serial_ran": len(serial.ran),
                "plan": run.plan,
                "ended": ended,
                "retried": retried,
                "crashed": [r["crashed"] for r in run.records if r.get("crashed")],
                # `recent bench compare`'s episode-by-episode check, on every episode of the slice
                "same_outcomes": len(same := compare_records(serial.records, run.records)) == 6
                and all(c.reproduced for c in same),
                "same_aggregates": aggregates(run.records) == aggregates(serial.records),
                "overheads": [r["ray_overhead_seconds"] for r in run.ran],
            }
        )
    )


if __name__ == "__main__":
    main(Path(sys.argv[1]))
