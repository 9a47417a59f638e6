"""Pre-execution grounding: resolve each determined conflict with one localized FIM edit.

Conflicts are resolved last-to-first, so offsets of the pending ones stay valid and consecutive
prompts share the longest possible prefix (llama.cpp reuses its KV cache for it). Each generated
span is validated — with the still-pending spans blanked out — before it is accepted; a rejected
span is retried with the rejection as an extra hint, up to ``max_retries`` times.
"""

from __future__ import annotations

import ast
import difflib
import json
import textwrap
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from lerobot_policy_recent.logs.events import Event, PatchApplied, SkillDiagnosed, ValidationVerdict
from lerobot_policy_recent.ontology.builder import Ontology
from lerobot_policy_recent.ontology.diagnosis import OMITTED, Conflict, Diagnosis, Warning, diagnose
from lerobot_policy_recent.ontology.skill_code import CodeSpan
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.failures import REFUSED, FailureCategory
from lerobot_policy_recent.recent_plugin.grounding.attempts import (
    LMCall,
    call_events,
    infill_until_valid,
)
from lerobot_policy_recent.recent_plugin.grounding.gate import Verdict, security_gate, validate_program
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.refactoring.substitution import PLACEHOLDER
from lerobot_policy_recent.recent_plugin.refactoring.units import (
    RefactoringUnit,
    apply_unit,
    names_in_scope,
    unit_from_conflict,
)
from lerobot_policy_recent.skills.repository import Skill


@dataclass
class GroundedSkill:
    skill: str
    entry: str
    robot: str
    original: str
    code: str
    diagnosis: Diagnosis
    skill_tokens: int
    backend: str
    model: str
    calls: list[LMCall] = field(default_factory=list)
    verdict: Verdict | None = None
    seconds: float = 0.0  # wall time from diagnosis to validated code (IGT for this skill)
    edits: list[tuple[int, int, int]] = field(default_factory=list)  # (start, end, new length), original offsets
    source: str = "Panda"  # the embodiment whose API the original code calls

    def warnings(self) -> list[Warning]:
        """The diagnosis' run-time warnings with their spans moved onto the grounded code."""
        return [replace(w, span=self._moved(w.span)) for w in self.diagnosis.warnings]

    def _moved(self, span: CodeSpan) -> CodeSpan:
        def offset(o: int) -> int:
            shift = 0
            for start, end, length in sorted(self.edits):
                if end <= o:
                    shift += length - (end - start)
                elif start <= o:
                    return start + shift  # inside an edited span: its replacement's start
            return o + shift

        start = offset(span.start)
        inside = next(((s, length) for s, e, length in self.edits if s <= span.start < e), None)
        end = start + inside[1] if inside else offset(span.end)
        line = self.code.count("\n", 0, start) + 1
        return CodeSpan(start, end, line, self.code.count("\n", 0, max(start, end - 1)) + 1)

    @classmethod
    def start(cls, skill: Skill, robot: str, diagnosis: Diagnosis, infiller: Infiller) -> GroundedSkill:
        """The record grounding fills in: the skill unchanged so far, its size in the infiller's tokens."""
        return cls(
            skill=skill.name,
            entry=skill.entry,
            robot=robot,
            original=skill.code,
            code=skill.code,
            diagnosis=diagnosis,
            skill_tokens=infiller.count_tokens(strip_imports(skill.code)),
            backend=infiller.name,
            model=infiller.model,
            source=skill.source_embodiment,
        )

    @property
    def valid(self) -> bool:
        return self.verdict is not None and self.verdict.ok

    @property
    def generated_tokens(self) -> int:
        return sum(c.generated_tokens for c in self.calls)

    @property
    def lm_seconds(self) -> float:
        return sum(c.seconds for c in self.calls)

    @property
    def retries(self) -> int:
        return sum(1 for c in self.calls if not c.accepted)

    @property
    def go(self) -> float:
        """Grounding overhead: generated tokens ÷ tokens of the original skill code × 100."""
        return 100.0 * self.generated_tokens / max(1, self.skill_tokens)

    def events(self, *, cached: bool = False) -> list[Event]:
        """What grounding did, as typed events: the diagnosis, each infiller call and verdict, the patch."""
        diagnosis = self.diagnosis
        out: list[Event] = [
            SkillDiagnosed(
                self.skill,
                self.robot,
                [
                    f"line {c.span.line}: {c.span_type} {c.original} -> {_substitute_name(c)}"
                    for c in diagnosis.conflicts
                ],
                [f"line {w.span.line}: {w.check} ({w.phase})" for w in diagnosis.warnings],
                cached,
            )
        ]
        for call in self.calls:
            out += call_events(self.skill, call)
        if self.code != self.original:
            out.append(PatchApplied(self.skill, "ground", self.diff(), self.code))
        if self.verdict is not None and not self.verdict.ok:  # the skill's own verdict, after its rejected spans
            out.append(ValidationVerdict(self.skill, "skill", False, str(self.verdict.category), self.verdict.message))
        return out

    def diff(self) -> str:
        return "".join(
            difflib.unified_diff(
                self.original.splitlines(keepends=True),
                self.code.splitlines(keepends=True),
                fromfile=f"{self.skill}.py ({self.source})",
                tofile=f"{self.skill}.py ({self.robot})",
            )
        )


