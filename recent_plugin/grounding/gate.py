"""Checks before anything runs: generated code is untrusted.

Two layers over one AST walk:

* the **security gate** (:func:`security_gate`), which every method's code passes before it
  runs: no imports, no dunder or private names, no dynamic execution (``eval``, ``exec``,
  ``open``, ``getattr`` …), no unbounded loops or huge literals, no attribute walks into the
  simulator (skill code reaches the world only through primitives and ``task.<query>(…)``), no
  work or memory whose bound is statically too large (a sequence repeated, a nest of loops over
  literal ranges, a huge %-format width: the static twins of the executor's run-time budget,
  :mod:`~lerobot_policy_recent.recent_plugin.sandbox`), and nothing that the executor could not
  run as written (a primitive used as a value, a helper or nested function: a skill is one
  function, whose statements the executor runs one by one). Code that passes it is *safe*: a
  wrong name or keyword in it fails when it is reached, with the error Python gives (the paper's
  protocol for the baselines), and whatever it does at run time stays within its budget;
* **interface validation** (:func:`validate_program`), RECENT's validation stage: on top of the
  gate, every call is one of the target robot's primitives with its declared keywords, or a task
  query or helper, and every name is defined.

A verdict lists every violation (its category and line are the first one's), so a retry hears
all of them at once.
"""

from __future__ import annotations

import ast
import builtins
from collections.abc import Iterable
from contextlib import contextmanager
from dataclasses import dataclass

from lerobot_policy_recent.ontology.conversions import OBJECT_NAME
from lerobot_policy_recent.ontology.skill_code import name_variables, variable_kinds
from lerobot_policy_recent.ontology.specs import RECEIVING_ROLES, ROLE_MEANINGS, ApiSpec, ParameterSpec, held_along
from lerobot_policy_recent.recent_plugin.failures import FailureCategory
from lerobot_policy_recent.recent_plugin.sandbox import MAX_NESTED_ITERATIONS, format_problem
from lerobot_policy_recent.robosuite_envs.primitives.frames import SKILL_HELPERS
from lerobot_policy_recent.robosuite_envs.primitives.session import TaskContext

SAFE_HELPERS = frozenset(SKILL_HELPERS) | frozenset(  # conversions between frames and rotations, then builtins
    {
        "abs",
        "min",
        "max",
        "round",
        "len",
        "range",
        "list",
        "tuple",
        "float",
        "int",
        "bool",
        "sum",
        "zip",
        "enumerate",
        "sorted",
    }
)
TASK_QUERIES = frozenset(TaskContext.QUERIES + TaskContext.FRAME_QUERIES)
FORBIDDEN_CALLS = frozenset(
    {
        "exec",
        "eval",
        "compile",
        "open",
        "getattr",
        "setattr",
        "delattr",
        "globals",
        "locals",
        "vars",
        "__import__",
        "input",
        "breakpoint",
        "exit",
        "quit",
        "help",
        "memoryview",
        "type",
        "object",
        "super",
        "dir",
        "id",
    }
)
MAX_CONSTANT = 1e4  # no literal this large belongs in a skill (it is how huge allocations start)
MAX_RANGE = 1000
ROBOT_HANDLES = {"env": "session", "task": "task context"}  # every primitive call passes them on

FORBIDDEN_NODES = (
    ast.Import, ast.ImportFrom, ast.While, ast.Lambda, ast.ClassDef, ast.AsyncFunctionDef, ast.Await,
    ast.Global, ast.Nonlocal, ast.Try, ast.With, ast.AsyncWith, ast.AsyncFor, ast.Yield, ast.YieldFrom,
    ast.Delete, ast.Raise, ast.NamedExpr, ast.JoinedStr, ast.Starred, ast.Set, ast.SetComp, ast.DictComp, ast.GeneratorExp,
)  # fmt: skip


