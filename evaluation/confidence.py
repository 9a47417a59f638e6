"""95 % bootstrap confidence intervals for SR and GC, and paired comparisons between methods.

The unit resampled is the episode (one task on one target with one seed): an interval says how
much the rate would move under another draw of tasks and seeds of the same kind. A paired
comparison resamples the episodes two methods both ran, so task difficulty cancels out. The
bootstrap is seeded: the same records give the same interval every time.
"""

from __future__ import annotations

import numpy as np

RESAMPLES = 2000
LEVEL = 95.0


def _rates(records: list[dict]) -> dict[str, np.ndarray]:
    success = np.array([bool(r["success"]) for r in records], dtype=float)
    subtasks = np.array([max(1, int(r.get("subtasks") or 1)) for r in records], dtype=float)
    done = np.array([float(r.get("gc") or 0.0) for r in records]) * subtasks
    return {"success": success, "done": done, "subtasks": subtasks}


def _draws(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, n, size=(RESAMPLES, n))


def _interval(samples: np.ndarray) -> list[float]:
    tail = (100.0 - LEVEL) / 2
    low, high = np.percentile(samples, [tail, 100.0 - tail])
    return [round(float(low), 2), round(float(high), 2)]


def rate_intervals(records: list[dict], seed: int = 0) -> dict[str, list[float]]:
    """``{"sr_ci95": [lo, hi], "gc_ci95": [lo, hi]}`` in percent (GC weighted by subtasks, as the table's GC)."""
    if not records:
        return {}
    rates, picks = _rates(records), _draws(len(records), seed)
    sr = 100.0 * rates["success"][picks].mean(axis=1)
    gc = 100.0 * rates["done"][picks].sum(axis=1) / rates["subtasks"][picks].sum(axis=1)
    return {"sr_ci95": _interval(sr), "gc_ci95": _interval(gc)}


def episode_key(record: dict) -> tuple:
    """What makes two methods' episodes the same episode: suite, target, task and seed."""
    return record["suite"], record["target"], record["task_id"], record["seed"]


def paired_difference(method: list[dict], reference: list[dict], seed: int = 0) -> dict | None:
    """SR and GC of ``method`` minus ``reference`` (percentage points) on the episodes both ran, with
    95 % intervals from resampling those shared episodes; None when they share none."""
    mine = {episode_key(r): r for r in method}
    theirs = {episode_key(r): r for r in reference}
    shared = sorted(set(mine) & set(theirs), key=str)
    if not shared:
        return None
    a, b = _rates([mine[k] for k in shared]), _rates([theirs[k] for k in shared])
    picks = _draws(len(shared), seed)
    sr = 100.0 * (a["success"][picks] - b["success"][picks]).mean(axis=1)
    gc = 100.0 * (a["done"][picks].sum(axis=1) - b["done"][picks].sum(axis=1)) / a["subtasks"][picks].sum(axis=1)
    return {
        "episodes": len(shared),
        "sr_diff": round(100.0 * float((a["success"] - b["success"]).mean()), 2),
        "sr_diff_ci95": _interval(sr),
        "gc_diff": round(100.0 * float((a["done"] - b["done"]).sum() / a["subtasks"].sum()), 2),
        "gc_diff_ci95": _interval(gc),
    }


def paired_comparisons(records: list[dict], reference: str = "recent") -> dict[str, dict]:
    """``reference`` against every other method, per suite: ``{"recent vs cap|kinematic": {...}}``."""
    out = {}
    suites = sorted({r["suite"] for r in records})
    methods = sorted({r["method"] for r in records} - {reference})
    for suite in suites:
        base = [r for r in records if r["method"] == reference and r["suite"] == suite]
        for other in methods:
            compared = paired_difference(base, [r for r in records if r["method"] == other and r["suite"] == suite])
            if compared:
                out[f"{reference} vs {other}|{suite}"] = compared
    return out
