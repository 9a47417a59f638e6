"""One grounded episode outside LeRobot's loop: env → agent → executor → env, with a result record."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from recent_plugin.agent import EpisodeGrounding, RecentAgent
from recent_plugin.executor import SkillFailure
from recent_plugin.grounding.grounder import LMCall
from recent_plugin.insitu.adapter import AdaptationEvent
from robosuite_envs.gym_env import RecentEnv
from robosuite_envs.observation import Observation

SETTLE_STEPS = 20  # after the plan ends, let objects come to rest before judging success


@dataclass
class EpisodeResult:
    task_id: str
    robot: str
    seed: int
    success: bool
    gc: float  # goal-conditioned success: the fraction of the plan's subtasks achieved
    steps: int
    wall_seconds: float
    grounding: EpisodeGrounding
    failures: list[SkillFailure] = field(default_factory=list)
    runtime_calls: list[LMCall] = field(default_factory=list)  # revise (in-situ) and repair calls
    adaptations: list[AdaptationEvent] = field(default_factory=list)

    @property
    def generated_tokens(self) -> int:
        """Every token the infiller generated for this episode: before execution and during it."""
        return sum(s.generated_tokens for s in self.grounding.skills) + sum(
            c.generated_tokens for c in self.runtime_calls
        )

    @property
    def ei(self) -> int:
        """Execution interruptions: revise + repair infiller calls (the paper's EI)."""
        return len(self.runtime_calls)

    @property
    def it(self) -> float:
        """Idle time: seconds spent in those calls while the robot waited (the paper's IT)."""
        return sum(c.seconds for c in self.runtime_calls)

    @property
    def igt(self) -> float:
        """Initial grounding time: from receiving the task to the first executable code."""
        return self.grounding.igt_seconds

    @property
    def skill_tokens(self) -> int:
        return sum(s.skill_tokens for s in self.grounding.skills)

    @property
    def go(self) -> float:
        return 100.0 * self.generated_tokens / max(1, self.skill_tokens)

    @property
    def lm_seconds(self) -> float:
        return sum(s.lm_seconds for s in self.grounding.skills) + self.it


def run_episode(
    agent: RecentAgent,
    task_id: str,
    robot: str,
    *,
    seed: int = 0,
    max_steps: int | None = None,
    progress: bool = False,
    env: RecentEnv | None = None,
    variations: str = "off",
    to_completion: bool = False,
) -> EpisodeResult:
    """Ground the task's skills for ``robot`` and execute them until success or the step limit.

    Without an ``env`` one is built (with ``variations``) and closed again afterwards. With
    ``to_completion`` the skills run to their end even after the task succeeded (validation
    checks the effects a skill leaves behind).
    """
    if env is not None:
        return _run(agent, env, task_id, robot, seed, progress, to_completion)
    env = RecentEnv(task=task_id, robot=robot, render_mode="none", max_episode_steps=max_steps, variations=variations)
    try:
        return _run(agent, env, task_id, robot, seed, progress, to_completion)
    finally:
        env.close()


def _run(
    agent: RecentAgent, env: RecentEnv, task_id: str, robot: str, seed: int, progress: bool, to_completion: bool
) -> EpisodeResult:
    started = time.perf_counter()
    raw, _ = env.reset(seed=seed)
    names = env.spec_task.object_names()
    executor, grounding = agent.start_episode(
        task_id, robot, Observation.decode(raw["agent_pos"], raw["environment_state"], names)
    )
    bar = _bar(env._max_episode_steps, progress, f"{task_id} on {robot}")
    success, steps, settled, info = False, 0, 0, {}
    while True:
        action = executor.act(Observation.decode(raw["agent_pos"], raw["environment_state"], names))
        raw, _, terminated, truncated, info = env.step(action)
        steps += 1
        bar.update(1)
        success = bool(info["is_success"])
        settled = settled + 1 if executor.finished else 0
        if (terminated and not to_completion) or truncated or settled > SETTLE_STEPS:
            break
    bar.close()
    return EpisodeResult(
        task_id=task_id,
        robot=robot,
        seed=seed,
        success=success,
        gc=float(info.get("gc", 0.0)),
        steps=steps,
        wall_seconds=time.perf_counter() - started,
        grounding=grounding,
        failures=list(executor.failures),
        runtime_calls=list(executor.adapter.calls) if executor.adapter else [],
        adaptations=list(executor.adapter.events) if executor.adapter else [],
    )


def _bar(total: int, enabled: bool, desc: str):
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="step", disable=not enabled, leave=False)
