"""The run-time budget of skill code: Python time between two actions, and the memory it may create.

The security gate (:mod:`~lerobot_policy_recent.recent_plugin.grounding.gate`) refuses what is
unsafe to run; code that passes it can still loop for minutes or build a gigabyte in one
expression. Every skill the executor runs, whoever wrote it (an LM, a baseline, a user's
``--skill_library``), is therefore compiled *instrumented* (:func:`instrument`):

* every loop iteration, a comprehension's included, calls :meth:`Meter.tick`;
* ``*``, ``+``, ``%`` and their augmented forms go through :meth:`Meter.binop`, which computes the
  size of the result *before* Python builds it (a list repeated, a string padded by a format
  width, an integer multiplied to thousands of digits) and refuses one over the budget; a slice
  assignment counts what it inserts (``x[0:0] = x`` grows ``x`` in place);
* the builtins that copy a sequence (``list``, ``tuple``, ``sorted``) charge what they build, and
  ``sum`` adds numbers only (summing lists is a quadratic copy);
* what Python or numpy walks recursively in one C call (the operands of a comparison, a dict key,
  the arguments of ``%``, of ``min``/``max``/``sorted`` and of every call: a primitive turns its
  arguments into arrays) must be nested within bounds: ``x = [x, x]`` a few hundred times builds a
  small value whose comparison, hash or conversion never ends.

A :class:`Meter` counts, per skill, the items it has created (elements and characters) and, per
control step, the seconds its code has run. Going over either raises :class:`BudgetExceeded`,
which the executor turns into the failure category ``budget_exceeded`` naming the budget and the
line: the segment fails as any other (in-situ repair, or the episode ends), and the process goes
on. Nothing here traces Python: the cost is a function call where skill code loops or does
arithmetic, and two clock reads per control step (``docs/decisions.md``; ``BENCHMARKS.md``).

The static twins of these rules (a literal sequence repeated, a nest of ``range`` loops with a
large product, a huge format width) are the gate's, so such a span is refused before it runs.
"""

from __future__ import annotations

import ast
import builtins
import copy
import operator
import re
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from lerobot_policy_recent.recent_plugin.failures import FailureCategory

MAX_INT_BITS = 4096  # no robot skill needs an integer of more than 1,233 digits
MAX_FORMAT_WIDTH = 1000  # a %-format's width or precision
MAX_NESTED_ITERATIONS = 10_000  # a nest of loops over literal bounds (the gate's static rule)
_FORMAT = re.compile(r"%(?:\([^)]*\))?[#0 +-]*(\*|\d+)?(?:\.(\*|\d+))?[hlL]?[diouxXeEfFgGcrsab%]")


@dataclass(frozen=True)
class SkillBudget:
    """What one skill may spend at run time (``--skill_budget.*``); defaults in ``docs/decisions.md``."""

    step_seconds: float = 2.0  # Python time of the skill's code between two actions (its primitives' included)
    max_value_items: int = 1_000_000  # elements or characters in any one value it builds
    max_created_items: int = 20_000_000  # elements and characters it builds over its whole run

    def __post_init__(self):
        for name in ("step_seconds", "max_value_items", "max_created_items"):
            if not getattr(self, name) > 0:
                raise ValueError(f"--skill_budget.{name} must be > 0, got {getattr(self, name)}")


class BudgetExceeded(Exception):  # noqa: N818 - it is what the skill did, not an error of ours
    """Skill code went over its :class:`SkillBudget`; ``budget`` is ``time`` or ``memory``."""

    category = FailureCategory.BUDGET_EXCEEDED

    def __init__(self, budget: str, message: str):
        super().__init__(message)
        self.budget = budget


_SEQUENCES = (list, tuple, str, bytes, bytearray)


def _size(value: object) -> int | None:
    """Items a value holds (characters of a string), or None where it is not a sized sequence."""
    return len(value) if isinstance(value, _SEQUENCES) else None


