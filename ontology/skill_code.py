"""Static analysis of skill code, in one place: parsing, character spans, functions and their
statements, segments (with literal loops unrolled) and the data flow between statements.

Offsets are character offsets into the source string. ``ast`` reports columns as UTF-8 byte
offsets, so every span goes through :func:`span_of`, which converts them (a skill with a
non-ASCII string or comment before a statement on its line keeps correct spans).
"""

from __future__ import annotations

import ast
import copy
import textwrap
from dataclasses import dataclass, field


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


def line_starts(code: str) -> list[int]:
    """Character offset of each line's start, and of the end of the code (1-based line ``n`` starts at ``[n - 1]``)."""
    starts, total = [], 0
    for line in code.splitlines(keepends=True):
        starts.append(total)
        total += len(line)
    starts.append(total)
    return starts


def span_of(node: ast.AST, code: str, starts: list[int] | None = None) -> CodeSpan:
    """Character span of ``node`` (lines and columns from ``ast``; columns are UTF-8 byte offsets).

    ``starts``: :func:`line_starts` of ``code``, when the caller already has them.
    """
    starts = starts or line_starts(code)
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
    starts = line_starts(code)
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
    starts = line_starts(code)
    found = {}
    for node in ast.walk(tree):
        if (read := _position_read(node)) is not None:
            found[read[0]] = PositionBinding(read[0], node.lineno, span_of(node, code, starts).start)
    return found


def _position_read(node: ast.AST) -> tuple[str, ast.Call] | None:
    """``var = task.get_object_position(...)``: the variable and the call."""
    if (
        isinstance(node, ast.Assign)
        and len(node.targets) == 1
        and isinstance(node.targets[0], ast.Name)
        and isinstance(node.value, ast.Call)
        and isinstance(node.value.func, ast.Attribute)
        and node.value.func.attr == "get_object_position"
    ):
        return node.targets[0].id, node.value
    return None


def named_positions(code: str) -> dict[str, str]:
    """Variables that hold the position of a named object, or a point placed by it alone (see
    :func:`position_names`): variable -> the object's name expression."""
    return position_names(code).variables


@dataclass(frozen=True)
class PositionNames:
    """What positions in a skill name: variables read once from the task (``obj_pos =
    task.get_object_position(obj)`` names ``obj``), and points computed from one of them.

    A point names the object whose position alone places it horizontally: its x and y (the first
    two items of a list) come from exactly one named position, plus numbers, arithmetic and
    ``constants`` (variables a parameter or a literal loop binds), and no call. ``[bin_pos[0],
    bin_pos[1], bin_pos[2] + 0.1]`` names what ``bin_pos`` names: a drop point above the bin is the
    bin's, whatever height it drops from. A position argument that names an object determines its
    name: what a name-based API asks for instead."""

    variables: dict[str, str]
    constants: frozenset[str] = frozenset()
    # points the skill's metadata names where no one position places them: a place's release point,
    # where the skill declares the object the hand holds there ends over one object (see ``diagnose``)
    declared: dict[str, str] = field(default_factory=dict)
    points: dict[str, str] = field(default_factory=dict)  # a variable computed from one position: its expression

    def of(self, expression: str | None) -> str | None:
        """The object the position ``expression`` (an argument's source) names, or None."""
        node = parse_expression(expression)
        if node is None:
            return None
        return placed_by(node, self.variables, self.constants) or self.declared.get(expression)

    def beside(self, expression: str | None) -> str | None:
        """The object whose position alone places the point ``expression`` (inline, or a variable
        computed from it) beside, not straight over, its centre (``[bin_pos[0] + dx, bin_pos[1] + dy,
        ...]``, a corner of the bin); None for a point over the centre, or one no position places."""
        node = parse_expression(self.points.get(expression or "", expression))
        if node is None or isinstance(node, ast.Name):
            return None
        named = placed_by(node, self.variables, self.constants)
        return named if named is not None and self.straight_over(node) is None else None

    def straight_over(self, node: ast.expr) -> str | None:
        """The object a point ``[P[0], P[1], <a height>]`` lies straight over (``P`` its position
        read), or None: a point beside it (``P[0] - 0.06``) or placed by two objects is not."""
        if not (isinstance(node, ast.List) and len(node.elts) == 3):
            return None
        over = {_item_of(node.elts[0], 0), _item_of(node.elts[1], 1)}
        variable = over.pop() if len(over) == 1 else None
        return self.variables.get(variable) if variable is not None else None


def parse_expression(text: str | None) -> ast.expr | None:
    """``text`` as one Python expression, or None (empty, or not an expression)."""
    if not text:
        return None
    try:
        return ast.parse(text, mode="eval").body
    except SyntaxError:
        return None