@dataclass(frozen=True)
class Verdict:
    ok: bool
    category: FailureCategory | None = None
    message: str = ""
    line: int | None = None

    @classmethod
    def reject(cls, category: FailureCategory, message: str, node: ast.AST | None = None) -> Verdict:
        return cls(False, category, message, getattr(node, "lineno", None))

    @classmethod
    def of(cls, problems: list[Verdict]) -> Verdict:
        """Every violation found, the first one's category and line leading."""
        if not problems:
            return ACCEPT
        messages = list(dict.fromkeys(f"line {p.line}: {p.message}" if p.line else p.message for p in problems))
        first = problems[0]
        message = first.message if len(messages) == 1 else f"{len(messages)} problems: " + "; ".join(messages)
        return cls(False, first.category, message, first.line)


ACCEPT = Verdict(True)


def security_gate(code: str, entry: str, primitives: Iterable[str] = ()) -> Verdict:
    """Whether ``code`` is safe to run as a skill (see the module docstring); names and keywords unchecked.

    ``primitives``: the robot's primitive names, which may only be called (as a value, one would
    never be driven: the executor runs a primitive where the code calls it by name).
    """
    return _check(code, None, entry, {}, set(primitives))


def validate_program(code: str, api: ApiSpec, entry: str, other_apis: dict[str, ApiSpec] | None = None) -> Verdict:
    """The security gate, and every call and name checked against ``api`` (the target robot's primitives)."""
    return _check(code, api, entry, other_apis or {}, set(api.names()))


def _check(code: str, api: ApiSpec | None, entry: str, other_apis: dict[str, ApiSpec], primitives: set[str]) -> Verdict:
    if not code.strip():
        return Verdict.reject(FailureCategory.EMPTY_CONTINUATION, "the program is empty")
    try:
        tree = ast.parse(code)
    except SyntaxError as exc:
        return Verdict(False, FailureCategory.NON_EXECUTABLE, f"SyntaxError: {exc.msg}", exc.lineno)
    functions = [n for n in tree.body if isinstance(n, ast.FunctionDef)]
    extra = [n for n in tree.body if not isinstance(n, ast.FunctionDef) and not _is_docstring(n)]
    if extra:
        return Verdict.reject(
            FailureCategory.NON_EXECUTABLE, "only function definitions may appear at top level", extra[0]
        )
    if entry not in {f.name for f in functions}:
        return Verdict.reject(FailureCategory.HALLUCINATED_NAME, f"entry function {entry!r} is not defined")
    helpers = [f for f in functions if f.name != entry]
    if helpers:
        return Verdict.reject(
            FailureCategory.NON_EXECUTABLE,
            f"helper function {helpers[0].name!r} is not allowed: a skill is the one function {entry!r} "
            "(the executor runs its statements one by one); write the helper's statements in place",
            helpers[0],
        )
    checker = _Checker(api, other_apis, {f.name for f in functions}, primitives)
    for func in functions:
        checker.check_function(func)
    return Verdict.of(checker.problems)


def _is_docstring(node: ast.stmt) -> bool:
    return isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str)


# Roles of name-taking parameters that name what the hand will hold, and what it puts that on or into.


