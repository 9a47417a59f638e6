"""Task specifications: objects in the scene, the instruction, and the plan of skills.

A task is pure data so the policy (in another process than the env) can decode observations
and pick skills from the task id alone.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field


@dataclass(frozen=True)
class ObjectSpec:
    name: str
    kind: str  # "box" (free, graspable) or "bin" (fixed receptacle)
    size: tuple[float, float, float]  # full extents in metres
    xy: tuple[float, float]  # nominal position on the table, metres from the table centre
    xy_jitter: float = 0.0  # uniform +/- jitter per axis, drawn from the episode seed
    rgba: tuple[float, float, float, float] = (0.8, 0.2, 0.2, 1.0)


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

    def object_names(self) -> list[str]:
        return [o.name for o in self.objects]


TASKS: dict[str, TaskSpec] = {
    t.task_id: t
    for t in (
        TaskSpec(
            task_id="cube_in_bin",
            instruction="Pick the cube and place it in the bin.",
            objects=(
                ObjectSpec("cube", "box", (0.045, 0.045, 0.045), (-0.02, -0.12), 0.03, (0.85, 0.15, 0.1, 1.0)),
                ObjectSpec("bin", "bin", (0.20, 0.20, 0.08), (0.02, 0.16), 0.0, (0.35, 0.25, 0.15, 1.0)),
            ),
            plan=(PlanStep("put_in_bin", "put_in_bin", {"obj": "cube", "receptacle": "bin"}),),
        ),
    )
}


def get_task(task_id: str) -> TaskSpec:
    try:
        return TASKS[task_id]
    except KeyError:
        raise KeyError(f"unknown task {task_id!r}; known tasks: {', '.join(TASKS)}") from None


# The task id and robot travel to the policy inside LeRobot's `task` string.
_TAG_RE = re.compile(r"\[recent task=(?P<task>\S+) robot=(?P<robot>\S+)\]")


def task_string(task: TaskSpec, robot: str) -> str:
    return f"{task.instruction} [recent task={task.task_id} robot={robot}]"


def parse_task_string(text: str) -> tuple[str, str]:
    """Return ``(task_id, robot)`` from a task string built by :func:`task_string`."""
    match = _TAG_RE.search(text)
    if match is None:
        raise ValueError(f"task string {text!r} carries no '[recent task=... robot=...]' tag; is the env 'recent'?")
    return match.group("task"), match.group("robot")