def format_problem(template: str | bytes) -> str | None:
    """Why a %-format string would build a huge string (a width or precision over the limit, or ``*``)."""
    text = template.decode("latin-1") if isinstance(template, bytes) else template
    for match in _FORMAT.finditer(text):
        for value in match.groups():
            if value == "*":
                return "a '*' width or precision in a %-format"
            if value and int(value) > MAX_FORMAT_WIDTH:
                return f"a %-format width or precision of {int(value)} (at most {MAX_FORMAT_WIDTH})"
    return None


class Meter:
    """One skill's spending. The executor brackets each advance of its code with :meth:`enter` and
    :meth:`leave` and calls :meth:`new_step` per action; the instrumented code calls the rest."""

    def __init__(self, budget: SkillBudget):
        self.budget = budget
        self.created = 0  # items built over the skill's run
        self.step_spent = 0.0  # seconds run since the last action, before the current advance
        self._entered = 0.0
        self._inside = False  # within an advance of the skill (time counts only there)
        self._clock = time.perf_counter

    # -- the executor's side
    def new_step(self) -> None:
        self.step_spent = 0.0

    def enter(self) -> None:
        self._entered, self._inside = self._clock(), True

    def leave(self) -> None:
        self.step_spent += self._clock() - self._entered
        self._inside = False

    def check_time(self) -> None:
        if not self._inside:  # an expression the executor evaluates between advances: memory is still metered
            return
        spent = self.step_spent + self._clock() - self._entered
        if spent > self.budget.step_seconds:
            raise BudgetExceeded(
                "time",
                f"the skill ran {spent:.1f} s of Python without an action "
                f"(budget: {self.budget.step_seconds:g} s between two actions, --skill_budget.step_seconds)",
            )

    # -- the instrumented code's side
    def limit(self, items: int) -> None:
        """Refuse to build a value of ``items`` elements or characters (checked before it is built)."""
        if items > self.budget.max_value_items:
            raise BudgetExceeded(
                "memory",
                f"the skill would build a value of {items:,} items "
                f"(budget: {self.budget.max_value_items:,} per value, --skill_budget.max_value_items)",
            )

    def charge(self, items: int) -> None:
        """Count ``items`` newly built; refuse to go on past the skill's total."""
        self.created += items
        if self.created > self.budget.max_created_items:
            raise BudgetExceeded(
                "memory",
                f"the skill has built {self.created:,} items "
                f"(budget: {self.budget.max_created_items:,} over its run, --skill_budget.max_created_items)",
            )

    def tick(self) -> bool:
        """One loop iteration (True, so it can stand in a comprehension's ``if``)."""
        self.charge(1)
        self.check_time()
        return True

    def binop(self, op: str, left: object, right: object) -> object:
        """``left op right``, refused before it is computed where its result would be too big.

        Numbers take the short way (an integer's size is checked by its bits); time is not checked
        here: one operation is bounded by its size, and many need a loop, whose ticks check it."""
        if (type(left) is float and type(right) in _NUMBERS) or (type(right) is float and type(left) in _NUMBERS):
            return _OPERATORS[op](left, right)
        self._precheck(op, left, right)
        before = _size(left) if op.endswith("=") else None  # an in-place update grows ``left`` itself
        result = _OPERATORS[op](left, right)
        size = _size(result)
        if size is not None:  # what no precheck sizes (a %-format's output) is held to the same bound once built
            self.limit(size)
            self.charge(size - before if result is left and before is not None else size)
        return result

    def _precheck(self, op: str, left: object, right: object) -> None:
        if op in ("*", "*="):
            for seq, times in ((left, right), (right, left)):
                size = _size(seq)
                if size is not None and isinstance(times, int):
                    self.limit(size * max(times, 0))
            if isinstance(left, int) and isinstance(right, int) and not isinstance(left | right, bool):
                bits = left.bit_length() + right.bit_length()
                if bits > MAX_INT_BITS:
                    raise BudgetExceeded(
                        "memory", f"the skill would build an integer of ~{bits:,} bits (at most {MAX_INT_BITS})"
                    )
        elif op in ("+", "+="):
            sizes = (_size(left), _size(right))
            if None not in sizes:
                self.limit(sizes[0] + sizes[1])
        elif op in ("%", "%=") and isinstance(left, str | bytes):
            problem = format_problem(left)
            if problem:
                raise BudgetExceeded("memory", f"the skill would build a huge string: {problem}")
            self.bounded(right)

    def built(self, make: Callable[..., object]) -> Callable[..., object]:
        """A builtin that copies a sequence, charging what it builds."""

        def charged(*args, **kwargs):
            result = make(*args, **kwargs)
            size = _size(result)
            if size is not None:
                self.limit(size)
                self.charge(size)
            self.check_time()
            return result

        charged.__name__ = make.__name__
        return charged

    def sum(self, values: Iterable, start: object = 0) -> object:
        if not isinstance(start, int | float) or isinstance(start, bool):
            raise BudgetExceeded("memory", "sum() of sequences copies them over and over; skill code sums numbers only")
        total = builtins.sum(values, start)
        self.check_time()
        return total

    def bounded(self, value: object) -> object:
        """``value``, once it is known to hold at most ``max_value_items`` nested sequences, counted with
        repeats (what a comparison, hash or repr of it walks); else :class:`BudgetExceeded`."""
        if not isinstance(value, _CONTAINERS):
            return value
        todo, seen = [value], 0
        while todo:
            item = todo.pop()
            seen += 1
            if seen > self.budget.max_value_items:
                raise BudgetExceeded(
                    "time",
                    f"the skill compares, hashes or formats a value nested over {self.budget.max_value_items:,} "
                    "sequences deep and wide (one C call would walk it for minutes)",
                )
            todo.extend(v for v in (item.values() if isinstance(item, dict) else item) if isinstance(v, _CONTAINERS))
        return value

    def bounded_all(self, make: Callable[..., object]) -> Callable[..., object]:
        """A builtin that compares its arguments' items (``min``, ``max``, ``sorted``), on bounded arguments."""

        def checked(*args, **kwargs):
            for arg in args:
                self.bounded(arg)
            return make(*args, **kwargs)

        checked.__name__ = make.__name__
        return checked

    def spliced(self, value: object) -> object:
        """What a slice assignment inserts (``x[0:0] = x`` grows ``x`` in place), counted as built."""
        items = value if isinstance(value, _SEQUENCES) else list(value)  # Python materialises it anyway
        self.limit(len(items))
        self.charge(len(items))
        return items

    def names(self) -> dict[str, object]:
        """What instrumented code calls, by the names :func:`instrument` writes."""
        return {TICK: self.tick, BINOP: self.binop, BOUNDED: self.bounded, SPLICED: self.spliced}

    def builtins(self, base: dict[str, object]) -> dict[str, object]:
        """``base`` (a skill's builtins) with the copying ones charged."""
        out = dict(base)
        for name in ("min", "max", "sorted"):
            if name in out:
                out[name] = self.bounded_all(out[name])  # type: ignore[arg-type]
        for name in ("list", "tuple", "sorted"):
            if name in out:
                out[name] = self.built(out[name])  # type: ignore[arg-type]
        if "sum" in out:
            out["sum"] = self.sum
        return out


