"""Run grounded skills one control step at a time, segment by segment.

Each top-level statement of a skill's entry function is a *segment*, compiled on its own into a
generator in which every primitive call becomes ``yield from primitive(...)``. LeRobot calls
``select_action`` once per step; the executor advances the current segment by one action. A
segment that has not started yet can still be swapped (in-situ patching) without touching the
ones that ran. Only code that passed the security gate is ever compiled here; a wrong name or
keyword in it fails when it is reached, with Python's own error, categorised in the paper's
taxonomy (:func:`runtime_category`). Every segment runs instrumented under the skill's
:class:`~lerobot_policy_recent.recent_plugin.sandbox.SkillBudget`: code that runs too long
without an action, or builds too much, is stopped as ``budget_exceeded``, whoever wrote it.
"""

from __future__ import annotations

import ast
import builtins
import copy
import functools
import textwrap
from collections import Counter
from collections.abc import Callable, Generator
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from lerobot_policy_recent.descriptions.apis import api_spec_path, available_apis
from lerobot_policy_recent.logs.events import Emit, SegmentEnded, SegmentFailed, SegmentStarted, ignore
from lerobot_policy_recent.ontology.diagnosis import Warning
from lerobot_policy_recent.ontology.skill_code import entry_function, segment_statements
from lerobot_policy_recent.ontology.specs import load_api_spec
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.failures import PRIMITIVE_FAILURE_CATEGORY, REFUSED, FailureCategory
from lerobot_policy_recent.recent_plugin.grounding.gate import SAFE_HELPERS
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill
from lerobot_policy_recent.recent_plugin.sandbox import BudgetExceeded, Meter, SkillBudget, instrument
from lerobot_policy_recent.robosuite_envs.calibration import Calibration, Nominal
from lerobot_policy_recent.robosuite_envs.observation import Observation
from lerobot_policy_recent.robosuite_envs.primitives import PrimitiveFailure, RobotSession, TaskContext
from lerobot_policy_recent.robosuite_envs.primitives.binding import bind_primitives
from lerobot_policy_recent.robosuite_envs.primitives.control import servo_action
from lerobot_policy_recent.robosuite_envs.primitives.frames import SKILL_HELPERS, frames_for

DEFAULT_BUDGET = SkillBudget()
_SAFE_BUILTINS = {name: SKILL_HELPERS.get(name) or getattr(builtins, name) for name in SAFE_HELPERS}


@dataclass
class Segment:
    index: int
    line: int
    source: str
    node: ast.stmt
    guards: tuple[Warning, ...] = ()  # run-time checks evaluated before the segment starts
    effects: tuple[Warning, ...] = ()  # run-time checks of what it did, evaluated once it completes
    checked: bool = False  # guards evaluated (or the segment is itself a patch)


class Adapter(Protocol):
    """In-situ adaptation as the executor sees it (implemented in :mod:`lerobot_policy_recent.recent_plugin.insitu`)."""

    def guard(self, grounded: GroundedSkill, segments: list[Segment]) -> None: ...

    def before_segment(self, executor: SkillExecutor, index: int) -> None: ...

    def after_segment(self, executor: SkillExecutor, index: int) -> None: ...

    def after_skill(self, executor: SkillExecutor) -> str | None:
        """Once the last statement has run: may append statements to run; a text names an unmet effect."""
        ...

    def achieved(self, executor: SkillExecutor, failure: SkillFailure) -> bool:
        """A step failed: whether what the skill is for already holds (it then ends, done)."""
        ...

    def repair(self, executor: SkillExecutor, failure: SkillFailure) -> bool: ...


@dataclass
class RepairBudget:
    """At most ``per_skill`` repairs of each skill (None: no count, where the task's LM budget ends
    the loop instead), and only of the segment that just failed."""

    per_skill: int | None
    used: Counter = field(default_factory=Counter)

    def take(self, executor: SkillExecutor, failure: SkillFailure) -> bool:
        spent = self.per_skill is not None and self.used[failure.skill] >= self.per_skill
        if spent or failure.segment < executor.cursor:
            return False
        self.used[failure.skill] += 1
        return True


@dataclass
class SkillFailure:
    skill: str
    segment: int
    line: int
    category: FailureCategory
    message: str