def _item_of(node: ast.expr, index: int) -> str | None:
    """``P`` where ``node`` is ``P[index]``, else None."""
    if (
        isinstance(node, ast.Subscript)
        and isinstance(node.value, ast.Name)
        and isinstance(node.slice, ast.Constant)
        and node.slice.value == index
    ):
        return node.value.id
    return None


def placed_by(node: ast.expr, names: dict[str, str], constants: frozenset[str]) -> str | None:
    """The object a position expression is placed by (:class:`PositionNames`), or None."""
    if isinstance(node, ast.Name):
        return names.get(node.id)
    horizontal = node.elts[:2] if isinstance(node, ast.List | ast.Tuple) and len(node.elts) >= 2 else [node]
    used = set()
    for part in horizontal:
        for leaf in ast.walk(part):
            if isinstance(leaf, ast.Name):
                if leaf.id in names:
                    used.add(names[leaf.id])
                elif leaf.id not in constants:
                    return None
            elif not isinstance(leaf, _ARITHMETIC):
                return None
    if isinstance(node, ast.List | ast.Tuple):  # the height may come from anything but a call
        if any(isinstance(leaf, ast.Call) for leaf in ast.walk(node)):
            return None
    return used.pop() if len(used) == 1 else None


def object_of_point(expression: str, names: PositionNames) -> str | None:
    """The object a point expression is placed by, where it may also read positions itself
    (``task.get_object_position(base)``, ``[p[0], p[1], p[2] + 0.05]`` with ``p`` read once): None
    when it is not one object's."""
    try:
        node = ast.parse(expression, mode="eval").body
    except SyntaxError:
        return None
    reads: dict[str, str] = {}

    class _Reads(ast.NodeTransformer):
        def visit_Call(self, call: ast.Call) -> ast.AST:
            arguments = [*call.args, *(k.value for k in call.keywords)]  # name= or positional
            if isinstance(call.func, ast.Attribute) and call.func.attr == "get_object_position" and len(arguments) == 1:
                alias = f"_read_{len(reads)}"
                reads[alias] = ast.unparse(arguments[0])
                return ast.Name(alias, ast.Load())
            return self.generic_visit(call)

    node = _Reads().visit(node)
    return placed_by(node, {**names.variables, **reads}, names.constants)


_ARITHMETIC = (
    ast.List, ast.Tuple, ast.Subscript, ast.Constant, ast.BinOp, ast.UnaryOp, ast.Load, ast.Slice,
    ast.operator, ast.unaryop,
)  # fmt: skip


def position_names(code: str) -> PositionNames:
    """The :class:`PositionNames` of ``code``: a variable counts when that read (or the point
    computed from one) is its only write (no other assignment, no item or augmented assignment),
    and the name is a string or a variable that only a function argument or a loop binds."""
    tree = parse_skill(code)
    writes: dict[str, int] = {}
    assigned: set[str] = set()  # written by an assignment (a loop or a parameter binds the others)
    found: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign | ast.AugAssign | ast.AnnAssign):
            for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                for leaf in ast.walk(target):
                    if isinstance(leaf, ast.Name):
                        writes[leaf.id] = writes.get(leaf.id, 0) + 1
                        assigned.add(leaf.id)
                if isinstance(target, ast.Subscript) and isinstance(target.value, ast.Name):
                    writes[target.value.id] = writes.get(target.value.id, 0) + 2  # mutated in place
        elif isinstance(node, ast.For | ast.comprehension):
            for leaf in ast.walk(node.target):
                if isinstance(leaf, ast.Name):
                    writes[leaf.id] = writes.get(leaf.id, 0) + 1
    for node in ast.walk(tree):
        read = _position_read(node)
        if read is not None and len(read[1].args) == 1 and not read[1].keywords:
            name = read[1].args[0]
            literal = isinstance(name, ast.Constant) and isinstance(name.value, str)
            if literal or (isinstance(name, ast.Name) and name.id not in assigned):
                found[read[0]] = ast.unparse(name)
    read_once = {var: name for var, name in found.items() if writes.get(var) == 1}
    constants = frozenset(var for var in writes if var not in assigned) | _parameters(tree)
    derived, points = {}, {}
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Assign)
            and len(node.targets) == 1
            and isinstance(node.targets[0], ast.Name)
            and writes.get(node.targets[0].id) == 1
            and node.targets[0].id not in read_once
            and not isinstance(node.value, ast.Name)
            and (name := placed_by(node.value, read_once, constants)) is not None
        ):
            derived[node.targets[0].id] = name
            points[node.targets[0].id] = ast.unparse(node.value)
    return PositionNames({**read_once, **derived}, constants, points=points)


