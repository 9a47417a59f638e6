"""Typed events: what the agent did, as plain records the sinks can serialise without knowing the agent.

The agent (grounding, executor, in-situ adapter) creates these and hands them to an ``emit``
callable; the :class:`~lerobot_policy_recent.logs.recorder.Recorder` stamps them with the episode, the control step and
the wall clock and fans them out. Every field is a str, number, bool or a list/dict of those, so
each event is one JSON object (MCAP), one text log line (Rerun) and one parquet row (dataset).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields
from typing import ClassVar

import numpy as np


@dataclass(frozen=True)
class Event:
    """Base of every grounding/execution event; ``name`` is the stable schema name in every log."""

    name: ClassVar[str] = "event"
    level: ClassVar[str] = "info"  # debug | info | warning | error (Foxglove Log and Rerun TextLog levels)

    def payload(self) -> dict:
        return asdict(self)

    def summary(self) -> str:
        """One line for text logs."""
        return self.name


@dataclass(frozen=True)
class EpisodeStarted(Event):
    name: ClassVar[str] = "episode_started"
    task_id: str
    robot: str
    seed: int
    task: str = ""
    backend: str = ""
    model: str = ""
    method: str = ""  # the registered method (RECENT, an ablation or a baseline), as it labels itself
    variations: str = ""
    object_names: list[str] = field(default_factory=list)

    def summary(self) -> str:
        return f"episode: {self.task_id} on {self.robot} (seed {self.seed}, {self.backend}/{self.model}, {self.method})"


@dataclass(frozen=True)
class SkillDiagnosed(Event):
    name: ClassVar[str] = "skill_diagnosed"
    skill: str
    robot: str
    conflicts: list[str]  # "line N: span_type original -> substitute"
    warnings: list[str]  # "line N: check (phase)"
    cached: bool = False

    def summary(self) -> str:
        cached = ", cached" if self.cached else ""
        return f"D({self.skill}, {self.robot}): {len(self.conflicts)} conflicts, {len(self.warnings)} warnings{cached}"


@dataclass(frozen=True)
class InfillCall(Event):
    """One refactoring unit sent to the infiller: the span, its hints, the FIM prompt and the completion."""

    name: ClassVar[str] = "infill_call"
    skill: str
    kind: str  # ground | revise | repair
    span_type: str
    span: str
    hints: list[str]
    prompt: str  # prefix + <FILL> + suffix, with the hint comments as the model saw them
    completion: str
    generated_tokens: int
    seconds: float
    rendered: bool = False  # the fast path wrote the span; no model was called
    forced: bool = False  # the grammar admitted only this text; it was not decoded
    prompt_tokens: int = 0  # where the backend counts them
    evaluated_prompt_tokens: int = 0  # of those, the ones not already in the model's cache
    prompt_seconds: float = 0.0  # of ``seconds``: prompt evaluation (where the backend measures it)
    generation_seconds: float = 0.0  # of ``seconds``: generation

    def summary(self) -> str:
        cost = "rendered, no LM" if self.rendered else f"{self.generated_tokens} tok, {self.seconds:.2f} s"
        cost += ", held by the grammar, not decoded" if self.forced else ""
        return f"{self.kind} {self.skill} [{self.span_type}] -> {self.completion!r} ({cost})"


@dataclass(frozen=True)
class ValidationVerdict(Event):
    name: ClassVar[str] = "validation_verdict"
    skill: str
    kind: str  # the call's kind (ground | revise | repair), or "skill" for a whole skill's final verdict
    accepted: bool
    category: str = ""  # the failure taxonomy's category when rejected
    message: str = ""

    @property
    def level(self) -> str:  # type: ignore[override]
        return "info" if self.accepted else "warning"

    def summary(self) -> str:
        return f"{self.skill}: {'accepted' if self.accepted else f'rejected ({self.category}) {self.message}'}"


@dataclass(frozen=True)
class PatchApplied(Event):
    name: ClassVar[str] = "patch_applied"
    skill: str
    kind: str  # ground (before execution) | revise (in situ) | repair
    diff: str  # unified diff against the code before the patch
    code: str  # the whole skill after the patch

    def summary(self) -> str:
        changed = sum(1 for line in self.diff.splitlines() if line.startswith("+") and not line.startswith("+++"))
        return f"{self.kind} patch on {self.skill}: {changed} line(s) added"


@dataclass(frozen=True)
class CheckVerdict(Event):
    """A run-time unit test instantiated from a warning, evaluated before its segment."""

    name: ClassVar[str] = "check_verdict"
    skill: str
    segment: int
    check: str
    passed: bool
    observation: str = ""

    @property
    def level(self) -> str:  # type: ignore[override]
        return "info" if self.passed else "warning"

    def summary(self) -> str:
        return f"check {self.check} before segment {self.segment} of {self.skill}: " + (
            "passed" if self.passed else f"violated ({self.observation})"
        )


@dataclass(frozen=True)
class SegmentStarted(Event):
    name: ClassVar[str] = "segment_started"
    level: ClassVar[str] = "debug"
    skill: str
    segment: int
    source: str

    def summary(self) -> str:
        return f"{self.skill}[{self.segment}] start: {self.source.splitlines()[0]}"


@dataclass(frozen=True)
class SegmentEnded(Event):
    name: ClassVar[str] = "segment_ended"
    level: ClassVar[str] = "debug"
    skill: str
    segment: int
    steps: int  # control steps the segment took

    def summary(self) -> str:
        return f"{self.skill}[{self.segment}] done in {self.steps} steps"


@dataclass(frozen=True)
class SegmentFailed(Event):
    name: ClassVar[str] = "segment_failed"
    level: ClassVar[str] = "error"
    skill: str
    segment: int
    line: int
    category: str
    message: str

    def summary(self) -> str:
        return f"{self.skill}[{self.segment}] line {self.line} failed ({self.category}): {self.message}"


@dataclass(frozen=True)
class SubtaskSucceeded(Event):
    name: ClassVar[str] = "subtask_succeeded"
    index: int
    done: int  # subtasks achieved so far
    total: int

    def summary(self) -> str:
        return f"subtask {self.index} achieved ({self.done}/{self.total})"


@dataclass(frozen=True)
class HeldChanged(Event):
    """The simulator's ground truth of what the gripper holds changed (for replay and failure analysis:
    the policy never sees it, and infers a grasp from its sensors)."""

    name: ClassVar[str] = "held_changed"
    held: list[str]  # empty: nothing held

    def summary(self) -> str:
        return f"ground truth: holding {', '.join(self.held)}" if self.held else "ground truth: nothing held"


@dataclass(frozen=True)
class EpisodeEnded(Event):
    """The per-task result row: SR/GC and the grounding accounting (GO, EI, IT, IGT)."""

    name: ClassVar[str] = "episode_ended"
    task_id: str
    robot: str
    seed: int
    success: bool | None  # None where the logger cannot see the env's verdict (inside lerobot-eval)
    gc: float | None
    steps: int
    wall_seconds: float
    generated_tokens: int
    skill_tokens: int
    go: float  # repair + revise tokens ÷ skill tokens × 100 (the paper's GO)
    go_pre: float  # tokens generated before execution ÷ skill tokens × 100
    ei: int
    it: float
    igt: float
    failure_category: str = ""  # the first failure's category, when the episode failed
    failure_message: str = ""
    env_steps: int | None = None  # the env's own count of the episode's steps, where it reported one

    @property
    def level(self) -> str:  # type: ignore[override]
        return "info" if self.success is not False else "error"

    def summary(self) -> str:
        verdict = {True: "success", False: "failure", None: "ended"}[self.success]
        reason = f" ({self.failure_category}: {self.failure_message})" if self.failure_category else ""
        return f"{verdict}{reason}: {self.steps} steps, GO {self.go:.1f}% (before execution {self.go_pre:.1f}%), EI {self.ei}, IT {self.it:.2f} s, IGT {self.igt:.2f} s"


EVENT_TYPES: dict[str, type[Event]] = {
    t.name: t
    for t in (
        EpisodeStarted,
        SkillDiagnosed,
        InfillCall,
        ValidationVerdict,
        PatchApplied,
        CheckVerdict,
        SegmentStarted,
        SegmentEnded,
        SegmentFailed,
        SubtaskSucceeded,
        HeldChanged,
        EpisodeEnded,
    )
}


def json_schema(event_type: type[Event]) -> dict:
    """A JSON schema of an event's payload (MCAP channels carry it; Foxglove shows the fields)."""
    kinds = {"str": "string", "int": "integer", "float": "number", "bool": "boolean"}
    properties = {}
    for f in fields(event_type):
        annotation = str(f.type)
        if annotation.startswith("list"):
            properties[f.name] = {"type": "array"}
        else:
            types = [kinds[t.strip()] for t in annotation.split("|") if t.strip() in kinds]
            nullable = ["null"] if "None" in annotation else []
            properties[f.name] = {"type": types + nullable if nullable or len(types) > 1 else types[0]}
    return {"title": f"recent.{event_type.name}", "type": "object", "properties": properties}


@dataclass(frozen=True)
class Stamped:
    """An event as the sinks receive it: where in which episode, and when."""

    event: Event
    episode_index: int
    frame_index: int  # control step at which it happened (0 = before the first action)
    log_time_ns: int  # wall clock, nanoseconds since the epoch


@dataclass(frozen=True)
class Step:
    """One control step: the observation the policy acted on and the action it returned."""

    episode_index: int
    frame_index: int
    sim_time: float  # seconds of simulated time (frame_index / control frequency)
    log_time_ns: int
    state: np.ndarray  # agent_pos (8)
    environment_state: np.ndarray  # object slots (see robosuite_envs.observation)
    action: np.ndarray  # (7,)
    image: np.ndarray | None = None  # HxWx3 uint8 when a camera is logged
    truth: np.ndarray | None = (
        None  # the objects' exact poses (environment_state's layout), where the simulator is at hand
    )


Emit = Callable[[Event], None]


def ignore(_event: Event) -> None:
    """The default ``emit``: nobody is listening."""