class _YieldFromPrimitives(ast.NodeTransformer):
    def __init__(self, primitives: set[str]):
        self.primitives = primitives

    def visit_Call(self, node: ast.Call) -> ast.AST:
        self.generic_visit(node)
        if isinstance(node.func, ast.Name) and node.func.id in self.primitives:
            return ast.copy_location(ast.YieldFrom(value=node), node)
        return node


def split_segments(code: str, entry: str | ast.FunctionDef) -> list[Segment]:
    """The entry function's statements as segments, in order (:func:`~lerobot_policy_recent.ontology.skill_code.segment_statements`).

    A loop over a literal list is unrolled: each iteration's statements are segments of their own,
    so the checks that guard a call inside the loop run before every iteration's call, on what the
    world looks like then, and a patch touches one iteration only.
    """
    func = entry if isinstance(entry, ast.FunctionDef) else entry_function(code, entry)
    return [Segment(i, stmt.lineno, source, stmt) for i, (stmt, source) in enumerate(segment_statements(code, func))]


class SkillExecutor:
    """One grounded skill bound to a robot session: ``step()`` returns the next action or ``None``."""

    def __init__(
        self,
        grounded: GroundedSkill,
        args: dict[str, object],
        primitives: dict[str, Callable[..., Generator]],
        session: RobotSession,
        *,
        max_steps: int = 3000,
        budget: SkillBudget = DEFAULT_BUDGET,
        adapter: Adapter | None = None,
        emit: Emit = ignore,
    ):
        if not grounded.valid:
            raise ValueError(
                f"refusing to execute {grounded.skill} for {grounded.robot}: it did not pass validation ({grounded.verdict})"
            )
        self.grounded = grounded
        self.session = session
        self.primitives = primitives
        func = entry_function(grounded.code, grounded.entry)
        self.segments = split_segments(grounded.code, func)
        self.indent = " " * func.body[-1].col_offset
        lines = grounded.code.splitlines(keepends=True)
        self._head = "".join(lines[: self.segments[0].line - 1]) if self.segments else ""
        self._tail = "".join(lines[func.end_lineno :])  # functions defined after the entry
        self.adapter = adapter
        if adapter is not None:
            adapter.guard(grounded, self.segments)
        self.max_steps = max_steps
        self.meter = Meter(budget)
        self.namespace: dict[str, object] = {
            "__builtins__": self.meter.builtins(_SAFE_BUILTINS),
            **self.meter.names(),
            **primitives,
            "env": session,
            "task": TaskContext(session),
        }
        self.namespace.update(self._defaults(func))
        self.namespace.update(args)
        self.cursor = 0  # index of the segment running (or next to run)
        self._running: Generator | None = None
        self.steps = 0
        self.failure: SkillFailure | None = None
        self.emit = emit
        self._segment_start = 0  # self.steps when the running segment started
        self._ended = False  # the adapter found what the skill left as it should be
        self.segment_obs = session.obs  # what the robot sensed when the running segment started

    @staticmethod
    def _defaults(func: ast.FunctionDef) -> dict[str, object]:
        names = [a.arg for a in func.args.args][-len(func.args.defaults) :] if func.args.defaults else []
        return {name: ast.literal_eval(default) for name, default in zip(names, func.args.defaults, strict=True)}

    @property
    def failed(self) -> bool:
        return self.failure is not None

    def replace_segment(self, index: int, source: str) -> None:
        """Swap a segment that has not started for one or more statements (never rewrites the past)."""
        self._splice(index, index + 1, source)

    def replace_rest(self, index: int, source: str) -> None:
        """Swap segment ``index`` and every segment after it for ``source``: a regenerated program
        goes on from where the old one failed, and nothing of the old one runs after it."""
        self._splice(index, len(self.segments), source)

    def insert_segments(self, index: int, source: str) -> None:
        """Put new statements before segment ``index`` (or after the last one); nothing that ran is touched."""
        self._splice(index, index, source)

    def _splice(self, start: int, end: int, source: str) -> None:
        """Put the statements of ``source`` (later lines at the body's indentation) in place of segments[start:end]."""
        if start < self.cursor or (start == self.cursor and self._running is not None):
            raise ValueError(f"segment {start} has already started; only upcoming segments can be patched")
        anchor = self.segments[min(start, len(self.segments) - 1)]  # where tracebacks and logs place them
        text = textwrap.dedent(self.indent + source)
        new = [
            Segment(0, anchor.line, self._reindent(ast.get_source_segment(text, node)), node, checked=True)
            for node in ast.parse(text).body
        ]
        for segment in new:
            ast.copy_location(segment.node, anchor.node)
        self.segments[start:end] = new
        for i, segment in enumerate(self.segments):
            segment.index = i

    def source(self) -> str:
        """The skill as it stands now: patched segments in place of the ones they replaced."""
        return self._head + "".join(self.indent + s.source + "\n" for s in self.segments) + self._tail

    def _reindent(self, statement: str) -> str:
        """A statement as segments keep it: first line bare, later lines at the function body's indent."""
        return statement.replace("\n", "\n" + self.indent)

    def segment_offsets(self, index: int) -> tuple[int, int]:
        """Character range of segment ``index`` in :meth:`source`."""
        start = len(self._head) + sum(len(self.indent) + len(s.source) + 1 for s in self.segments[:index])
        start += len(self.indent)
        return start, start + len(self.segments[index].source)

    def _compile(self, segment: Segment) -> Generator:
        template = ast.parse("def _recent_segment():\n    if False:\n        yield\n")
        fn = template.body[0]
        stmt = instrument(_YieldFromPrimitives(set(self.primitives)).visit(copy.deepcopy(segment.node)))
        assigned = sorted({n.id for n in ast.walk(stmt) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)})
        fn.body = ([ast.Global(names=assigned)] if assigned else []) + [stmt] + fn.body
        ast.fix_missing_locations(template)
        scope: dict[str, object] = {}
        exec(compile(template, f"<{self.grounded.skill}:{self.grounded.robot}>", "exec"), self.namespace, scope)
        return scope["_recent_segment"]()

    def step(self) -> np.ndarray | None:
        """Advance by one action; segments without primitive calls complete within the same step."""
        self.meter.new_step()
        while self.failure is None and (self.cursor < len(self.segments) or self._reopened()):
            if self.steps >= self.max_steps:
                self._fail(FailureCategory.TIMEOUT, f"skill exceeded {self.max_steps} control steps", repairable=False)
                return None
            try:
                if self._running is None:
                    segment = self.segments[self.cursor]
                    if self.adapter is not None and not segment.checked:
                        segment.checked = True
                        self.adapter.before_segment(self, self.cursor)
                        if self.failure is not None:  # refused by a check: nothing of it runs
                            return None
                    self._running = self._compile(self.segments[self.cursor])
                    self._segment_start, self.segment_obs = self.steps, self.session.obs
                    self.emit(SegmentStarted(self.grounded.skill, self.cursor, self.segments[self.cursor].source))
                self.meter.enter()
                try:
                    action = next(self._running)
                finally:
                    self.meter.leave()
                self.steps += 1
                return action
            except StopIteration:
                self._running = None
                self.emit(SegmentEnded(self.grounded.skill, self.cursor, self.steps - self._segment_start))
                if self.adapter is not None and self.segments[self.cursor].effects:
                    self.adapter.after_segment(self, self.cursor)  # may insert statements right after it
                self.cursor += 1
            except PrimitiveFailure as exc:
                self._fail(PRIMITIVE_FAILURE_CATEGORY[exc.kind], str(exc))
            except BudgetExceeded as exc:
                self._fail(exc.category, str(exc))
            except MemoryError:
                self._fail(FailureCategory.BUDGET_EXCEEDED, "MemoryError: the skill ran out of memory")
            except Exception as exc:  # noqa: BLE001 - any error in skill code fails the skill, not the episode
                self._fail(runtime_category(exc), f"{type(exc).__name__}: {exc}")
        return None

    def _reopened(self) -> bool:
        """At the end: the adapter checks what the skill left, and may append statements to run again."""
        if self.adapter is None or self._ended:
            return False
        unmet = self.adapter.after_skill(self)
        if unmet is not None:
            self._fail(FailureCategory.EFFECT_UNMET, unmet, repairable=False)
            return False
        self._ended = self.cursor >= len(self.segments)
        return not self._ended

    def refuse(self, why: str) -> None:
        """End the skill before its current segment runs: a check found it cannot succeed (no repair)."""
        self._fail(FailureCategory.UNREACHABLE_OBJECT, REFUSED + why, repairable=False)

    def _fail(self, category: FailureCategory, message: str, *, repairable: bool = True) -> None:
        segment = self.segments[min(self.cursor, len(self.segments) - 1)]
        failure = SkillFailure(self.grounded.skill, segment.index, segment.line, category, message)
        self._running = None
        self.emit(SegmentFailed(failure.skill, failure.segment, failure.line, str(category), message))
        if repairable and self.adapter is not None and self.adapter.achieved(self, failure):
            self.cursor = len(self.segments)  # the rest of the skill is moot; its effects are checked as ever
            return
        if repairable and self.adapter is not None and self.adapter.repair(self, failure):
            self.meter.created = 0  # the repair starts afresh: at most max_repairs + 1 budgets per skill
            return  # the failed segment was replaced by a repair; it runs again from the current state
        self.failure = failure


