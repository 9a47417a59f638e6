"""Prompt windows: how much of the enclosing function a localized span's FIM prompt shows.

``function`` shows all of it. On a CPU every prompt token costs prefill time, and the statements
after a span are re-evaluated by every call (the KV cache only keeps a shared *start*), so
``dataflow`` shows what the edit depends on and nothing else:

* before the span: the signature and docstring, the headers of the blocks the span sits in, and
  the statements that define, directly or through others, a name the span, its hints' calls or
  those headers read; of the function's own statements only the latest definition of a name (an
  unrolled loop's earlier items, or a value a patch read again, no longer reach the span). Before
  an insertion (a run-time patch): what its own statements read, and the latest definition of what
  they assign again (a re-read copies it), not what the statement after it reads. A sweep's
  literals read nothing, so it shows none of the body;
* after it: the statements that read a name the span assigns, up to the first that assigns it
  again. Not simply the next statement: with the next, already grounded call in view, a small
  model copies it into the span. An insertion (a run-time patch) shows only the statement it comes
  before, what it serves: the readers further on cost prompt tokens and did not change what was
  written (docs/history.md, "Prompt cost" and "Run-time patches").

Whatever cannot be parsed keeps the whole function.
"""

from __future__ import annotations

import ast
import textwrap
from dataclasses import dataclass

from lerobot_policy_recent.ontology import skill_code

WINDOWS = ("function", "dataflow")
SUFFIX_STATEMENTS = 3  # at most: the first readers of what the span assigns


@dataclass(frozen=True)
class _Statement:
    first: int  # 0-based line range in the function's text, inclusive
    last: int
    loads: frozenset[str]
    stores: frozenset[str]
    block_last: int = -1  # a compound statement's header: the last line of its whole block
    # What a statement of the function's own body assigns on every path (``skill_code.always_assigned``):
    # earlier definitions of those names no longer reach what follows. Empty inside a block, which may not run.
    assigned: frozenset[str] = frozenset()


def _names(node: ast.AST) -> tuple[set[str], set[str]]:
    return skill_code.loads(node), skill_code.stores(node)


def _code_names(*texts: str | None) -> tuple[set[str], set[str]]:
    """Names read and written by code fragments (a span, a hint's call); unparsable ones add nothing."""
    loads, stores = set(), set()
    for text in texts:
        if not text or not text.strip():
            continue
        try:
            tree = ast.parse(textwrap.dedent(text))
        except SyntaxError:
            continue
        more_loads, more_stores = _names(tree)
        loads |= more_loads
        stores |= more_stores
    return loads, stores


def _walk(body: list[ast.stmt], headers: list[_Statement], leaves: list[_Statement], top: bool = True) -> None:
    """Leaf statements, and the header lines of the compound statements around them (``top``: ``body``
    is the function's own)."""
    for stmt in body:
        blocks = [b for b in (getattr(stmt, f, None) for f in ("body", "orelse", "finalbody")) if b]
        blocks += [h.body for h in getattr(stmt, "handlers", [])]
        if blocks and not isinstance(stmt, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            first_inner = min(b[0].lineno for b in blocks) - 1
            loads, stores = set(), set()
            for field in ("target", "iter", "test", "items"):
                part = getattr(stmt, field, None)
                for node in part if isinstance(part, list) else [part] if part is not None else []:
                    more_loads, more_stores = _names(node)
                    loads |= more_loads
                    stores |= more_stores
            headers.append(
                _Statement(stmt.lineno - 1, first_inner - 1, frozenset(loads), frozenset(stores), stmt.end_lineno - 1)
            )
            for block in blocks:
                _walk(block, headers, leaves, top=False)
        else:
            loads, stores = _names(stmt)
            assigned = frozenset(skill_code.always_assigned([stmt])) if top else frozenset()
            leaves.append(
                _Statement(stmt.lineno - 1, stmt.end_lineno - 1, frozenset(loads), frozenset(stores), assigned=assigned)
            )


def dataflow_window(
    prefix: str, indent: str, span: str, suffix: str, hint_code: tuple[str | None, ...] = ()
) -> tuple[str, str]:
    """The ``(prefix, suffix)`` of the ``dataflow`` window, cut from the unit's whole-function ones."""
    text = prefix + indent + span + suffix
    try:
        func = ast.parse(text).body[0]
    except (SyntaxError, IndexError):
        return prefix, suffix
    if not isinstance(func, ast.FunctionDef) or not func.body:
        return prefix, suffix
    lines = text.splitlines(keepends=True)
    first, last = prefix.count("\n"), prefix.count("\n") + span.count("\n")
    headers: list[_Statement] = []
    leaves: list[_Statement] = []
    _walk(func.body, headers, leaves)
    body_start = func.body[0].lineno - 1
    docstring = (
        func.body[0] if isinstance(func.body[0], ast.Expr) and isinstance(func.body[0].value, ast.Constant) else None
    )
    keep = set(range(func.lineno - 1, body_start))  # the signature (decorators aside)
    if docstring is not None:
        keep |= set(range(docstring.lineno - 1, docstring.end_lineno))

    loads, stores = _code_names(span, *hint_code)
    if not span:  # an insertion: the earlier definitions of what it assigns again (a re-read copies them)
        loads |= stores
    around = [h for h in headers if h.last < first <= h.block_last]  # the blocks the span sits in
    for header in around:
        keep |= set(range(header.first, header.last + 1))
        loads |= header.loads
    needed = set(loads)
    for stmt in sorted((s for s in [*leaves, *headers] if s.last < first), key=lambda s: -s.first):
        if stmt.stores & needed:
            keep |= set(range(stmt.first, stmt.last + 1))
            # the latest definition: earlier ones of what it always assigns no longer reach the span
            needed = (needed - stmt.assigned) | stmt.loads
    window_prefix = "".join(lines[i] for i in sorted(keep) if i < first)

    rest_of_line, _, _ = suffix.partition("\n")
    after = [s for s in leaves if s.first > last]
    if not span:  # an insertion (a run-time patch): the statement it comes before, alone
        chosen = after[:1]
    else:
        chosen = []
        for stmt in after:
            if stmt.loads & stores:
                chosen.append(stmt)
            if stmt.stores & stores:
                break  # from here on those names hold other values (an unrolled loop's next item)
    window_suffix = (
        rest_of_line + "\n" + "".join("".join(lines[s.first : s.last + 1]) for s in chosen[:SUFFIX_STATEMENTS])
    )
    return window_prefix, window_suffix
