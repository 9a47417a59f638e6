"""Render a refactoring unit as a Fill-in-the-Middle prompt: hints become comments before the span.

The comments carry only what this conflict holds (the span type, mapped/dropped/unfilled
arguments, the substitute), so the LM sees the cues for this one edit and nothing else.
"""

from __future__ import annotations

import ast
import json
import re
from dataclasses import dataclass

from lerobot_policy_recent.ontology.diagnosis import SPAN_TYPES, ParameterMapping
from lerobot_policy_recent.recent_plugin.refactoring.decisions import Exclusion
from lerobot_policy_recent.recent_plugin.refactoring.substitution import PLACEHOLDER, has_placeholders
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit, at_indent, names_in_scope
from lerobot_policy_recent.recent_plugin.refactoring.window import WINDOWS, dataflow_window

# GBNF grammars for RECENT's localized spans: code statements, never comments (a small model
# otherwise sometimes copies a hint line instead of writing the call). Whole programs and a
# baseline's statement rewrites (a unit with a style) get none: a grammar that forbids comments or a
# line starting with a closing bracket cuts ordinary Python short. Backends without grammar
# support ignore them.
# The span may end where the model ends it (end of the FIM middle) or at a line break: a grammar
# that demanded the newline would refuse the model's end token, and the next-best admitted tokens
# ran on (" # <the call again>") to the length cap.
STATEMENT_LINE = r'root ::= [a-zA-Z_] [^\n]* "\n"?'
LINE = r"line ::= [ ]* [a-zA-Z_] [^\n]*"
STATEMENT_LINES = r'root ::= line ("\n" line)* "\n"?' + "\n" + LINE
# Lines of code, any Python a statement may span (a closing bracket's line too), but no line that is
# only a comment: a prompt that ends in comment lines (a baseline's statement rewrite) otherwise
# gets more comments from a small model, and a completion that is only comments is no edit.
CODE_LINES = r'root ::= code ("\n" code)* "\n"?' + "\n" + r"code ::= [ ]* [^# \n] [^\n]*"


def statement_lines(most: int) -> str:
    """:data:`STATEMENT_LINES`, at most ``most`` lines: a run-time patch as long as the statements its
    check or repair wrote. Uncapped, a small model goes on past a repair's recomputation into the rest
    of the skill, to the length cap."""
    return f'root ::= line ("\\n" line){{0,{most - 1}}} "\\n"?' + "\n" + LINE


def patch_grammar(statements: str) -> str | None:
    """GBNF for a run-time patch's first attempt: the statements its check or repair wrote, in order, one
    line each, every line beginning as its statement does (``name, dx, dy = ``, ``sawyer_push(``); the
    rest of each line is the LM's. None where a statement spans lines or is not an assignment or a call.

    A repair recomputes what the failed statement uses and a check's patch calls what it named, so
    validation rejects a patch that does anything else. Given only a line count, a small model often
    writes the retried call, copied from the suffix, instead of the recomputation.
    """
    heads = []
    for line in statements.splitlines():
        try:
            (statement,) = ast.parse(line.strip()).body
        except (SyntaxError, ValueError):
            return None
        source = line.strip().encode()  # ast's columns count UTF-8 bytes
        if isinstance(statement, ast.Assign | ast.AugAssign | ast.AnnAssign) and statement.value is not None:
            heads.append(source[: statement.value.col_offset].decode())
        elif isinstance(statement, ast.Expr) and isinstance(statement.value, ast.Call):
            heads.append(source[: statement.value.func.end_col_offset].decode() + "(")
        else:
            return None
    if not heads:
        return None
    lines = ' "\\n" [ ]* '.join(f"{json.dumps(head, ensure_ascii=False)} rest" for head in heads)
    return f'root ::= {lines} "\\n"?\nrest ::= [^\\n]*'


