"""What the whole-program methods wrote, counted from a run's recorded prompts and answers.

A baseline at GC 0 is only believable with the reason in numbers. This module reads every program
that a baseline wrote (first programs and regenerations, from ``lm_call_rows``) and counts four things.
How many do not parse. How many call a function that the target robot lacks. How many of those call
the source robot's name for it, copied from the example. How many regenerations repeat, call for call,
a program that the same episode had already written for the same skill. The counts come from the
committed ``lm_calls.jsonl.gz`` (or the run's logs), so a reader can reproduce them and read the
programs behind them.
"""

from __future__ import annotations

import ast
import builtins
import functools
from collections import defaultdict
from dataclasses import dataclass

from lerobot_policy_recent.descriptions.apis import api_spec_path
from lerobot_policy_recent.descriptions.embodiments import EMBODIMENTS
from lerobot_policy_recent.evaluation.baselines.program_prompt import PROGRAM
from lerobot_policy_recent.evaluation.methods import ONTOLOGY_METHODS, method_of, method_rank
from lerobot_policy_recent.ontology.specs import load_api_spec
from lerobot_policy_recent.skills.repository import SkillNotFoundError, load_skill

SAFE_CALLS = frozenset(dir(builtins))  # len, range, abs… : Python's, not a robot's


@functools.cache
def primitives(robot: str) -> frozenset[str]:
    """The primitive names of a bundled embodiment's API spec, as the executor reads them (empty for
    a robot this package does not know)."""
    embodiment = EMBODIMENTS.get(robot)
    return frozenset(load_api_spec(api_spec_path(embodiment.api)).names()) if embodiment else frozenset()


@functools.cache
def source_robot(skill: str) -> str | None:
    """The robot that the bundled skill was written for (None where the skill is not bundled)."""
    try:
        return load_skill(skill).source_embodiment
    except SkillNotFoundError:
        return None


def called_names(program: str) -> list[str] | None:
    """The plain function names that a program body calls, in order (None where it does not parse).
    A body is recorded as the model wrote it after the ``def`` line: its first line unindented."""
    try:
        tree = ast.parse("def _program():\n    " + program)
    except SyntaxError:
        return None
    defined = {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}  # helpers the program writes
    nodes = sorted(
        (n for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)),
        key=lambda n: (n.lineno, n.col_offset),
    )
    return [n.func.id for n in nodes if n.func.id not in defined]


@dataclass
class ProgramCounts:
    """One method's programs: how many, and how many of each kind of flaw."""

    method: str
    programs: int = 0
    unparsable: int = 0
    foreign: int = 0  # call at least one function the target lacks (not a builtin, not defined in the program)
    copied: int = 0  # ... of which at least one is the source robot's primitive of that name
    regenerations: int = 0  # programs after the first for the same episode and skill
    repeated: int = 0  # regenerations that call what an earlier program of the episode's skill called, in order

    def share(self, count: int) -> str:
        return f"{count} ({100.0 * count / self.programs:.0f} %)" if self.programs else "–"


def program_counts(rows: list[dict]) -> list[ProgramCounts]:
    """Per whole-program method (every method that does not ground through the ontology), in the
    tables' method order: what its recorded programs call. Rows are read in episode and event order."""
    counts: dict[str, ProgramCounts] = {}
    earlier: dict[tuple, list[tuple[str, ...] | None]] = defaultdict(list)  # per episode and skill
    for row in rows:
        method = row["method"]
        if (
            row.get("event") != "infill_call"
            or row.get("span_type") != PROGRAM
            or method_of(method) in ONTOLOGY_METHODS
        ):
            continue
        tally = counts.setdefault(method, ProgramCounts(method))
        tally.programs += 1
        names = called_names(str(row.get("completion") or ""))
        episode = (method, row["task_id"], row["robot"], row["seed"], row.get("skill"))
        regenerated = bool(earlier[episode])  # after a failure, or a pre-execution detector's finding
        tally.regenerations += regenerated
        if names is None:
            tally.unparsable += 1
            earlier[episode].append(None)
            continue
        target = primitives(row["robot"])
        missing = {n for n in names if n not in target and n not in SAFE_CALLS}
        tally.foreign += bool(missing)
        source = source_robot(row.get("skill") or "")
        tally.copied += bool(source and missing & primitives(source))
        calls = tuple(names)
        tally.repeated += regenerated and calls in earlier[episode]
        earlier[episode].append(calls)
    return sorted(counts.values(), key=lambda c: (method_rank(method_of(c.method)), c.method))


def program_table(rows: list[dict]) -> str | None:
    """The markdown table of ``program_counts`` (None where no whole program was recorded)."""
    counts = program_counts(rows)
    if not counts:
        return None
    lines = [
        "| method | programs | do not parse | call a function the target lacks | ... the source robot's "
        "primitive | regenerations | repeating an earlier program's calls |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for c in counts:
        repeated = f"{c.repeated} of {c.regenerations}" if c.regenerations else "–"
        lines.append(
            f"| {c.method} | {c.programs} | {c.share(c.unparsable)} | {c.share(c.foreign)} | {c.share(c.copied)} "
            f"| {c.regenerations} | {repeated} |"
        )
    return "\n".join(lines)
