"""Task specifications: objects in the scene, the instruction, and the plan of skills.

A task is pure data so the policy (in another process than the env) can decode observations
and pick skills from the task id alone. The suites' tasks live in :mod:`lerobot_policy_recent.robosuite_envs.suites`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import NamedTuple

from lerobot_policy_recent.robosuite_envs.objects import get_kind


@dataclass(frozen=True)
class ObjectSpec:
    name: str
    kind: str  # a key of robosuite_envs.objects.KINDS
    xy: tuple[float, float]  # nominal position on the table, metres from the table centre
    size: tuple[float, float, float] | None = None  # full extents; None = the kind's own (MJCF) size
    xy_jitter: float = 0.0  # uniform +/- jitter per axis, drawn from the episode seed
    rgba: tuple[float, float, float, float] = (0.8, 0.2, 0.2, 1.0)
    state: float = 0.0  # initial articulation (drawer opening m, lid angle rad)
    surface: str = "smooth"  # "porous": a suction cup cannot seal on it
    mass_kg: float | None = None  # None: as its kind's density makes it

    def __post_init__(self) -> None:
        kind = get_kind(self.kind)  # unknown kinds fail here, listing the valid ones
        if self.size is None:
            if kind.size is None:
                raise ValueError(f"object {self.name!r} of kind {self.kind!r} needs a size")
            object.__setattr__(self, "size", kind.size)
        if self.surface not in ("smooth", "porous"):
            raise ValueError(f"object {self.name!r}: surface must be 'smooth' or 'porous', got {self.surface!r}")


@dataclass(frozen=True)
class PlanStep:
    subtask: str
    skill: str
    args: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class TaskSpec:
    task_id: str
    instruction: str
    objects: tuple[ObjectSpec, ...]
    plan: tuple[PlanStep, ...]
    max_steps: int = 400
    suite: str = ""
    # LM calls the task's budget allows per primitive call of its reference skills (0: the flat budget
    # alone); a long task then affords one call per span and as many retries
    lm_calls_per_primitive: int = 0

    def object_names(self) -> list[str]:
        return [o.name for o in self.objects]

    def spec(self, name: str) -> ObjectSpec:
        for obj in self.objects:
            if obj.name == name:
                return obj
        raise KeyError(f"task {self.task_id!r} has no object {name!r}; objects: {', '.join(self.object_names())}")

    def subtasks(self) -> list[str]:
        return [step.subtask for step in self.plan]


# The task id, robot and episode seed travel to the policy inside LeRobot's `task` string (the one
# channel from a vectorised env to the policy); the logs keep the plain instruction.
_TAG_RE = re.compile(
    r"\[recent task=(?P<task>\S+) robot=(?P<robot>\S+)(?: seed=(?P<seed>-?\d+))?(?: ep=(?P<ep>\d+))?(?: end=(?P<end>\d+))?\]"
)


class TaskTag(NamedTuple):
    task_id: str
    robot: str
    seed: int | None  # the env's episode seed (None before its first seeded reset)
    # the env's episode ended after this many steps (terminated or truncated): in a vectorised
    # lerobot-eval the env is auto-reset at its next step, and what follows is not this episode
    ended_at: int | None = None
    # the env's count of its resets: a new count is a new episode, also one auto-reset within the same
    # step as the last one's end (LeRobot's SAME_STEP autoreset), which LeRobot does not count either
    episode: int | None = None


def task_string(
    task: TaskSpec, robot: str, seed: int | None = None, ended_at: int | None = None, episode: int | None = None
) -> str:
    tail = (
        (f" seed={seed}" if seed is not None else "")
        + (f" ep={episode}" if episode is not None else "")
        + (f" end={ended_at}" if ended_at is not None else "")
    )
    return f"{task.instruction} [recent task={task.task_id} robot={robot}{tail}]"


def parse_task_string(text: str) -> TaskTag:
    """The ``(task_id, robot, seed)`` a task string built by :func:`task_string` carries."""
    match = _TAG_RE.search(text)
    if match is None:
        raise ValueError(f"task string {text!r} carries no '[recent task=... robot=...]' tag; is the env 'recent'?")
    seed = match.group("seed")
    end, episode = match.group("end"), match.group("ep")
    return TaskTag(
        match.group("task"),
        match.group("robot"),
        int(seed) if seed is not None else None,
        int(end) if end is not None else None,
        int(episode) if episode is not None else None,
    )