RUNTIME_SPAN_TYPES = ("in_situ_revision", "reactive_repair")  # spans patched while the skill runs
# The spans a ``dataflow`` window applies to: RECENT's localized edits before and during execution.
# A reactive repair once kept the whole function before the span: shown only the definitions of the
# values it recomputes (an unrolled loop defines them twice), the 1.5B wrote them over and over to
# the length cap (dev: end_effector/stock_drawer, Suction, seed 3). A run-time patch is now at most
# as many lines as its statements (:func:`statement_lines`), and the whole function cost a repair's
# first attempt 380 to 510 cold prompt tokens (dev: plate_clear_switch and tool_panel on UR5e).
WINDOWED_SPAN_TYPES = (*SPAN_TYPES, *RUNTIME_SPAN_TYPES)
FILL = "<FILL>"  # where the span goes, in the prompts the logs record


def decided_by_rule(unit: RefactoringUnit) -> bool:
    """Whether the ontology (or the run-time check that cut the unit) wrote the span's every argument:
    a determined conflict or a run-time patch whose call has no ``<placeholder>`` left, on its first
    attempt. Nothing is left for an LM to decide (the fast path renders it; the report's rule coverage)."""
    call = unit.hints.substitute_call
    return (
        unit.span_type in (*SPAN_TYPES, *RUNTIME_SPAN_TYPES)
        and unit.hints.attempt == 0
        and bool(call)
        and not has_placeholders(call)
    )


def call_grammar(call: str, names: tuple[str, ...] = (), exclusions: tuple[Exclusion, ...] = ()) -> str:
    """GBNF holding an answer to the ontology's call: its text verbatim, each ``<type>`` placeholder free.

    A first attempt at an open decision is held to the call's form: left free, the 1.5B wrote
    `put_xyz = task.get_object_position(middle)`, an assignment, not the call. After a rejection, a
    small model tends to copy the same neighbouring line again; constraining the retry keeps what
    the ontology decided (the substitute, the keywords, the carried-over values) and leaves the LM
    only what it did not. A run-time patch's retry is held the same way to the statements its check
    wrote: left free, the 1.5B named a push primitive the robot lacks on all three attempts of a new
    arm's sweep. An ``<object_name>`` is one of the ``names`` in scope
    (:func:`~lerobot_policy_recent.recent_plugin.refactoring.units.names_in_scope`; left free, the
    1.5B wrote the object's position variable there on every retry), less a keyword's
    ``exclusions``: told in the hint that a place's receptacle is not the object the hand holds, the
    1.5B still wrote the held object at every first answer.
    """
    parts, holes = PLACEHOLDER.split(call), PLACEHOLDER.findall(call)
    barred: dict[tuple[str, str], set[str]] = {}
    for exclusion in exclusions:
        barred.setdefault((exclusion.call, exclusion.argument), set()).update(exclusion.names)
    items, rules, written = [], {}, ""  # the name rules, by the names each allows
    for i, part in enumerate(parts):
        written += part
        if part:
            items.append(json.dumps(part, ensure_ascii=False))
        if i == len(parts) - 1:
            continue
        keyword = re.search(r"(\w+)=$", part)
        barring = barred.get((_open_call(written), keyword.group(1) if keyword else ""), set())
        allowed = tuple(n for n in names if n not in barring)
        if holes[i] != "<object_name>" or not allowed:  # nothing in scope fits: validation says so
            items.append("expr")
            continue
        items.append(rules.setdefault(allowed, "name" if allowed == names else f"name-{len(rules)}"))
    lines = [f'root ::= {" ".join(items)} "\\n"', "expr ::= [^\\n]+"]
    lines += [f"{rule} ::= " + " | ".join(json.dumps(n) for n in allowed) for allowed, rule in rules.items()]
    return "\n".join(lines)


