"""The transfer matrix: every skill of the library on every embodiment, and how its grounding came about.

A cell is one (skill, robot) pair. Its grounding is one of:

* ``source`` — the robot the skill is written for;
* ``ontology`` — valid, every span decided by the ontology (no LM token);
* ``lm`` — valid, with spans the LM decided (their calls and seconds are the cell's);
* ``refused`` — the robot lacks a capability the skill needs: a call no primitive of the robot has
  the effects of, and no path the robot's moves can trace; named before anything runs;
* ``invalid`` — grounding failed validation (the last rejection is the reason).

A cell that is refused but whose grounding the LM got through validation anyway is flagged
``defect``: the grounding could have known. The matrix is written as JSON, a markdown table and a
PNG heatmap (``recent transfer``).
"""

from __future__ import annotations

import ast
import json
import textwrap
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path

from lerobot_policy_recent.ontology.builder import Ontology
from lerobot_policy_recent.ontology.diagnosis import Diagnosis, diagnose
from lerobot_policy_recent.ontology.skill_code import object_of_point, position_names
from lerobot_policy_recent.recent_plugin.extras import pyplot
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill
from lerobot_policy_recent.recent_plugin.refactoring.substitution import has_placeholders, render_substitute_call
from lerobot_policy_recent.recent_plugin.refactoring.units import at_indent
from lerobot_policy_recent.skills.repository import Skill, load_skills

GROUNDINGS = ("source", "ontology", "lm", "refused", "invalid")
SYMBOLS = {"source": "·", "ontology": "O", "lm": "L", "refused": "–", "invalid": "✗"}
PAR = 0.95  # a cell is at par where its successes are at least this share of the source's on the same episodes


@dataclass
class Execution:
    """One cell under one variation setting: its successes and the source robot's on the same episodes.
    An episode a check refused by name as infeasible for this robot (a target it cannot reach) is kept
    apart from the gaps: the cell is at par on the episodes it did not refuse."""

    variations: str
    episodes: int = 0
    successes: int = 0
    source_successes: int = 0
    gaps: list[str] = field(default_factory=list)  # "seed S: failure" where the source succeeded and it did not
    refusals: list[str] = field(default_factory=list)  # "seed S: reason" where the source succeeded and it refused

    @property
    def feasible_source_successes(self) -> int:
        """The source's successes on the episodes this robot did not refuse."""
        return self.source_successes - len(self.refusals)

    @property
    def at_par(self) -> bool:
        return self.successes >= PAR * self.feasible_source_successes

    def render(self) -> str:
        return f"{self.successes}/{self.episodes}" + (f" ({len(self.refusals)} refused)" if self.refusals else "")


@dataclass
class Decision:
    """One argument the LM wrote where the ontology's rendering gives the answer the code implies
    (the object a point stands for, a name, a converted value): the paper's method asks the LM for
    every conflicting span, the product's fast path only for what no rendering decides."""

    role: str  # the substitute parameter's role: the decision's type
    expected: str  # the rendering's answer: an object's position as such, else its expression
    attempts: int  # the LM's answers for its span
    right_first: bool  # the first answer decided it as the code implies
    right: bool  # the accepted answer did (False where none was accepted)


@dataclass
class Cell:
    skill: str
    robot: str
    grounding: str  # one of GROUNDINGS
    reason: str = ""  # why refused or invalid
    igt_seconds: float = 0.0  # grounding time (a few ms where it came from the grounding cache)
    cached: bool = False
    lm_calls: int = 0  # calls an LM answered (the fast path's renderings and the rule backend are none)
    generated_tokens: int = 0
    defect: bool = False  # refused by the ontology, yet validated: the grounding could have known
    execution: dict[str, Execution] = field(default_factory=dict)  # by variation setting (``off``, ``on``)
    decisions: list[Decision] = field(default_factory=list)  # the LM's, where the code implies the answer


def classify(grounded: GroundedSkill, source: str, keyed: Diagnosis | None = None) -> Cell:
    """The cell of one grounding (see the module's docstring). A span is the LM's when an accepted
    call was not decided completely by the ontology (``LMCall.decided``). ``keyed``: the diagnosis
    with the answers the task's plan implies (:func:`answer_key`), which scores open decisions."""
    cell = Cell(grounded.skill, grounded.robot, "source" if grounded.robot == source else "ontology")
    cell.lm_calls = sum(not c.rendered for c in grounded.calls) if grounded.backend != "rule" else 0
    cell.generated_tokens = grounded.generated_tokens
    if cell.grounding == "source":
        return cell
    missing = [c for c in grounded.diagnosis.conflicts if c.refused]
    if missing:
        cell.grounding, cell.reason = "refused", f"line {missing[0].span.line}: {missing[0].reason}"
        cell.defect = grounded.valid
    elif not grounded.valid:
        cell.grounding = "invalid"
        cell.reason = grounded.verdict.message if grounded.verdict is not None else "not validated"
    elif any(c.accepted and not c.decided for c in grounded.calls):
        cell.grounding = "lm"
    cell.decisions = scored_decisions(grounded, keyed)
    return cell


