"""The env's verdict on an episode (success, GC), handed to the logs inside ``lerobot-eval``.

There the policy never sees the env's verdict: LeRobot keeps ``info["is_success"]`` to itself. So
the env writes one small JSON file per finished episode into ``<log dir>/verdicts/``, keyed by
task, robot and seed, and the policy's logs take it from there when the episode's result row is
written. The verdict goes to the logs only; the policy's decisions never read it.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path


def verdict_path(log_dir: str | Path, task_id: str, robot: str, seed: int) -> Path:
    return Path(log_dir) / "verdicts" / f"{task_id.replace('/', '__')}__{robot}__s{seed}.json"


@dataclass(frozen=True)
class Verdict:
    success: bool
    gc: float
    steps: int | None  # the env's own count of the episode's steps (the logs must hold as many frames)


def write_verdict(
    log_dir: str | Path, task_id: str, robot: str, seed: int, success: bool, gc: float, steps: int
) -> Path:
    """Written whole or not at all (write, then rename)."""
    path = verdict_path(log_dir, task_id, robot, seed)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps({"success": bool(success), "gc": float(gc), "steps": int(steps)}))
    os.replace(tmp, path)
    return path


def take_verdict(log_dir: str | Path, task_id: str, robot: str, seed: int) -> Verdict | None:
    """That episode's verdict, removing its file; None where the env wrote none (or not one of ours)."""
    path = verdict_path(log_dir, task_id, robot, seed)
    try:
        data = json.loads(path.read_text())
        verdict = Verdict(bool(data["success"]), float(data["gc"]), int(data["steps"]) if "steps" in data else None)
    except (OSError, ValueError, KeyError, TypeError):
        return None
    path.unlink(missing_ok=True)
    return verdict