class _Checker(ast.NodeVisitor):
    """Collects violations; without an ``api`` only the security gate's (the interface is left to run time)."""

    def __init__(self, api: ApiSpec | None, other_apis: dict[str, ApiSpec], functions: set[str], primitives: set[str]):
        self.api = api
        self.interface = api is not None
        robot = api.embodiment if api is not None else None
        self.other: dict[str, str] = {}  # a name several robots share is named after the first (the Panda's)
        for other, spec in other_apis.items():
            for name in spec.names() if other != robot else ():
                self.other.setdefault(name, other)
        self.primitives = primitives
        self.functions = functions
        self.defined: set[str] = set()
        self.problems: list[Verdict] = []
        self.nest = 1  # the static iteration count of the loops around the node being visited

    def fail(self, category: FailureCategory, message: str, node: ast.AST) -> None:
        self.problems.append(Verdict.reject(category, message, node))

    def check_function(self, func: ast.FunctionDef) -> None:
        if func.decorator_list:
            self.fail(FailureCategory.NON_EXECUTABLE, "decorators are not allowed", func)
        args = func.args
        if args.vararg or args.kwarg or args.kwonlyargs:
            self.fail(FailureCategory.NON_EXECUTABLE, "*args/**kwargs are not allowed in skills", func)
        params = [a.arg for a in args.args]
        if params[:2] != ["env", "task"]:
            self.fail(FailureCategory.NON_EXECUTABLE, "a skill takes (env, task, ...) as its first parameters", func)
        self.defined = set(params) | self._assigned_names(func)
        self.kinds = variable_kinds(func)
        for default in args.defaults:
            self.visit(default)
        for stmt in func.body:
            self.visit(stmt)
        if self.api is not None:
            self._check_roles(func)

    def _check_roles(self, func: ast.FunctionDef) -> None:
        """Arguments checked by their role: a place's receptacle is not the object the hand holds then
        (put "on itself"). The held object is the last name a grasp took, in statement order."""
        calls = sorted(
            (n for n in ast.walk(func) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)),
            key=lambda n: (n.lineno, n.col_offset),
        )
        specs = [self.api.get(call.func.id) for call in calls]
        given = [{k.arg: ast.unparse(k.value) for k in call.keywords if k.arg} for call in calls]
        holds = held_along(
            list(zip(specs, given, strict=True)), lambda p, text: text if p.type == OBJECT_NAME else None
        )
        for call, spec, held in zip(calls, specs, holds, strict=True):
            for keyword in call.keywords if spec is not None and held is not None else ():
                param = spec.parameter(keyword.arg) if keyword.arg else None
                value = ast.unparse(keyword.value)
                if param is None or param.type != OBJECT_NAME or param.role not in RECEIVING_ROLES or value != held[0]:
                    continue
                since = calls[held[1]]
                self.fail(
                    FailureCategory.HALLUCINATED_KWARG,
                    f"{keyword.arg}={value}: {spec.name}'s {keyword.arg} is {ROLE_MEANINGS[param.role]}, but "
                    f"{value} is the object held since line {since.lineno} ({ast.unparse(since.func)}(..., {value}))",
                    call,
                )

    @staticmethod
    def _assigned_names(func: ast.FunctionDef) -> set[str]:
        names = set()
        for node in ast.walk(func):
            if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                names.add(node.id)
        return names

    def generic_visit(self, node: ast.AST) -> None:
        if isinstance(node, FORBIDDEN_NODES):
            self.fail(FailureCategory.NON_EXECUTABLE, f"{type(node).__name__} is not allowed in skill code", node)
        if isinstance(node, ast.FunctionDef):
            self.fail(FailureCategory.NON_EXECUTABLE, "nested function definitions are not allowed", node)
        super().generic_visit(node)

    def visit_Name(self, node: ast.Name) -> None:
        """A name used as a value: a parameter or assigned variable (callables only in call position)."""
        if node.id.startswith("_"):
            self.fail(FailureCategory.NON_EXECUTABLE, f"private or dunder name {node.id!r}", node)
        if node.id in ROBOT_HANDLES and not isinstance(node.ctx, ast.Load):
            self.fail(
                FailureCategory.NON_EXECUTABLE,
                f"{node.id!r} is the robot's {ROBOT_HANDLES[node.id]}; skill code may not assign it",
                node,
            )
        if isinstance(node.ctx, ast.Load) and node.id not in self.defined | {"True", "False", "None"}:
            self._unknown_name(node.id, node, called=False)

    def _unknown_name(self, name: str, node: ast.AST, *, called: bool) -> None:
        """A name the code does not define: unsafe as a value where it is a callable or a builtin; else
        (interface validation only) another robot's primitive or an undefined name."""
        if not called and (name in self.primitives or name in self.functions or name in SAFE_HELPERS):
            self.fail(FailureCategory.NON_EXECUTABLE, f"{name!r} may only be called, not used as a value", node)
        elif name in FORBIDDEN_CALLS or (not called and hasattr(builtins, name) and name not in self.other):
            self.fail(FailureCategory.NON_EXECUTABLE, f"builtin {name!r} is not allowed in skill code", node)
        elif not self.interface:
            return  # an undefined name: a NameError when it is reached
        elif name in self.other:
            self.fail(
                FailureCategory.HALLUCINATED_API,
                f"{name} is a {self.other[name]} primitive, not available on {self.api.embodiment}",
                node,
            )
        elif hasattr(builtins, name):
            self.fail(FailureCategory.NON_EXECUTABLE, f"builtin {name!r} is not allowed in skill code", node)
        else:
            self.fail(FailureCategory.HALLUCINATED_NAME, f"name {name!r} is not defined", node)

    def visit_Attribute(self, node: ast.Attribute) -> None:
        if node.attr.startswith("_"):
            self.fail(FailureCategory.NON_EXECUTABLE, f"private or dunder attribute {node.attr!r}", node)
        if not (isinstance(node.value, ast.Name) and node.value.id == "task" and node.attr in TASK_QUERIES):
            self.fail(
                FailureCategory.HALLUCINATED_API,
                f"attribute access .{node.attr} is not allowed (task queries: {', '.join(sorted(TASK_QUERIES))})",
                node,
            )

    def visit_Constant(self, node: ast.Constant) -> None:
        if isinstance(node.value, int | float) and not isinstance(node.value, bool) and abs(node.value) > MAX_CONSTANT:
            self.fail(FailureCategory.NON_EXECUTABLE, f"constant {node.value!r} is out of range for a skill", node)
        if isinstance(node.value, str | bytes) and len(node.value) > 200:
            self.fail(FailureCategory.NON_EXECUTABLE, "string literal too long", node)

    def visit_BinOp(self, node: ast.BinOp) -> None:
        if isinstance(node.op, ast.Pow | ast.LShift):
            self.fail(
                FailureCategory.NON_EXECUTABLE, "power and shift operators are not allowed (unbounded results)", node
            )
        if isinstance(node.op, ast.Mult) and (_is_sequence(node.left) or _is_sequence(node.right)):
            self.fail(FailureCategory.NON_EXECUTABLE, "sequence repetition is not allowed", node)
        if isinstance(node.op, ast.Mod) and isinstance(node.left, ast.Constant) and isinstance(node.left.value, str):
            problem = format_problem(node.left.value)
            if problem:
                self.fail(FailureCategory.NON_EXECUTABLE, f"{problem} is not allowed (a huge string)", node)
        self.generic_visit(node)

    def visit_AugAssign(self, node: ast.AugAssign) -> None:
        if isinstance(node.op, ast.Mult) and _is_sequence(node.value):
            self.fail(FailureCategory.NON_EXECUTABLE, "sequence repetition is not allowed", node)
        if isinstance(node.op, ast.Pow | ast.LShift):
            self.fail(
                FailureCategory.NON_EXECUTABLE, "power and shift operators are not allowed (unbounded results)", node
            )
        self.generic_visit(node)

    def visit_For(self, node: ast.For) -> None:
        self._check_iterable(node.iter, node)
        self.visit(node.target)
        self.visit(node.iter)
        with self._loop(node.iter, node):
            for stmt in node.body + node.orelse:
                self.visit(stmt)

    def visit_ListComp(self, node: ast.ListComp) -> None:
        """A comprehension's ``for`` clauses are loops too: bounded the same way (nested ones multiply)."""
        outer = self.nest
        for generator in node.generators:
            self._check_iterable(generator.iter, generator.iter)
            self.visit(generator.iter)
            self._enter_loop(generator.iter, generator.iter)
            self.visit(generator.target)
            for condition in generator.ifs:
                self.visit(condition)
        self.visit(node.elt)
        self.nest = outer

    @contextmanager
    def _loop(self, iterable: ast.expr, node: ast.AST):
        outer = self.nest
        self._enter_loop(iterable, node)
        try:
            yield
        finally:
            self.nest = outer

    def _enter_loop(self, iterable: ast.expr, node: ast.AST) -> None:
        """Multiply the nest by the loop's static length; refuse a nest whose product is too large."""
        length = _static_length(iterable)
        if length is None:
            return
        within = self.nest <= MAX_NESTED_ITERATIONS
        self.nest *= max(length, 1)
        if within and self.nest > MAX_NESTED_ITERATIONS:
            self.fail(
                FailureCategory.NON_EXECUTABLE,
                f"nested loops of {self.nest:,} iterations are not allowed (at most {MAX_NESTED_ITERATIONS:,})",
                node,
            )

    def _check_iterable(self, it: ast.expr, node: ast.AST) -> None:
        """A loop runs over something of bounded size: a literal, a variable, range() and its kin, or
        the fixed-size vector a position or frame query or a conversion helper returns (an object's
        point, a frame's point, a rotation: a traced KRL move scales a named object's point to mm)."""
        func = it.func if isinstance(it, ast.Call) else None
        bounded = (
            isinstance(it, ast.List | ast.Tuple | ast.Name)
            or (isinstance(func, ast.Name) and func.id in {"range", "enumerate", "zip", "sorted", *SKILL_HELPERS})
            or (
                isinstance(func, ast.Attribute)
                and isinstance(func.value, ast.Name)
                and func.value.id == "task"
                and func.attr in ("get_object_position", *TaskContext.FRAME_QUERIES)
            )
        )
        if not bounded:
            self.fail(
                FailureCategory.NON_EXECUTABLE,
                "for-loops must iterate over a literal, a variable, range() or a frame query",
                node,
            )

    def _check_range(self, node: ast.Call) -> None:
        """``range()`` anywhere (a loop, ``list(range(...))``) takes integer literals up to MAX_RANGE."""
        if not all(
            isinstance(a, ast.Constant) and isinstance(a.value, int) and abs(a.value) <= MAX_RANGE for a in node.args
        ):
            self.fail(
                FailureCategory.NON_EXECUTABLE, f"range() bounds must be integer literals up to {MAX_RANGE}", node
            )

    def visit_Call(self, node: ast.Call) -> None:
        func = node.func
        if isinstance(func, ast.Name) and func.id == "range":
            self._check_range(node)
        if isinstance(func, ast.Attribute):
            task_call = isinstance(func.value, ast.Name) and func.value.id == "task" and not func.attr.startswith("_")
            if self.interface or not task_call:  # the gate lets any task.<public>(...) fail at run time
                self.visit_Attribute(func)
        elif isinstance(func, ast.Name):
            spec = self.api.get(func.id) if self.api is not None else None
            if func.id.startswith("_"):
                self.fail(FailureCategory.NON_EXECUTABLE, f"private or dunder name {func.id!r}", node)
            elif spec is not None:
                self._check_primitive_call(node, spec.name, {p.name: p for p in spec.parameters})
            elif func.id in FORBIDDEN_CALLS:
                self.fail(FailureCategory.NON_EXECUTABLE, f"call to {func.id}() is forbidden", node)
            elif func.id in self.defined:
                if self.interface:
                    self.fail(
                        FailureCategory.NON_EXECUTABLE,
                        f"{func.id!r} is a variable; only primitives and helpers may be called",
                        node,
                    )
            elif func.id in self.functions:
                self.fail(FailureCategory.NON_EXECUTABLE, f"a skill may not call itself ({func.id}())", node)
            elif func.id not in SAFE_HELPERS:
                self._unknown_name(func.id, node, called=True)
        else:
            self.fail(FailureCategory.NON_EXECUTABLE, "only plain functions and task queries may be called", node)
        for arg in node.args:
            self.visit(arg)
        for kw in node.keywords:
            if kw.arg is None:
                self.fail(FailureCategory.NON_EXECUTABLE, "**kwargs expansion is not allowed", node)
            self.visit(kw.value)

    def _check_primitive_call(self, node: ast.Call, name: str, params: dict[str, ParameterSpec]) -> None:
        if (
            len(node.args) != 2
            or not all(isinstance(a, ast.Name) for a in node.args)
            or [a.id for a in node.args] != ["env", "task"]
        ):
            self.fail(
                FailureCategory.HALLUCINATED_KWARG,
                f"{name}() takes env, task positionally and everything else by keyword",
                node,
            )
        given = {kw.arg for kw in node.keywords}
        for kw in node.keywords:
            spec = params.get(kw.arg)
            if spec is None:
                self.fail(
                    FailureCategory.HALLUCINATED_KWARG,
                    f"{name}() got an unexpected keyword argument {kw.arg!r} (accepts: {', '.join(params) or 'none'})",
                    node,
                )
                continue
            problem = _literal_type_problem(kw.value, spec) or _variable_kind_problem(kw.value, spec, self.kinds)
            if problem:
                self.fail(FailureCategory.HALLUCINATED_KWARG, f"{name}({kw.arg}=...): {problem}", node)
        missing = [p for p, spec in params.items() if spec.required and p not in given]
        if missing:
            self.fail(
                FailureCategory.HALLUCINATED_KWARG,
                f"{name}() missing required keyword argument(s): {', '.join(missing)}",
                node,
            )


