"""``recent bench`` on a real Ray cluster on loopback: a head and one worker node, the worker killed mid-run.

Every episode must end exactly once, and the run's outcomes must equal a serial run's (the rule
backend is deterministic and the physics seeded; only timings may differ). The scenario runs in a
process of its own (tests/ray_cluster_scenario.py): Ray cannot join a second cluster from a process
that already ran and shut down another instance, as this test process has.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

SCENARIO = Path(__file__).with_name("ray_cluster_scenario.py")


def test_a_killed_worker_node_loses_no_episode_and_changes_no_outcome(tmp_path: Path):
    done = subprocess.run([sys.executable, str(SCENARIO), str(tmp_path)], capture_output=True, text=True, timeout=540)
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["serial_workers"] == 1 and result["serial_ran"] == 6
    assert result["plan"]["engine"] == "ray" and result["plan"]["workers"] == 2
    assert result["retried"] and all(reason.startswith("worker lost") for reason in result["retried"])
    assert len(result["ended"]) == len(set(result["ended"])) == 6  # every episode ended exactly once
    assert result["crashed"] == []
    assert result["same_outcomes"] and result["same_aggregates"]  # as the serial run, episode by episode
    assert all(overhead >= 0 for overhead in result["overheads"])