def _parameters(tree: ast.Module) -> frozenset[str]:
    return frozenset(
        a.arg for f in ast.walk(tree) if isinstance(f, ast.FunctionDef) for a in [*f.args.args, *f.args.kwonlyargs]
    )


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


def object_literals(func: ast.FunctionDef) -> tuple[str, ...]:
    """Object names the function writes in quotes where a task query reads them
    (``task.get_object_position("table")``), in order of first use: names in scope that no variable
    holds."""
    found = [
        node.args[0].value
        for node in ast.walk(func)
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and isinstance(node.func.value, ast.Name)
        and node.func.value.id == "task"
        and node.args
        and isinstance(node.args[0], ast.Constant)
        and isinstance(node.args[0].value, str)
    ]
    return tuple(dict.fromkeys(found))


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


# ------------------------------------------------------------------------------------------ functions


def entry_function(code: str | ast.Module, entry: str) -> ast.FunctionDef:
    """The top-level function ``entry`` (a skill's entry point)."""
    tree = ast.parse(code) if isinstance(code, str) else code
    found = next((n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == entry), None)
    if found is None:
        raise SkillCodeError(f"no top-level function {entry!r}")
    return found


def body_statements(func: ast.FunctionDef) -> list[ast.stmt]:
    """The function's statements, its docstring excluded."""
    first = func.body[0]
    docstring = (
        isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str)
    )
    return func.body[1:] if docstring else func.body


def enclosing_function(code: str, offset: int) -> tuple[int, int]:
    """Character range of the whole lines of the top-level function containing ``offset`` (all of ``code`` if none)."""
    starts = line_starts(code)
    for node in ast.parse(code).body:
        if isinstance(node, ast.FunctionDef):
            first = node.decorator_list[0].lineno if node.decorator_list else node.lineno
            lo, hi = starts[first - 1], starts[node.end_lineno]
            if lo <= offset < hi:
                return lo, hi
    return 0, len(code)


def body_span(code: str, entry: str) -> tuple[int, int]:
    """Character range of the entry function's statements (its docstring excluded)."""
    func = entry_function(code, entry)
    body = body_statements(func) or func.body  # a function that is only a docstring: the docstring
    starts = line_starts(code)
    return span_of(body[0], code, starts).start, span_of(body[-1], code, starts).end


def statement_span(code: str, entry: str, line: int) -> tuple[int, int]:
    """Character range of the entry body's top-level statement covering ``line`` ((0, 0) if none, or no parse)."""
    try:
        func = entry_function(code, entry)
    except (SyntaxError, SkillCodeError):
        return 0, 0
    for stmt in func.body:
        if stmt.lineno <= line <= (stmt.end_lineno or stmt.lineno):
            span = span_of(stmt, code)
            return span.start, span.end
    return 0, 0


# ------------------------------------------------------------------------------------------- segments


def segment_statements(code: str, func: ast.FunctionDef) -> list[tuple[ast.stmt, str]]:
    """The statements a skill executes one at a time, with their source: the body's top-level
    statements, and each iteration of a loop over a literal list (:func:`unroll`) as statements of its own.

    A statement's later lines keep the body's indentation; its first line is bare.
    """
    body = body_statements(func)
    indent = " " * body[0].col_offset if body else ""
    statements: list[tuple[ast.stmt, str]] = []
    for stmt in body:
        iterations = unroll(stmt)
        if iterations is None:
            statements.append((stmt, ast.get_source_segment(code, stmt) or ast.unparse(stmt)))
        else:
            for bind, nodes in iterations:
                statements += [(bind, ast.unparse(bind)), *((n, _nested_source(code, n, indent)) for n in nodes)]
    return statements


