"""RoboInspector's pre-execution behaviour detector, over the target robot's API spec and the scene.

RoboInspector sorts unreliable robot programs into four behaviours; the paper's appendix uses its
taxonomy as a filter before simulation, and to categorise execution failures for the repair
prompt. Here each is read off the code and the primitive specs (no simulator, no LM):

* **Nonsense** — a call the robot cannot make: an unknown function, a keyword its primitive does
  not take, a required one missing;
* **Disorder** — actions in an impossible order: a primitive that needs a held object while
  nothing is held, or a free hand while something is (the specs' ``object_grasped`` /
  ``end_effector_free`` preconditions, tracked through each call's effects);
* **Infeasible** — a literal target outside the workspace (the table, up to 0.6 m above it);
* **Badpose** — a literal orientation that is no unit quaternion, or a literal outside a
  parameter's declared range or choices.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass

from lerobot_policy_recent.ontology.skill_code import entry_function, segment_statements
from lerobot_policy_recent.ontology.specs import WORLD_FRAME, ApiSpec, ParameterSpec
from lerobot_policy_recent.recent_plugin.failures import FailureCategory
from lerobot_policy_recent.recent_plugin.grounding.gate import SAFE_HELPERS, Verdict
from lerobot_policy_recent.robosuite_envs.table import TABLE_SIZE, TABLE_Z

BEHAVIOURS = ("nonsense", "disorder", "infeasible", "badpose")
REACH_ABOVE_TABLE = 0.6  # metres: how high a target may lie above the table top
HELD, FREE = "object_grasped", "end_effector_free"


@dataclass(frozen=True)
class Finding:
    behaviour: str  # one of BEHAVIOURS
    line: int
    message: str

    def feedback(self) -> str:
        return f"{self.behaviour.capitalize()} (line {self.line}): {self.message}"


def inspect_program(code: str, entry: str, api: ApiSpec) -> list[Finding]:
    """Every unreliable behaviour the detector sees in ``entry``, in execution order."""
    findings: list[Finding] = []
    holding = False
    for stmt, _source in segment_statements(code, entry_function(code, entry)):
        for call in (n for n in ast.walk(stmt) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)):
            name = call.func.id
            spec = api.get(name)
            if spec is None:
                if name not in SAFE_HELPERS:
                    findings.append(Finding("nonsense", call.lineno, f"{name}() is not a {api.embodiment} primitive"))
                continue
            params = {p.name: p for p in spec.parameters}
            given = {kw.arg for kw in call.keywords}
            for kw in call.keywords:
                if kw.arg not in params:
                    findings.append(Finding("nonsense", call.lineno, f"{name}() takes no keyword {kw.arg!r}"))
                else:
                    findings += _literal_findings(name, params[kw.arg], kw.value)
            missing = [p for p, s in params.items() if s.required and p not in given and len(call.args) <= 2]
            if missing:
                findings.append(Finding("nonsense", call.lineno, f"{name}() misses {', '.join(missing)}"))
            if HELD in spec.preconditions and not holding:
                findings.append(Finding("disorder", call.lineno, f"{name}() needs a held object, but nothing is held"))
            if FREE in spec.preconditions and holding:
                findings.append(Finding("disorder", call.lineno, f"{name}() needs a free hand, but it still holds"))
            if HELD in spec.effects:
                holding = True
            elif FREE in spec.effects:
                holding = False
    return findings


def _literal_findings(primitive: str, spec: ParameterSpec, value: ast.expr) -> list[Finding]:
    line = value.lineno
    literal = _literal(value)
    if literal is None:
        return []
    world_metres = spec.unit == "m" and spec.frame in (None, WORLD_FRAME)  # where the table's bounds apply
    if spec.type == "position" and world_metres and isinstance(literal, list) and len(literal) == 3:
        x, y, z = literal
        half_x, half_y = TABLE_SIZE[0] / 2, TABLE_SIZE[1] / 2
        if not (-half_x <= x <= half_x and -half_y <= y <= half_y and TABLE_Z <= z <= TABLE_Z + REACH_ABOVE_TABLE):
            return [Finding("infeasible", line, f"{primitive}({spec.name}={literal}) lies outside the workspace")]
    if spec.type == "quaternion" and isinstance(literal, list):
        norm = sum(v * v for v in literal) ** 0.5
        if len(literal) != 4 or abs(norm - 1.0) > 0.05:
            return [Finding("badpose", line, f"{primitive}({spec.name}={literal}) is not a unit quaternion")]
    if isinstance(literal, int | float) and spec.range and not spec.range[0] <= literal <= spec.range[1]:
        return [Finding("badpose", line, f"{primitive}({spec.name}={literal}) is outside {list(spec.range)}")]
    if spec.choices and not isinstance(literal, list) and literal not in spec.choices:
        return [Finding("badpose", line, f"{primitive}({spec.name}={literal!r}) is not one of {list(spec.choices)}")]
    return []


def _literal(value: ast.expr):
    """A constant or a list of numeric constants; None for anything computed at run time."""
    try:
        literal = ast.literal_eval(value)
    except (ValueError, SyntaxError, TypeError):
        return None
    if isinstance(literal, tuple):
        literal = list(literal)
    if isinstance(literal, list) and not all(isinstance(v, int | float) for v in literal):
        return None
    return literal


# how a finding counts in the paper's taxonomy when it rejects a program before execution
FINDING_CATEGORY = {
    "nonsense": FailureCategory.HALLUCINATED_API,
    "disorder": FailureCategory.SUBTASK_FAILED,
    "infeasible": FailureCategory.WORKSPACE,
    "badpose": FailureCategory.MOTION_PLANNING,
}


def inspection_verdict(code: str, entry: str, api: ApiSpec) -> Verdict:
    """The detector as a gate: every finding, categorised, or acceptance."""
    findings = inspect_program(code, entry, api)
    if not findings:
        return Verdict(True)
    message = "unreliable behaviour detected: " + "; ".join(f.feedback() for f in findings)
    return Verdict(False, FINDING_CATEGORY[findings[0].behaviour], message, findings[0].line)


def categorised(category: str) -> str:
    """An execution failure in RoboInspector's taxonomy (the repair prompt names it)."""
    if category.startswith("hallucinated") or category in ("non_executable", "empty_continuation"):
        return "nonsense"
    if category in ("workspace", "unreachable_object"):
        return "infeasible"
    if category == "motion_planning":
        return "badpose"
    return "disorder"