TICK = "_recent_tick"  # names the gate would refuse in skill code, so a skill cannot shadow them
BINOP = "_recent_binop"
BOUNDED = "_recent_bounded"
SPLICED = "_recent_spliced"
_CONTAINERS = (list, tuple, dict)
_NUMBERS = (int, float)
_OPERATORS: dict[str, Callable[[object, object], object]] = {
    "*": operator.mul,
    "+": operator.add,
    "%": operator.mod,
    "*=": operator.imul,
    "+=": operator.iadd,
    "%=": operator.imod,
}
_SYMBOLS = {ast.Mult: "*", ast.Add: "+", ast.Mod: "%"}


def _call(name: str, *args: ast.expr) -> ast.Call:
    return ast.Call(func=ast.Name(name, ast.Load()), args=list(args), keywords=[])


def _as_load(target: ast.expr) -> ast.expr:
    """The target of an augmented assignment, read (``a[i] += 1`` reads ``a[i]``)."""
    load = ast.parse(ast.unparse(target), mode="eval").body
    return ast.copy_location(load, target)


class _Instrument(ast.NodeTransformer):
    def visit_For(self, node: ast.For) -> ast.AST:
        self.generic_visit(node)
        node.body.insert(0, ast.copy_location(ast.Expr(_call(TICK)), node))
        return node

    def visit_comprehension(self, node: ast.comprehension) -> ast.AST:
        self.generic_visit(node)
        node.ifs.insert(0, _call(TICK))
        return node

    def visit_BinOp(self, node: ast.BinOp) -> ast.AST:
        self.generic_visit(node)
        symbol = _SYMBOLS.get(type(node.op))
        if symbol is None:
            return node
        return ast.copy_location(_call(BINOP, ast.Constant(symbol), node.left, node.right), node)

    def visit_Call(self, node: ast.Call) -> ast.AST:
        self.generic_visit(node)
        node.args = [a if isinstance(a, ast.Starred) else _call(BOUNDED, a) for a in node.args]
        for keyword in node.keywords:
            keyword.value = _call(BOUNDED, keyword.value)
        return node

    def visit_Assign(self, node: ast.Assign) -> ast.AST:
        self.generic_visit(node)
        if any(isinstance(t, ast.Subscript) and isinstance(t.slice, ast.Slice) for t in node.targets):
            node.value = _call(SPLICED, node.value)
        return node

    def visit_Compare(self, node: ast.Compare) -> ast.AST:
        self.generic_visit(node)
        node.left = _call(BOUNDED, node.left)
        node.comparators = [_call(BOUNDED, c) for c in node.comparators]
        return node

    def visit_Dict(self, node: ast.Dict) -> ast.AST:
        self.generic_visit(node)
        node.keys = [k if k is None else _call(BOUNDED, k) for k in node.keys]
        return node

    def visit_Subscript(self, node: ast.Subscript) -> ast.AST:
        self.generic_visit(node)
        if not isinstance(node.slice, ast.Constant | ast.Slice):  # a key that may be hashed
            node.slice = _call(BOUNDED, node.slice)
        return node

    def visit_AugAssign(self, node: ast.AugAssign) -> ast.AST:
        self.generic_visit(node)
        symbol = _SYMBOLS.get(type(node.op))
        if symbol is None:
            return node
        value = _call(BINOP, ast.Constant(symbol + "="), _as_load(node.target), node.value)
        return ast.copy_location(ast.Assign(targets=[node.target], value=value), node)


def instrument(node: ast.AST) -> ast.AST:
    """``node`` (a statement of skill code, modified in place) with its loops and operators metered."""
    return ast.fix_missing_locations(_Instrument().visit(node))


UNKNOWN = object()  # an expression that cannot be evaluated now


def evaluate_now(node: ast.expr, namespace: dict) -> object:
    """The value of an expression of validated code in ``namespace`` now (``UNKNOWN`` where it fails),
    metered as the skill's own code is (the executor's namespace holds its meter)."""
    try:
        expression = ast.Expression(node)
        scope = dict(namespace)
        if any(isinstance(n, ast.BinOp | ast.comprehension) for n in ast.walk(node)):  # what could build a lot
            expression = instrument(ast.Expression(copy.deepcopy(node)))
            if BINOP not in scope:  # a namespace not the executor's: a meter of its own
                scope.update(Meter(SkillBudget()).names())
        return eval(compile(expression, "<skill>", "eval"), scope)  # noqa: S307
    except Exception:  # noqa: BLE001 - a value we cannot compute is one we cannot use
        return UNKNOWN