def strip_imports(code: str) -> str:
    return "".join(
        line for line in code.splitlines(keepends=True) if not line.lstrip().startswith(("import ", "from "))
    )


def ground_skill(
    skill: Skill,
    target: Target,
    onto: Ontology,
    infiller: Infiller,
    *,
    max_retries: int = 2,
    rediagnose: Callable[[Diagnosis], Diagnosis] | None = None,
) -> GroundedSkill:
    """Ground ``skill`` for ``target``: one localized edit per conflict the diagnosis (or ``rediagnose`` of it) names."""
    started = time.perf_counter()
    robot, api, apis = target.name, target.api, onto.apis
    diagnosis = diagnose(onto, skill.name, skill.code, robot, skill.source_embodiment, skill.placed_over)
    if rediagnose is not None:
        diagnosis = rediagnose(diagnosis)
    result = GroundedSkill.start(skill, robot, diagnosis, infiller)
    if refused := refused_source(skill, apis) or refused_capability(diagnosis):
        result.verdict, result.seconds = refused, time.perf_counter() - started
        return result
    pending = list(diagnosis.conflicts)
    while pending:
        conflict = pending.pop()  # last first: earlier offsets stay valid
        made = len(result.calls)
        accepted = _resolve(result, conflict, pending, target, infiller, apis, max_retries)
        if accepted is None:
            tried = len(result.calls) - made
            declined = tried and result.calls[-1].declined
            why = (
                f"after {max_retries + 1} attempts"
                if tried > max_retries
                else f"after {tried} attempt(s)"
                + ("" if declined else ": the task's LM call budget is spent")  # no further call was made
            )
            last = result.calls[-1].message if len(result.calls) > made and result.calls[-1].message else ""
            result.verdict = unrecoverable(
                result,
                f"unrecoverable: could not ground {conflict.original!r} at line {conflict.span.line} {why}"
                + (f"; the last attempt was rejected: {last}" if last else ""),
            )
            result.seconds = time.perf_counter() - started
            return result
        result.code, text_length = accepted
        result.edits.append((conflict.span.start, conflict.span.end, text_length))
    result.verdict = validate_program(result.code, api, skill.entry, apis)
    result.seconds = time.perf_counter() - started
    return result


def refused_source(skill: Skill, apis: dict) -> Verdict | None:
    """The security gate's verdict on the skill as written, where it refuses it: code outside every span
    (a user's skill with a huge loop, say) is refused before grounding, with the statement and the rule,
    rather than blamed on each span's attempts."""
    source = apis.get(skill.source_embodiment)
    verdict = security_gate(skill.code, skill.entry, source.names() if source is not None else ())
    if verdict.ok:
        return None
    where = f" line {verdict.line}:" if verdict.line else ""
    return replace(
        verdict,
        message=f"the skill {skill.name!r} as written is refused by the security gate:{where} {verdict.message}",
    )


def refused_capability(diagnosis: Diagnosis) -> Verdict | None:
    """The ontology's refusal of a call the robot cannot make in any form (IIWAKRL has no place), as
    the skill's verdict: named at once, with the line and the missing effects, rather than sent to the
    LM, whose every answer could only call what the robot lacks."""
    refused = next((c for c in diagnosis.conflicts if c.refused), None)
    if refused is None:
        return None
    return Verdict.reject(
        FailureCategory.UNSUPPORTED,
        f"{REFUSED}line {refused.span.line}: {refused.reason}",
    )