def runtime_category(error: Exception) -> FailureCategory:
    """The paper's category of an error raised by safe skill code: NameError is a hallucinated name,
    or a hallucinated API where the name is a primitive of some robot; AttributeError (a task query
    that does not exist) a hallucinated API; TypeError (a wrong or missing keyword) a hallucinated kwarg."""
    if isinstance(error, NameError) and not isinstance(error, UnboundLocalError):
        return (
            FailureCategory.HALLUCINATED_API if error.name in known_primitives() else FailureCategory.HALLUCINATED_NAME
        )
    if isinstance(error, AttributeError):
        return FailureCategory.HALLUCINATED_API
    if isinstance(error, TypeError):
        return FailureCategory.HALLUCINATED_KWARG
    return FailureCategory.NON_EXECUTABLE


@functools.cache
def known_primitives() -> frozenset[str]:
    """Every bundled robot's primitive names (a NameError on one is a call of an API this robot lacks)."""
    return frozenset(name for api in available_apis() for name in load_api_spec(api_spec_path(api)).names())


@dataclass
class PlannedSkill:
    grounded: GroundedSkill
    args: dict[str, object] = field(default_factory=dict)


class TaskExecutor:
    """Runs the skills of a task plan in order for one robot; holds still once finished or failed."""

    def __init__(
        self,
        plan: list[PlannedSkill],
        target: Target,
        first_obs: Observation,
        *,
        max_steps: int = 3000,
        budget: SkillBudget = DEFAULT_BUDGET,
        adapter: Adapter | None = None,
        emit: Emit = ignore,
        calibration: Calibration | None = None,
    ):
        """``calibration``: the embodiment's, for the controllers (None: nominal values, for made-up observations)."""
        calibration = calibration or Nominal()
        self.session = RobotSession(target.name, first_obs, calibration)
        self.session.frames = frames_for(target.api.frames, calibration.base_xyz)
        self.emit = emit
        self.adapter = adapter
        self.plan = plan
        self.primitives: dict[str, Callable[..., Generator]] = bind_primitives(target)  # type: ignore[assignment]
        self.max_steps = max_steps
        self.budget = budget
        self.index = 0
        self.current: SkillExecutor | None = None
        self.failures: list[SkillFailure] = []
        self._hold: np.ndarray | None = None

    @property
    def finished(self) -> bool:
        return self.index >= len(self.plan) or bool(self.failures)

    def act(self, obs: Observation) -> np.ndarray:
        self.session.update(obs)
        while not self.finished:
            if self.current is None:
                planned = self.plan[self.index]
                self.current = SkillExecutor(
                    planned.grounded,
                    planned.args,
                    self.primitives,
                    self.session,
                    max_steps=self.max_steps,
                    budget=self.budget,
                    adapter=self.adapter,
                    emit=self.emit,
                )
            action = self.current.step()
            if action is not None:
                self._hold = None
                return action
            if self.current.failed:
                self.failures.append(self.current.failure)
            else:
                self.index += 1
            self.current = None
        if self._hold is None:
            self._hold = np.array(self.session.obs.eef_pos)
        return servo_action(self.session, self._hold)
