"""Where a run's records came from: the commits its episodes ran at, crashes, ``results.json``."""

from __future__ import annotations

from collections import Counter

from lerobot_policy_recent.evaluation.metrics import aggregate, split_crashed


def results_document(records: list[dict], header: dict, runs: list[dict] = ()) -> dict:
    """``DIR/results.json``: what ran, on which LM, code and machine, and every aggregate (crashed
    episodes are listed apart and in no aggregate). ``runs`` are the headers of every ``recent bench``
    call that filled the directory."""
    ran, broken = split_crashed(records)
    commits = episode_commits(records, runs)
    return {
        **header,
        "commit": single_clean_commit(commits),
        "commits": dict(commits),
        "episodes": len(ran),
        "crashed": [crash_entry(r) for r in broken],
        **aggregate(ran),
    }


UNRECORDED = "unrecorded"


def episode_commits(records: list[dict], runs: list[dict] = ()) -> Counter:
    """Episodes per commit their code came from. A record from before records were stamped counts
    under its directory's commit where every run of the directory names the same one."""
    named = {run.get("git_commit") for run in runs}
    fallback = next(iter(named)) if len(named) == 1 else None
    return Counter(r.get("commit") or fallback or UNRECORDED for r in records)


def single_clean_commit(commits: Counter) -> str | None:
    """The one commit every episode ran at, or None: several commits, local edits or an unknown one."""
    if len(commits) != 1:
        return None
    (commit,) = commits
    return None if commit == UNRECORDED or commit.endswith("+dirty") else commit


def commit_line(records: list[dict]) -> str:
    """The report's word on the code: one commit, or how many episodes ran at each."""
    commits = episode_commits(records)
    one = single_clean_commit(commits)
    if one:
        return f"code: commit {one[:12]}"
    return f"code: **not one clean commit** (episodes per commit: {commit_counts(commits)})"


def commit_counts(commits: Counter, digits: int = 12) -> str:
    """``abc123 (40), def456+dirty (2)``: the episodes per commit, most first, local edits kept visible."""
    return ", ".join(f"{short_commit(c, digits)} ({n})" for c, n in commits.most_common())


def short_commit(commit: str, digits: int = 12) -> str:
    """A commit's first ``digits`` hex digits, with its ``+dirty`` kept; "not recorded" where it was not."""
    if commit == UNRECORDED:
        return "not recorded"
    sha, plus, suffix = commit.partition("+")
    return sha[:digits] + plus + suffix


def crash_entry(record: dict) -> dict:
    error = record.get("crashed") or record.get("failure_message", "")
    return {k: record.get(k) for k in ("method", "task_id", "target", "seed")} | {"error": error}


def crash_lines(broken: list[dict]) -> list[str]:
    """The report's list of crashed episodes (re-run them with ``recent bench ... --retry_crashed``)."""
    if not broken:
        return []
    lines = [
        f"## Crashed episodes ({len(broken)}, in no figure above)",
        "",
        "An error broke these off before the env gave a verdict; they are failures to investigate, not "
        "results. `recent bench ... --retry_crashed` runs them again.",
        "",
    ]
    lines += [
        f"- {e['method']} {e['task_id']} on {e['target']} seed {e['seed']}: {e['error']}"
        for e in map(crash_entry, broken)
    ]
    return [*lines, ""]