def answer_key(
    onto: Ontology, skill: Skill, robot: str, references: Mapping[str, Mapping[str, str]]
) -> Diagnosis | None:
    """The diagnosis of ``skill`` on ``robot`` with the placements its subtask's reference skill
    declares (``references``: subtask -> placements, :func:`reference_placements`), where the skill
    declares none: where the task's plan says each object ends, so a receptacle the code leaves open
    has the answer the plan implies. None where there is no such reference (the skill's own
    placements already decide what they can)."""
    placements = references.get(skill.subtask)
    if skill.placed_over or not placements:
        return None
    return diagnose(onto, skill.name, skill.code, robot, skill.source_embodiment, placements)


def reference_placements() -> dict[str, dict[str, str]]:
    """Where each subtask's reference skill (the bundled library's) says the objects it moves end."""
    return {s.subtask: s.placed_over for s in load_skills()[0] if s.placed_over}


def scored_decisions(grounded: GroundedSkill, keyed: Diagnosis | None = None) -> list[Decision]:
    """Each argument of a span the LM answered whose rendering is complete (no ``<type>`` left), its
    first and its accepted answer scored against that rendering, argument by argument: the
    substitute's and those of the calls made before it (a cup's move over the box it lets go in).
    A span the ontology left open is scored against its rendering in ``keyed``, where complete."""
    found = []
    answers = {c.span.start: c for c in keyed.conflicts} if keyed is not None else {}
    for conflict in grounded.diagnosis.conflicts:
        original = conflict.span.text(grounded.original)
        calls = [c for c in grounded.calls if c.kind == "ground" and c.original == original and not c.rendered]
        if conflict.unfilled and conflict.span.start in answers:
            conflict = answers[conflict.span.start]
        rendering = render_substitute_call(original, conflict) if conflict.substitute is not None else None
        if not calls or not rendering or has_placeholders(rendering):
            continue
        around = (grounded.original[: conflict.span.start], grounded.original[conflict.span.end :])
        roles = {conflict.substitute.name: {p.name: p.role for p in conflict.substitute.parameters}}
        for name, arguments in zip(conflict.preparatory, conflict.preparatory_arguments, strict=False):
            roles[name] = {m.target: m.role for m in arguments}
        expected = _arguments(around, rendering, roles)
        accepted = next((c for c in calls if c.accepted), None)
        first = _arguments(around, calls[0].text, roles)
        last = _arguments(around, accepted.text, roles) if accepted is not None else {}
        for key, answer in expected.items():
            right_first, right = first.get(key) == answer, last.get(key) == answer
            found.append(Decision(roles[key[0]][key[2]], answer, len(calls), right_first, right))
    return found


def _arguments(around: tuple[str, str], text: str, roles: dict[str, dict[str, str]]) -> dict[tuple[str, int, str], str]:
    """What each keyword argument with a role (``roles``: callee -> parameter -> role) says in the
    calls of ``text``, keyed by callee, the call's place among that callee's calls (a traced span
    makes several) and keyword, read with ``text`` in its place in the skill: an object's position
    as such (``obj_pos`` read from ``obj``, or ``task.get_object_position(obj)``), else the
    expression itself, offsets and all (empty: no parse)."""
    before = around[0]
    indent = before[len(before.rstrip(" \t")) :]  # the span starts after its line's indentation
    placed = at_indent(text, indent)  # a rendering's later lines at the body's indentation, as an answer's are
    try:
        names = position_names(before + placed[len(indent) :] + around[1])
        tree = ast.parse(textwrap.dedent(placed))
    except (SyntaxError, ValueError):  # SkillCodeError: the answer left the function unparseable
        return {}
    calls = sorted(
        (n for n in ast.walk(tree) if isinstance(n, ast.Call) and ast.unparse(n.func) in roles),
        key=lambda n: (n.lineno, n.col_offset),
    )
    meanings, seen = {}, dict.fromkeys(roles, 0)
    for call in calls:
        callee = ast.unparse(call.func)
        for keyword in (k for k in call.keywords if k.arg in roles[callee]):
            value = ast.unparse(keyword.value)
            bare = isinstance(keyword.value, ast.Name | ast.Call) and object_of_point(value, names)
            meanings[callee, seen[callee], keyword.arg] = f"the position of {bare}" if bare else value
        seen[callee] += 1
    return meanings


def decision_lines(cells: list[Cell]) -> list[str]:
    """LM decision accuracy per decision type (the argument's role), over every cell."""
    by_role: dict[str, list[Decision]] = {}
    for cell in cells:
        for decision in cell.decisions:
            by_role.setdefault(decision.role, []).append(decision)
    if not by_role:
        return []
    lines = [
        "",
        "| LM decision (role) | asked | right at the first answer | right when accepted |",
        "|---|---:|---:|---:|",
    ]
    for role, ds in sorted(by_role.items()):
        n = len(ds)
        lines.append(
            f"| {role} | {n} | {sum(d.right_first for d in ds)} ({100 * sum(d.right_first for d in ds) / n:.0f} %) | "
            f"{sum(d.right for d in ds)} ({100 * sum(d.right for d in ds) / n:.0f} %) |"
        )
    return lines