def _is_sequence(expr: ast.expr) -> bool:
    """Whether ``expr`` is a list, tuple or string by its form alone (a literal, a comprehension, a
    copy by ``list()``/``tuple()``/``sorted()``, or a sum or repetition of one)."""
    if isinstance(expr, ast.List | ast.Tuple | ast.ListComp | ast.JoinedStr):
        return True
    if isinstance(expr, ast.Constant):
        return isinstance(expr.value, str | bytes)
    if isinstance(expr, ast.Call) and isinstance(expr.func, ast.Name):
        return expr.func.id in {"list", "tuple", "sorted"}
    if isinstance(expr, ast.BinOp) and isinstance(expr.op, ast.Add | ast.Mult):
        return _is_sequence(expr.left) or _is_sequence(expr.right)
    return False


def _static_length(iterable: ast.expr) -> int | None:
    """How many items a loop's iterable yields, where its form says (``range`` of literals, a literal)."""
    if isinstance(iterable, ast.List | ast.Tuple):
        return len(iterable.elts)
    if not (isinstance(iterable, ast.Call) and isinstance(iterable.func, ast.Name)):
        return None
    name, args = iterable.func.id, iterable.args
    if name == "range":
        values = [a.value for a in args if isinstance(a, ast.Constant) and isinstance(a.value, int)]
        if len(values) != len(args) or not 1 <= len(values) <= 3 or (len(values) == 3 and values[2] == 0):
            return None
        return len(range(*values))
    if name in {"enumerate", "sorted", "list", "tuple"} and args:
        return _static_length(args[0])
    if name == "zip" and args:
        lengths = [_static_length(a) for a in args]
        known = [n for n in lengths if n is not None]
        return min(known) if known else None
    return None