def unroll(stmt: ast.stmt) -> list[tuple[ast.Assign, list[ast.stmt]]] | None:
    """``for x in [a, b]: body`` as iterations ``(x = a, body)``, ``(x = b, body)``; None for any other statement.

    Only loops whose iterations are fixed before they start: a literal list or tuple of
    expressions without calls whose names the loop does not rebind (evaluating them one iteration
    later gives the same values), no ``else`` and no ``break``/``continue``. Unrolled statements keep the loop's line numbers.
    """
    if not (isinstance(stmt, ast.For) and isinstance(stmt.iter, ast.List | ast.Tuple)) or stmt.orelse:
        return None
    if any(isinstance(n, ast.Starred | ast.Call) for e in stmt.iter.elts for n in ast.walk(e)):
        return None
    if any(isinstance(n, ast.Break | ast.Continue) for s in stmt.body for n in ast.walk(s)):
        return None
    items = {n.id for e in stmt.iter.elts for n in ast.walk(e) if isinstance(n, ast.Name)}
    if any(isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store) and n.id in items for n in ast.walk(stmt)):
        return None  # the body (or the loop variable) rebinds a name an item reads: items are evaluated once, up front
    iterations = []
    for element in stmt.iter.elts:
        bind = ast.Assign(targets=[copy.deepcopy(stmt.target)], value=copy.deepcopy(element))
        bind.lineno, bind.end_lineno = stmt.lineno, stmt.lineno  # the ``for`` line, not the whole loop
        bind.col_offset, bind.end_col_offset = stmt.col_offset, stmt.iter.end_col_offset
        iterations.append((ast.fix_missing_locations(bind), [copy.deepcopy(s) for s in stmt.body]))
    return iterations


@dataclass(frozen=True)
class CallCount:
    """How many calls a piece of skill code makes when it runs, counted as the paper counts them."""

    primitives: int  # calls of the robot's primitives (actions), literal loops unrolled
    position_reads: int  # ``task.get_object_position(...)``, left out of the paper's count

    def __add__(self, other: CallCount) -> CallCount:
        return CallCount(self.primitives + other.primitives, self.position_reads + other.position_reads)


def count_calls(code: str, entry: str, primitives: set[str]) -> CallCount:
    """The calls ``entry`` makes: a loop over a literal list, tuple or ``range`` of constants counts
    its body once per item (other loops once); both branches of an ``if`` count."""

    def count(statements: list[ast.stmt]) -> CallCount:
        total = CallCount(0, 0)
        for stmt in statements:
            if isinstance(stmt, ast.For | ast.While | ast.If | ast.With | ast.Try):
                nested = [s for field in ("body", "orelse", "finalbody") for s in getattr(stmt, field, [])]
                nested += [s for handler in getattr(stmt, "handlers", []) for s in handler.body]
                header = [stmt.iter] if isinstance(stmt, ast.For) else [getattr(stmt, "test", None)]
                times = _literal_iterations(stmt) if isinstance(stmt, ast.For) else 1
                inner = count(nested)
                total += CallCount(inner.primitives * times, inner.position_reads * times)
                total += _calls_in([h for h in header if h is not None], primitives)
            else:
                total += _calls_in([stmt], primitives)
        return total

    return count(body_statements(entry_function(code, entry)))


def _literal_iterations(loop: ast.For) -> int:
    """How often a ``for`` loop runs where the code says it: a literal sequence or ``range`` of constants; else 1."""
    if isinstance(loop.iter, ast.List | ast.Tuple):
        return len(loop.iter.elts)
    call = loop.iter
    if isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id == "range":
        if all(isinstance(a, ast.Constant) and isinstance(a.value, int) for a in call.args) and call.args:
            return len(range(*(a.value for a in call.args)))
    return 1


def _calls_in(nodes: list[ast.AST], primitives: set[str]) -> CallCount:
    calls = [n for node in nodes for n in ast.walk(node) if isinstance(n, ast.Call)]
    actions = sum(1 for c in calls if isinstance(c.func, ast.Name) and c.func.id in primitives)
    reads = sum(1 for c in calls if isinstance(c.func, ast.Attribute) and c.func.attr == "get_object_position")
    return CallCount(actions, reads)


def _nested_source(code: str, node: ast.stmt, indent: str) -> str:
    """A statement from inside a loop as segments keep it: first line bare, later lines at ``indent``."""
    text = textwrap.dedent(ast.get_source_segment(code, node, padded=True) or ast.unparse(node))
    return text.replace("\n", "\n" + indent)


# ------------------------------------------------------------------------------------------ data flow


def loads(node: ast.AST) -> set[str]:
    """Names the node reads."""
    return {n.id for n in ast.walk(node) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)}


def stores(node: ast.AST) -> set[str]:
    """Names the node assigns (on some path)."""
    return {n.id for n in ast.walk(node) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)}


def reads_before_assigning(body: list[ast.stmt], assigned: frozenset[str] = frozenset()) -> set[str]:
    """Names a block reads before it assigns them itself (a branch's ``sign`` set and then used is not)."""
    out: set[str] = set()
    for stmt in body:
        if isinstance(stmt, ast.If):
            out |= (
                (loads(stmt.test) - assigned)
                | reads_before_assigning(stmt.body, assigned)
                | reads_before_assigning(stmt.orelse, assigned)
            )
        else:
            out |= loads(stmt) - assigned
        assigned = assigned | always_assigned([stmt])
    return out


