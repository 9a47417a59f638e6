"""Static analysis of skill code: the primitive call sites the ontology reasons about."""

from __future__ import annotations

import ast
from dataclasses import dataclass


@dataclass(frozen=True)
class CodeSpan:
    """A half-open character range of the source, with 1-based lines as ``ast`` reports them."""

    start: int
    end: int
    line: int
    end_line: int

    def text(self, code: str) -> str:
        return code[self.start : self.end]


@dataclass(frozen=True)
class CallSite:
    function: str  # the skill function that contains the call
    name: str  # the callee
    span: CodeSpan  # the whole statement that holds the call
    keywords: tuple[str, ...]
    positional: int
    arguments: tuple[tuple[str, str], ...] = ()  # keyword -> source text of the argument
    context: str = "body"  # the innermost control structure around the call: body, if, else or for


@dataclass(frozen=True)
class PositionBinding:
    """``var = task.get_object_position(...)``: where the skill read an object's position."""

    variable: str
    line: int
    offset: int


class SkillCodeError(ValueError):
    pass


def _offsets(code: str) -> list[int]:
    starts, total = [], 0
    for line in code.splitlines(keepends=True):
        starts.append(total)
        total += len(line)
    starts.append(total)
    return starts


def span_of(node: ast.AST, code: str, line_starts: list[int] | None = None) -> CodeSpan:
    """Character span of ``node`` (lines and columns from ``ast``; columns are UTF-8 byte offsets)."""
    starts = line_starts or _offsets(code)
    lines = code.splitlines(keepends=True)

    def char(line: int, col_bytes: int) -> int:
        text = lines[line - 1].encode()[:col_bytes].decode(errors="ignore")
        return starts[line - 1] + len(text)

    return CodeSpan(
        start=char(node.lineno, node.col_offset),
        end=char(node.end_lineno, node.end_col_offset),
        line=node.lineno,
        end_line=node.end_lineno,
    )


def parse_skill(code: str, filename: str = "<skill>") -> ast.Module:
    try:
        return ast.parse(code, filename=filename)
    except SyntaxError as exc:
        raise SkillCodeError(f"{filename}:{exc.lineno}: skill code does not parse: {exc.msg}") from None


def call_sites(code: str, filename: str = "<skill>") -> list[CallSite]:
    """Every statement of the form ``f(...)`` or ``x = f(...)`` inside a skill function, in source order."""
    tree = parse_skill(code, filename)
    starts = _offsets(code)
    sites = []
    for func in (n for n in tree.body if isinstance(n, ast.FunctionDef)):
        for stmt, context in _statements(func.body, "body"):
            call = getattr(stmt, "value", None) if isinstance(stmt, ast.Expr | ast.Assign) else None
            if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name)):
                continue
            sites.append(
                CallSite(
                    function=func.name,
                    name=call.func.id,
                    span=span_of(stmt, code, starts),
                    keywords=tuple(k.arg for k in call.keywords if k.arg),
                    positional=len(call.args),
                    arguments=tuple((k.arg, ast.unparse(k.value)) for k in call.keywords if k.arg),
                    context=context,
                )
            )
    return sorted(sites, key=lambda s: s.span.start)


def _statements(body: list[ast.stmt], context: str):
    """Statements in source order with the control structure they sit in."""
    for stmt in body:
        yield stmt, context
        if isinstance(stmt, ast.If):
            yield from _statements(stmt.body, "if")
            yield from _statements(stmt.orelse, "else")
        elif isinstance(stmt, ast.For):
            yield from _statements(stmt.body, "for")


def position_bindings(code: str) -> dict[str, PositionBinding]:
    """Variables that hold an object position read from the task, with where they were read."""
    tree = parse_skill(code)
    starts = _offsets(code)
    found = {}
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Assign)
            and len(node.targets) == 1
            and isinstance(node.targets[0], ast.Name)
            and isinstance(node.value, ast.Call)
            and isinstance(node.value.func, ast.Attribute)
            and node.value.func.attr == "get_object_position"
        ):
            found[node.targets[0].id] = PositionBinding(
                node.targets[0].id, node.lineno, span_of(node, code, starts).start
            )
    return found


def variable_kinds(func: ast.FunctionDef) -> dict[str, str]:
    """What simple variables hold: ``"position"`` (an object position or a 3-list), ``"name"`` (a string).

    A variable assigned more than once with different kinds is left out (nothing is claimed about it).
    """
    kinds: dict[str, set[str]] = {}
    args = func.args.args
    for arg, default in zip(args[len(args) - len(func.args.defaults) :], func.args.defaults, strict=True):
        if isinstance(default, ast.Constant) and isinstance(default.value, str):
            kinds.setdefault(arg.arg, set()).add("name")
    for node in ast.walk(func):
        if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
            kind = _expression_kind(node.value)
            kinds.setdefault(node.targets[0].id, set()).add(kind or "unknown")
    return {name: next(iter(k)) for name, k in kinds.items() if len(k) == 1 and "unknown" not in k}


def name_variables(kinds: dict[str, str]) -> tuple[str, ...]:
    """The variables of :func:`variable_kinds` that hold an object name, sorted."""
    return tuple(sorted(n for n, kind in kinds.items() if kind == "name"))


def _expression_kind(value: ast.expr) -> str | None:
    if (
        isinstance(value, ast.Call)
        and isinstance(value.func, ast.Attribute)
        and value.func.attr == "get_object_position"
    ):
        return "position"
    if isinstance(value, ast.List | ast.Tuple) and len(value.elts) == 3:
        return "position"
    if isinstance(value, ast.Constant) and isinstance(value.value, str):
        return "name"
    return None