def _open_call(text: str) -> str:
    """The callee whose parentheses ``text`` leaves open last: whose argument comes next."""
    callees: list[str] = []
    for bracket in re.finditer(r"([\w.]*)\(|\)", text):
        if bracket.group(0) == ")":
            if callees:
                callees.pop()
        else:
            callees.append(bracket.group(1))
    return callees[-1] if callees else ""


@dataclass(frozen=True)
class FimPrompt:
    prefix: str
    suffix: str
    stop: tuple[str, ...]  # text stops that end the span (on top of the model's special tokens)
    max_tokens: int
    grammar: str | None  # GBNF the generated span must match (None: unconstrained)
    # The one text ``grammar`` admits, where it admits one (a retry of a call with no placeholder
    # left): a backend that applies the grammar may answer it without decoding, as decoding copies it.
    forced: str | None = None
    # Text the completion is likely to copy (the hint's call, as the span writes it), for lookup drafts.
    draft: str | None = None

    def shown(self) -> str:
        """The prompt as the logs record it: prefix, ``<FILL>`` at the span, suffix (format-independent)."""
        return self.prefix + FILL + self.suffix


def hint_lines(unit: RefactoringUnit) -> list[str]:
    """Comment lines for one edit; the substitute's call comes last, nearest the span.

    A retry narrows the cues to the original call, the rejection and the call to write: a small
    model that copied a hint line instead of writing code gets less to copy the second time.
    A span of another method's (``unit.style``) has the lines that method writes.
    """
    span_type, hints = unit.span_type, unit.hints
    if unit.style is not None:
        return unit.style.comments(hints)
    if span_type in RUNTIME_SPAN_TYPES:  # an insertion: what was observed and the edit in words
        rejected = [f"Rejected before: {hints.feedback}"] if hints.feedback else []
        return [*rejected, f"{hints.observation}: {hints.reason}"]
    if hints.attempt > 0:
        call = [f"Call exactly: {one_line(hints.substitute_call)}"] if hints.substitute_call else []
        return [f"Was: {one_line(hints.original_call)}", f"Rejected before: {hints.feedback}", *call]
    lines = [f"{hints.robot} ({span_type.replace('_', ' ')}): {hints.reason}", f"Was: {one_line(hints.original_call)}"]
    edits = []
    if hints.mapping:
        edits.append("map " + ", ".join(_render_mapping(m) for m in hints.mapping))
    if hints.dropped:
        edits.append("drop " + ", ".join(hints.dropped))
    if hints.unfilled:
        edits.append("also pass " + ", ".join(hints.unfilled))
    if edits:
        lines.append("Arguments: " + "; ".join(edits))
    if hints.substitute_signature:
        lines.append(f"{hints.robot} API: {hints.substitute_signature}")
        lines += hints.facts
        if hints.unfilled:
            lines.append("Replace each <...> with a variable or literal from the code above")
        lines.append(f"Call exactly: {one_line(hints.substitute_call)}")
    return lines


def one_line(code: str | None) -> str:
    """Statements on one comment line, joined by "; then ".

    A call written over several lines becomes one statement: its later lines, put into the
    comment as they were, stood in the prompt as uncommented code, and the 1.5B copied them.
    """
    statements, current, depth = [], [], 0
    for line in (code or "").splitlines():
        if not line.strip():
            continue
        current.append(line.strip())
        depth += sum(line.count(c) for c in "([{") - sum(line.count(c) for c in ")]}")
        if depth <= 0:
            statements.append(_joined(current))
            current, depth = [], 0
    if current:
        statements.append(_joined(current))
    return "; then ".join(statements)


def _joined(lines: list[str]) -> str:
    if len(lines) == 1:
        return lines[0]
    text = re.sub(r"([(\[{]) ", r"\1", " ".join(lines))
    return re.sub(r",? ([)\]}])", r"\1", text)


def _render_mapping(mapping: ParameterMapping) -> str:
    values = ", ".join(f"{a!r} -> {b!r}" for a, b in mapping.values)
    return f"{mapping.source} -> {mapping.target}" + (f" ({values})" if values else "")