def always_assigned(body: list[ast.stmt]) -> set[str]:
    """Names a block assigns on every path through it (an augmented assignment reads its old value)."""
    names: set[str] = set()
    for stmt in body:
        if isinstance(stmt, ast.Assign | ast.AnnAssign):
            targets = stmt.targets if isinstance(stmt, ast.Assign) else [stmt.target]
            names |= {n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)}
        elif isinstance(stmt, ast.If) and stmt.orelse:
            names |= always_assigned(stmt.body) & always_assigned(stmt.orelse)
    return names


def computes(stmt: ast.stmt, primitives: set[str]) -> bool:
    """An assignment, or a branch of them, that moves nothing (no primitive call): safe to run again."""
    if not isinstance(stmt, ast.Assign | ast.AugAssign | ast.AnnAssign | ast.If):
        return False
    calls = {n.func.id for n in ast.walk(stmt) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}
    return not calls & primitives


def dependency_indices(earlier: list[ast.stmt], node: ast.AST, primitives: set[str]) -> list[int]:
    """Which of the ``earlier`` statements (assignments and branches of them, no primitive calls)
    ``node`` depends on, in order.

    Only the latest definition of a value is taken: once a statement is chosen, what it assigns on
    every path is no longer needed from further back.
    """
    needed = loads(node)
    chosen = []
    for index in range(len(earlier) - 1, -1, -1):
        stmt = earlier[index]
        if not computes(stmt, primitives) or not stores(stmt) & needed:
            continue
        chosen.append(index)
        needed = (needed - always_assigned([stmt])) | reads_before_assigning([stmt])
    return chosen[::-1]


def recomputed_indices(
    earlier: list[ast.stmt], node: ast.AST, primitives: set[str], kept: frozenset[str] = frozenset()
) -> list[int]:
    """Of :func:`dependency_indices`, the statements that may compute another value when run again:
    those that call something (a task query reads the world as it is now) and those that read what
    such a statement assigns. The rest would compute what they hold already from the same values
    (an unrolled loop's ``name, dx, dy = [first, -0.045, -0.045]``, a ``lift += 0.01`` that would add
    its offset twice). A name assigned on some paths only, or augmented, is read as well: its old
    value goes on. A statement that assigns only ``kept`` names is not run again: its value stands
    (where the held tool lay when it was read, not where the hand carries it now)."""
    chosen, changed = [], set()
    for index in dependency_indices(earlier, node, primitives):
        stmt = earlier[index]
        if stores(stmt) and stores(stmt) <= kept:
            continue
        reads = loads(stmt) | (stores(stmt) - always_assigned([stmt]))
        if any(isinstance(n, ast.Call) for n in ast.walk(stmt)) or reads & changed:
            chosen.append(index)
            changed |= stores(stmt)
    return chosen


def definition_indices(earlier: list[ast.stmt], primitives: set[str]) -> list[int]:
    """Which of the ``earlier`` assignments (and branches of them, no primitive calls) still define a value, in order."""
    chosen, defined = [], set()
    for index in range(len(earlier) - 1, -1, -1):
        stmt = earlier[index]
        if not computes(stmt, primitives) or not stores(stmt) - defined:
            continue
        chosen.append(index)
        defined |= always_assigned([stmt])
    return chosen[::-1]


def plain_assignments(statements: list[ast.stmt]) -> dict[str, ast.expr]:
    """``targets -> value`` of the plain assignments among ``statements`` (the last one of each)."""
    return {
        ", ".join(ast.unparse(t) for t in s.targets): s.value
        for s in statements
        if isinstance(s, ast.Assign) and not any(isinstance(t, ast.Subscript | ast.Attribute) for t in s.targets)
    }


def assigned_names(code: str) -> list[str]:
    """The variables ``code``'s statements assign, in the order they assign them."""
    names = [
        n.id
        for statement in parse_statements(code)
        for n in ast.walk(statement)
        if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)
    ]
    return list(dict.fromkeys(names))


def parse_statements(code: str) -> list[ast.stmt]:
    """``code``'s statements (none where it does not parse: what it calls or assigns is then unknown)."""
    try:
        return ast.parse(textwrap.dedent(code)).body
    except SyntaxError:
        return []


def called_names(code: str) -> set[str]:
    """Names of the functions and task queries ``code`` calls."""
    return {
        n.func.id if isinstance(n.func, ast.Name) else n.func.attr
        for n in ast.walk(ast.Module(parse_statements(code), []))
        if isinstance(n, ast.Call) and isinstance(n.func, ast.Name | ast.Attribute)
    }