def _variable_kind_problem(value: ast.expr, spec: ParameterSpec, kinds: dict[str, str]) -> str | None:
    kind = kinds.get(value.id) if isinstance(value, ast.Name) else None
    if kind == "position" and spec.type in {"object_name", "str"}:
        names = name_variables(kinds)
        # the retry's cue: the 1.5B otherwise wrote the position again on every attempt (peg_pos for peg)
        candidates = f"; names here: {', '.join(names)}" if names else ""
        return (
            f"expects {'an object name' if spec.type == 'object_name' else 'a string'}, but {value.id} holds a position"
            + candidates
        )
    if kind == "name" and spec.type in {"position", "quaternion", "float", "int"}:
        return f"expects a {spec.type}, but {value.id} holds a name"
    return None


def _literal_type_problem(value: ast.expr, spec: ParameterSpec) -> str | None:
    """Type-check literal arguments against the parameter spec; variables are checked at run time."""
    if isinstance(value, ast.Constant):
        v = value.value
        if spec.type in {"float", "int"} and (isinstance(v, bool) or not isinstance(v, int | float)):
            return f"expects a number, got {v!r}"
        if spec.type in {"float", "int"} and spec.range and not spec.range[0] <= v <= spec.range[1]:
            return f"{v!r} is outside {list(spec.range)}"
        if spec.type in {"str", "object_name"} and not isinstance(v, str):
            return f"expects a string, got {v!r}"
        if spec.choices and v not in spec.choices:
            return f"{v!r} is not one of {list(spec.choices)}"
        if spec.type in {"position", "quaternion"}:
            return f"expects a {spec.type} (list of numbers), got {v!r}"
    if isinstance(value, ast.List | ast.Tuple) and spec.type == "position" and len(value.elts) != 3:
        return f"a position has 3 elements, got {len(value.elts)}"
    return None