def unrecoverable(result: GroundedSkill, message: str) -> Verdict:
    """The verdict of a skill no attempt could ground: the category of its last rejected call."""
    category = result.calls[-1].category if result.calls else None
    return Verdict.reject(FailureCategory(category or FailureCategory.EMPTY_CONTINUATION), message)


def _resolve(
    result, conflict: Conflict, pending, target: Target, infiller, apis, max_retries
) -> tuple[str, int] | None:
    def judge(unit: RefactoringUnit, text: str) -> tuple[Verdict, str]:
        candidate = apply_unit(result.code, unit, text)
        verdict = validate_program(_blank(candidate, pending), target.api, result.entry, apis)
        return (verdict.ok and _check_span(text, unit)) or verdict, candidate

    accepted = infill_until_valid(
        infiller,
        lambda feedback, attempt: unit_from_conflict(result.code, conflict, target, feedback=feedback, attempt=attempt),
        judge,
        kind="ground",
        max_retries=max_retries,
        calls=result.calls,
    )
    return None if accepted is None else (accepted.candidate, len(accepted.text))


def _substitute_name(conflict: Conflict) -> str:
    """What a conflict's call becomes, as the diagnosis event shows it."""
    if conflict.omitted:
        return "nothing (dropped)"
    return conflict.substitute.name if conflict.substitute else "?"


def _check_span(text: str, unit: RefactoringUnit) -> Verdict | None:
    """The span must hold code and nothing it was not asked for (no `return`, no statement after the
    ontology's call), and a determined substitution must call the substitute it names."""
    try:  # later lines sit at the body's indentation: parse the span as the block it forms
        statements = ast.parse(textwrap.dedent(unit.indent + text)).body if text else []
    except SyntaxError:
        return None  # reported with its position by the whole-program validation
    if not statements:
        return Verdict.reject(
            FailureCategory.EMPTY_CONTINUATION, "the span holds no statement (empty or only comments)"
        )
    returned = next((s for s in statements if any(isinstance(n, ast.Return) for n in ast.walk(s))), None)
    if returned is not None:
        return Verdict.reject(
            FailureCategory.NON_EXECUTABLE, f"the span adds `{ast.unparse(returned)}`, which it was not asked for"
        )
    called = {name for name, _ in _ordered_calls(statements)}
    if unit.hints.substitute_call == OMITTED and called:
        return Verdict.reject(
            FailureCategory.HALLUCINATED_API,
            f"the ontology drops this call ({unit.hints.reason}), but the span calls {sorted(called)}",
        )
    if unit.substitute and unit.substitute not in called:
        return Verdict.reject(
            FailureCategory.HALLUCINATED_API,
            f"the ontology substitutes {unit.substitute}() here, but the span calls {sorted(called) or 'nothing'}",
        )
    asked = _statement_count(unit.hints.substitute_call)
    if asked and len(statements) > asked:
        return Verdict.reject(
            FailureCategory.NON_EXECUTABLE,
            f"the span adds `{ast.unparse(statements[asked])}` after the {asked} statement(s) it was asked for",
        )
    return _misnamed(statements, unit) or changed_argument(statements, unit.hints.substitute_call)


def _misnamed(statements: list[ast.stmt], unit: RefactoringUnit) -> Verdict | None:
    """An object name the span writes that its role or its scope rules out: a receiving argument
    naming the object the hand holds (``unit.hints.exclusions``), or, where the ontology's call
    leaves a name open, a quoted name the skill never uses (:func:`names_in_scope`): the 1.5B wrote
    ``obj_name="cube1"``, which no task has."""
    open_names, names = _open_names(unit.hints.substitute_call or ""), None
    for call in (n for s in statements for n in ast.walk(s) if isinstance(n, ast.Call)):
        callee = ast.unparse(call.func)
        for keyword in call.keywords:
            value = ast.unparse(keyword.value)
            for barred in unit.hints.exclusions:
                if (barred.call, barred.argument) == (callee, keyword.arg) and value in barred.names:
                    return Verdict.reject(FailureCategory.HALLUCINATED_KWARG, f"{keyword.arg}={value}: {barred.why}")
            quoted = isinstance(keyword.value, ast.Constant) and isinstance(keyword.value.value, str)
            if not quoted or (callee, keyword.arg) not in open_names:
                continue
            names = names_in_scope(unit) if names is None else names
            if json.dumps(keyword.value.value) not in names:
                return Verdict.reject(
                    FailureCategory.HALLUCINATED_KWARG,
                    f"{keyword.arg}={value}: no object of that name is in scope (names here: {', '.join(names) or 'none'})",
                )
    return None