def ground_cells(agent, skills: list[str], robots: list[str], on_cell=None) -> list[Cell]:
    """Ground every (skill, robot) with ``agent`` (its method, LM and ontology); ``on_cell`` hears each."""
    cells, references = [], reference_placements()
    for name in skills:
        skill = agent.skill(name)
        for robot in robots:
            started = time.perf_counter()
            grounded, hit = agent.ground(name, robot)
            seconds = round(time.perf_counter() - started, 3)
            open_ = any(c.unfilled for c in grounded.diagnosis.conflicts)
            keyed = answer_key(agent.ontology, skill, robot, references) if open_ else None
            cell = classify(grounded, skill.source_embodiment, keyed)
            cell.igt_seconds, cell.cached = seconds, hit
            cells.append(cell)
            if on_cell is not None:
                on_cell(cell)
    return cells


def counts(cells: list[Cell]) -> dict[str, int]:
    return {g: sum(c.grounding == g for c in cells) for g in GROUNDINGS}


def grid_lines(cells: list[Cell], text: Callable[[Cell], str]) -> list[str]:
    """A markdown table with skills as rows and robots as columns, ``text(cell)`` in each (blank where none)."""
    robots = list(dict.fromkeys(c.robot for c in cells))
    at = {(c.skill, c.robot): c for c in cells}
    lines = ["| skill | " + " | ".join(robots) + " |", "|---|" + "---:|" * len(robots)]
    for skill in dict.fromkeys(c.skill for c in cells):
        row = [text(at[skill, robot]) if (skill, robot) in at else "" for robot in robots]
        lines.append(f"| `{skill}` | " + " | ".join(row) + " |")
    return lines


def render_table(cells: list[Cell]) -> str:
    """Skills as rows, robots as columns, one symbol per cell; the refused and invalid cells listed with reasons."""
    legend = ", ".join(f"`{SYMBOLS[g]}` {g}" for g in GROUNDINGS)
    lines = [
        f"Cells: {', '.join(f'{n} {g}' for g, n in counts(cells).items() if n)}. Legend: {legend}; `!` a defect.",
        "",
        *grid_lines(cells, lambda cell: SYMBOLS[cell.grounding] + ("!" if cell.defect else "")),
    ]
    explained = [c for c in cells if c.grounding in ("refused", "invalid")]
    if explained:
        lines += ["", "| skill | robot | grounding | reason |", "|---|---|---|---|"]
        lines += [
            f"| `{c.skill}` | {c.robot} | {c.grounding}{' (defect)' if c.defect else ''} | {c.reason} |"
            for c in explained
        ]
    lines += decision_lines(cells)
    return "\n".join(lines) + "\n"


def plot_heatmap(cells: list[Cell], path: Path) -> Path:
    """One coloured square per cell, by grounding."""
    plt = pyplot("the transfer heatmap")
    from matplotlib.colors import ListedColormap

    skills = list(dict.fromkeys(c.skill for c in cells))
    robots = list(dict.fromkeys(c.robot for c in cells))
    grid = [[float("nan")] * len(robots) for _ in skills]
    for c in cells:
        grid[skills.index(c.skill)][robots.index(c.robot)] = GROUNDINGS.index(c.grounding)
    colours = ListedColormap(["#d9d9d9", "#55a868", "#4c72b0", "#8c8c8c", "#c44e52"])
    fig, ax = plt.subplots(figsize=(1.0 + 0.55 * len(robots), 1.2 + 0.32 * len(skills)))
    ax.imshow(grid, cmap=colours, vmin=-0.5, vmax=len(GROUNDINGS) - 0.5, aspect="auto")
    ax.set_xticks(range(len(robots)), robots, rotation=45, ha="right")
    ax.set_yticks(range(len(skills)), skills)
    for c in cells:
        if c.defect:
            ax.text(robots.index(c.robot), skills.index(c.skill), "!", ha="center", va="center", color="white")
    handles = [plt.Rectangle((0, 0), 1, 1, color=colours(i)) for i in range(len(GROUNDINGS))]
    ax.legend(handles, GROUNDINGS, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    ax.set_title("Grounding of each skill on each robot")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path


def write_matrix(cells: list[Cell], out: Path, header: dict, more_md: str = "") -> dict[str, Path]:
    """``out/transfer.json`` (the cells and what produced them), ``transfer.md`` (the table, then
    ``more_md``) and ``transfer.png``."""
    out.mkdir(parents=True, exist_ok=True)
    data = {**header, "counts": counts(cells), "cells": [asdict(c) for c in cells]}
    (out / "transfer.json").write_text(json.dumps(data, indent=1) + "\n")
    (out / "transfer.md").write_text(render_table(cells) + more_md)
    return {"json": out / "transfer.json", "md": out / "transfer.md", "png": plot_heatmap(cells, out / "transfer.png")}