def build_prompt(unit: RefactoringUnit, span_tokens: int, window: str = "function") -> FimPrompt:
    """The FIM prompt for ``unit``. ``window`` (:mod:`~lerobot_policy_recent.recent_plugin.refactoring.window`) applies
    to :data:`WINDOWED_SPAN_TYPES`; whole bodies and the baselines' rewrites show the whole function."""
    if window not in WINDOWS:
        raise ValueError(f"unknown prompt window {window!r}; choose one of: {', '.join(WINDOWS)}")
    comments = "".join(f"{unit.indent}# {line}\n" for line in hint_lines(unit))
    call = unit.hints.substitute_call
    if (
        call and unit.style is None and unit.span_type not in RUNTIME_SPAN_TYPES
    ):  # what replaces the span, however the call was written
        single_line = "\n" not in call
    else:
        single_line = "\n" not in unit.span and "\n" not in (call or "")
    grammar = STATEMENT_LINE if single_line else STATEMENT_LINES
    if call and not single_line and unit.style is None:
        # as many lines as the ontology's statements: uncapped, the 1.5B went on past a traced path or
        # a cup's detach into the suffix's next calls (`move_gripper_to(obj_name=obj)`, `place(...)`),
        # and the span was rejected for what it added
        grammar = statement_lines(call.count("\n") + 1)
    if call and unit.span_type in RUNTIME_SPAN_TYPES:
        grammar = patch_grammar(call) or grammar
    elif single_line and unit.style is None and unit.substitute and call and call.startswith(f"{unit.substitute}("):
        # the call the ontology determined, its arguments free: left to begin the line, the 1.5B wrote
        # the right point as `task.move_to_position([...])`, a method of the task, on every traced move
        grammar = f'root ::= {json.dumps(unit.substitute + "(")} [^\\n]* "\\n"?'
    forced = None
    draft = call and at_indent(call, unit.indent)[len(unit.indent) :]  # its later lines at the body's indentation
    if unit.hints.attempt > 0 and call and unit.style is None:
        # a retry held to the call, and its names to those the role allows
        grammar = call_grammar(call, names_in_scope(unit), unit.hints.exclusions)
        forced = None if has_placeholders(call) else call + "\n"
        draft = call  # the grammar holds the retry to the call's own lines
    elif call and unit.style is None and unit.span_type not in RUNTIME_SPAN_TYPES and has_placeholders(call):
        # an open decision: the call's form is the ontology's, what fills its holes the LM's, among
        # the names the argument's role allows (the retry's grammar, from the first answer on)
        grammar = call_grammar(call, names_in_scope(unit), unit.hints.exclusions)
    stop = ("\n", "  #") if single_line else ("\n\n",)
    if unit.style is not None:  # the method's own: Python as the model would write it, or its grammar
        grammar, stop = unit.style.grammar, unit.style.stop or stop
    prefix, suffix = unit.prefix, unit.suffix
    if window == "dataflow" and unit.span_type in WINDOWED_SPAN_TYPES:
        # a run-time patch's original call is the statement it comes before: the window shows it, not what it reads
        code = (call,) if unit.span_type in RUNTIME_SPAN_TYPES else (unit.hints.original_call, call)
        prefix, suffix = dataflow_window(prefix, unit.indent, unit.span, suffix, code)
    return FimPrompt(
        prefix=prefix + comments + unit.indent,
        suffix=suffix,
        stop=stop,
        max_tokens=max(24, 2 * max(span_tokens, approximate_tokens(call or "")) + 16),
        grammar=grammar,
        forced=forced,
        draft=draft or None,
    )


_CODE_TOKEN = re.compile(r"[A-Za-z_]+|\d+|\S")


def approximate_tokens(text: str) -> int:
    """A tokenizer-free count (identifiers, numbers, symbols) for backends without a model."""
    return len(_CODE_TOKEN.findall(text))