def _open_names(expected: str) -> set[tuple[str, str]]:
    """The (callee, keyword) pairs whose value the ontology's call leaves as an ``<object_name>``."""
    hole = "_object_name_hole"
    try:
        tree = ast.parse(
            textwrap.dedent(PLACEHOLDER.sub(lambda m: hole if m.group(0) == "<object_name>" else "_", expected))
        )
    except SyntaxError:
        return set()
    return {
        (ast.unparse(n.func), k.arg)
        for n in ast.walk(tree)
        if isinstance(n, ast.Call)
        for k in n.keywords
        if isinstance(k.value, ast.Name) and k.value.id == hole
    }


def _statement_count(code: str | None) -> int:
    """How many statements the ontology's call for a span is (0: none, or it does not parse: no limit)."""
    if not code:
        return 0
    try:
        return len(ast.parse(textwrap.dedent(PLACEHOLDER.sub("_", code))).body)  # <name> parses as a name
    except SyntaxError:
        return 0


def changed_argument(
    statements: list[ast.stmt], expected: str | None, decided_by: str = "the original call passed"
) -> Verdict | None:
    """Grounding edits bindings only: an argument the ontology (or a run-time check) wrote keeps its value.

    (A small model filling the span sometimes repeats a neighbouring line of the suffix instead,
    e.g. the approach height where the press height belongs; the code stays valid, the skill not.
    In a run-time sweep it wrote the target's position where the check had put the push beside the
    obstacle, and pushed down through it.)
    """
    undecided = "_undecided"  # a <type> placeholder: that value is the LM's to choose
    try:
        wanted = _ordered_calls(ast.parse(PLACEHOLDER.sub(undecided, expected or "")).body)
    except SyntaxError:
        return None
    got = _ordered_calls(statements)
    for (name, nth), call in wanted.items():  # the n-th call of a name against the n-th (a traced path's moves)
        given = {k.arg: k.value for k in got[name, nth].keywords} if (name, nth) in got else {}
        for keyword in call.keywords:
            value = given.get(keyword.arg)
            if value is not None and not _matches(value, keyword.value, undecided):
                return Verdict.reject(
                    FailureCategory.HALLUCINATED_KWARG,
                    f"{name}({keyword.arg}={ast.unparse(value)}) changes the value {decided_by}: "
                    f"keep {keyword.arg}={ast.unparse(keyword.value)}",
                )
    return None


def _matches(node: ast.AST, pattern: ast.AST, hole: str) -> bool:
    """``node`` is ``pattern`` with any expression where the pattern has the name ``hole``
    (a conversion the ontology wrote around a value it left to the LM: ``to_frame(p) + <rotvec>``)."""
    if isinstance(pattern, ast.Name) and pattern.id == hole:
        return True
    if type(node) is not type(pattern):
        return False
    for name in pattern._fields:
        a, b = getattr(node, name, None), getattr(pattern, name, None)
        if isinstance(b, list):
            if not isinstance(a, list) or len(a) != len(b):
                return False
            if not all(_matches(x, y, hole) if isinstance(y, ast.AST) else x == y for x, y in zip(a, b, strict=True)):
                return False
        elif isinstance(b, ast.AST):
            if not (isinstance(a, ast.AST) and _matches(a, b, hole)):
                return False
        elif a != b:
            return False
    return True


def _ordered_calls(statements: list[ast.stmt]) -> dict[tuple[str, int], ast.Call]:
    """The statements' calls by (name, how many calls of that name came before it)."""
    seen: dict[str, int] = {}
    out = {}
    for stmt in statements:
        for node in ast.walk(stmt):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
                out[node.func.id, seen.get(node.func.id, 0)] = node
                seen[node.func.id] = seen.get(node.func.id, 0) + 1
    return out


def _blank(code: str, pending: list[Conflict]) -> str:
    """Replace still-unresolved conflict spans with ``pass`` so the rest can be validated now."""
    for conflict in sorted(pending, key=lambda c: c.span.start, reverse=True):
        code = code[: conflict.span.start] + "pass" + code[conflict.span.end :]
    return code
