"""One grounded episode outside LeRobot's loop: env → agent → executor → env, with a result record."""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field, fields

from lerobot_policy_recent.logs.events import EpisodeEnded, HeldChanged, SubtaskSucceeded, ignore
from lerobot_policy_recent.logs.recorder import Recorder
from lerobot_policy_recent.recent_plugin.agent import EpisodeGrounding, RecentAgent
from lerobot_policy_recent.recent_plugin.executor import SkillFailure, TaskExecutor
from lerobot_policy_recent.recent_plugin.failures import FailureCategory
from lerobot_policy_recent.recent_plugin.grounding.attempts import AdaptationEvent, LMCall
from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
from lerobot_policy_recent.robosuite_envs.observation import Observation
from lerobot_policy_recent.robosuite_envs.tasks import PlanStep

CAMERA_SIZE = 84  # the logged front view, pixels per side
SETTLE_STEPS = 20  # after the plan ends, let objects come to rest before judging success
INTERRUPTING_CALLS = ("repair", "revise")  # the LM calls the paper's EI counts, IT times and GO's numerator sums


@dataclass
class EpisodeResult:
    task_id: str
    robot: str
    seed: int
    success: bool | None  # None where the env's verdict is not visible (the policy inside lerobot-eval)
    gc: float | None  # goal-conditioned success: the fraction of the plan's subtasks achieved
    steps: int
    wall_seconds: float
    grounding: EpisodeGrounding
    failures: list[SkillFailure] = field(default_factory=list)
    finished: bool = True  # the plan ran to its end (or failed) before the step limit
    runtime_calls: list[LMCall] = field(default_factory=list)  # revise (in-situ) and repair calls
    adaptations: list[AdaptationEvent] = field(default_factory=list)
    unmet: str = ""  # the first subtask the env did not count as achieved, with its objects as observed at the end
    env_steps: int | None = None  # the env's own count of the episode's steps (None: it reported none)

    @property
    def generated_tokens(self) -> int:
        """Every token the infiller generated for this episode: before execution and during it."""
        return sum(s.generated_tokens for s in self.grounding.skills) + sum(
            c.generated_tokens for c in self.runtime_calls
        )

    def patch_calls(self) -> list[LMCall]:
        """Every repair and revise call made while the robot ran: the same rule for every method.

        Calls before the first action (grounding, and any retry of code rejected before it ran:
        RECENT's validation, a baseline's syntax or security rejection) are no interruption; they
        count in GO-pre and IGT.
        """
        return [c for c in self.runtime_calls if c.kind in INTERRUPTING_CALLS]

    def interruptions(self) -> list[LMCall]:
        """The repair and revise calls the model answered (a span the fast path rendered made no one wait)."""
        return [c for c in self.patch_calls() if not c.rendered]

    @property
    def ei(self) -> int:
        """Execution interruptions: the number of repair + revise LM calls (the paper's EI)."""
        return len(self.interruptions())

    @property
    def patches(self) -> int:
        """Run-time patch calls, rendered or generated: EI plus what the fast path wrote without the model."""
        return len(self.patch_calls())

    @property
    def it(self) -> float:
        """Idle time: seconds spent in those calls while the robot waited (the paper's IT)."""
        return sum(c.seconds for c in self.interruptions())

    @property
    def igt(self) -> float:
        """Initial grounding time: from receiving the task to the first executable code."""
        return self.grounding.igt_seconds

    @property
    def skill_tokens(self) -> int:
        return sum(s.skill_tokens for s in self.grounding.skills)

    @property
    def adaptation_tokens(self) -> int:
        """τ_adapt: tokens generated in repair and revise calls (the numerator of the paper's GO)."""
        return sum(c.generated_tokens for c in self.interruptions())

    @property
    def go(self) -> float:
        """Grounding overhead as the paper's appendix defines it: τ_adapt ÷ source skill tokens × 100.

        Pre-execution grounding is not in it (the paper's "w/o ontology guidance" regenerates whole
        skills before execution and reports GO 2.35%); :attr:`go_pre` reports that part.
        """
        return 100.0 * self.adaptation_tokens / max(1, self.skill_tokens)

    @property
    def go_pre(self) -> float:
        """The tokens generated before execution (grounding and a baseline's first program) ÷ skill tokens × 100."""
        return 100.0 * (self.generated_tokens - self.adaptation_tokens) / max(1, self.skill_tokens)

    @property
    def rule_coverage(self) -> float | None:
        """% of the spans and run-time patches (first attempts) that the ontology or a check decided
        completely, so that no LM was needed for them; None where there was none."""
        calls = [c for s in self.grounding.skills for c in s.calls] + list(self.runtime_calls)
        spans = [c for c in calls if c.attempt == 0]
        return 100.0 * sum(c.decided for c in spans) / len(spans) if spans else None

    def time_breakdown(self) -> dict[str, float | int]:
        """IGT (cold) and IT split as users feel them: prompt evaluation, generation, and the rest
        (diagnosis, prompt building, validation); IT per interruption; prompt tokens evaluated
        against those sent (the share the model's cache saved)."""
        grounding = [c for s in self.grounding.skills for c in s.calls]
        interruptions = self.interruptions()
        cold = sum(s.seconds for s in self.grounding.skills)
        every = grounding + list(self.runtime_calls)
        return {
            "igt_prompt_s": round(sum(c.prompt_seconds for c in grounding), 4),
            "igt_generation_s": round(sum(c.generation_seconds for c in grounding), 4),
            "igt_other_s": round(max(0.0, cold - sum(c.seconds for c in grounding)), 4),
            "it_prompt_s": round(sum(c.prompt_seconds for c in interruptions), 4),
            "it_generation_s": round(sum(c.generation_seconds for c in interruptions), 4),
            "it_per_call_s": round(self.it / len(interruptions), 4) if interruptions else 0.0,
            "prompt_tokens": sum(c.prompt_tokens for c in every),
            "prompt_tokens_evaluated": sum(c.evaluated_prompt_tokens for c in every),
        }

    @property
    def lm_seconds(self) -> float:
        return sum(s.lm_seconds for s in self.grounding.skills) + sum(c.seconds for c in self.runtime_calls)

    def first_failure(self) -> tuple[str, str]:
        """(category, message) of what stopped the episode: a skill that failed or one that never grounded."""
        if self.failures:
            return str(self.failures[0].category), self.failures[0].message
        broken = next((s for s in self.grounding.skills if not s.valid), None)
        if broken is not None and broken.verdict is not None:
            return str(broken.verdict.category), f"{broken.skill}: {broken.verdict.message}"
        if self.success is False:
            return str(FailureCategory.TIMEOUT if not self.finished else FailureCategory.SUBTASK_FAILED), self.unmet
        return "", ""

    def to_record(self) -> dict:
        """The episode's numbers in one shape: ``recent run --json``, the bench records and the ``EpisodeEnded`` event.

        Every figure is a sum over the recorded LM calls and the env's verdicts, never an estimate.
        """
        category, message = self.first_failure() if self.success is not True else ("", "")
        calls = [c for s in self.grounding.skills for c in s.calls] + list(self.runtime_calls)
        first = self.grounding.skills[0] if self.grounding.skills else None
        return {
            "task_id": self.task_id,
            "robot": self.robot,
            "seed": self.seed,
            "success": self.success,
            "gc": self.gc,
            "subtasks": len(self.grounding.skills),
            "steps": self.steps,
            "wall_seconds": round(self.wall_seconds, 3),
            "generated_tokens": self.generated_tokens,
            "skill_tokens": self.skill_tokens,
            "adaptation_tokens": self.adaptation_tokens,
            "go": round(self.go, 3),
            "go_pre": round(self.go_pre, 3),
            "ei": self.ei,
            "patches": self.patches,  # run-time patch calls, the fast path's rendered ones included
            "it": round(self.it, 4),
            "igt": round(self.igt, 4),
            # what grounding took when it was not served from the cache: the time to first code of a cold start
            "igt_cold": round(sum(s.seconds for s in self.grounding.skills), 4),
            "grounding_cached": self.grounding.cached,
            "lm_seconds": round(self.lm_seconds, 4),
            "lm_calls": len(calls),
            "forced_calls": sum(c.forced for c in calls),  # answered by the grammar alone (a held retry), not decoded
            "rule_coverage": None if self.rule_coverage is None else round(self.rule_coverage, 1),
            **self.time_breakdown(),
            "valid": all(s.valid for s in self.grounding.skills),
            "failure_category": category,
            "failure_message": message[:500],
            "rejected": dict(Counter(c.category for c in calls if not c.accepted and c.category)),
            "failed_segments": dict(Counter(str(f.category) for f in self.failures)),
            "backend": first.backend if first else "",
            "model": first.model if first else "",
            "env_steps": self.env_steps,
        }

    def ended_event(self) -> EpisodeEnded:
        record = self.to_record()
        return EpisodeEnded(**{f.name: record[f.name] for f in fields(EpisodeEnded)})


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
    recorder: Recorder | None = None,
    camera: bool = False,
) -> EpisodeResult:
    """Ground the task's skills for ``robot`` and execute them until success or the step limit.

    Without an ``env`` one is built (with ``variations``) and closed again afterwards. With
    ``to_completion`` the skills run to their end even after the task succeeded (validation
    checks the effects a skill leaves behind). With a ``recorder`` every event and step is logged
    (``camera``: with an 84×84 front view).
    """
    if env is not None:
        return _run(agent, env, task_id, robot, seed, progress, to_completion, recorder, camera)
    env = RecentEnv(
        task=task_id,
        robot=robot,
        render_mode="rgb_array" if camera else "none",
        visualization_width=CAMERA_SIZE,
        visualization_height=CAMERA_SIZE,
        max_episode_steps=max_steps,
        variations=variations,
    )
    try:
        return _run(agent, env, task_id, robot, seed, progress, to_completion, recorder, camera)
    finally:
        env.close()


def _run(
    agent: RecentAgent,
    env: RecentEnv,
    task_id: str,
    robot: str,
    seed: int,
    progress: bool,
    to_completion: bool,
    recorder: Recorder | None,
    camera: bool,
) -> EpisodeResult:
    started = time.perf_counter()
    raw, _ = env.reset(seed=seed)
    names = env.spec_task.object_names()
    episode = None
    if recorder is not None:
        started_event = agent.started_event(task_id, robot, seed, ",".join(env.episode_variations))
        episode = recorder.start_episode(started_event)
    success, steps, settled, info, done, held = False, 0, 0, {}, 0, ()
    bar = _bar(len(env.spec_task.plan), progress, f"grounding {task_id} for {robot}", unit="skill")
    try:
        executor, grounding = agent.start_episode(
            task_id,
            robot,
            Observation.decode(raw["agent_pos"], raw["environment_state"], names),
            emit=episode.emit if episode else ignore,
            seed=seed,
            on_grounded=lambda _skill: bar.update(1),
        )
        bar.close()  # grounding is its own phase: the step bar (and its ETA) starts with the first action
        bar = _bar(env._max_episode_steps, progress, f"{task_id} on {robot}")
        while True:
            action = executor.act(Observation.decode(raw["agent_pos"], raw["environment_state"], names))
            if episode is not None:
                image = env.render() if camera else None
                truth = env.true_environment_state()
                episode.step(raw["agent_pos"], raw["environment_state"], action, image, truth)
            raw, _, terminated, truncated, info = env.step(action)
            steps += 1
            bar.update(1)
            success = bool(info["is_success"])
            if episode is not None and info["subtasks_done"] > done:
                done = info["subtasks_done"]
                episode.emit(SubtaskSucceeded(done - 1, done, len(env.spec_task.plan)))
            if episode is not None and info["held"] != held:
                held = info["held"]
                episode.emit(HeldChanged(list(held)))
            settled = settled + 1 if executor.finished else 0
            if (terminated and not to_completion) or truncated or settled > SETTLE_STEPS:
                break
    except Exception as exc:
        if episode is not None:  # the logs say what broke the run, and stay whole and readable
            episode.end(crashed_event(task_id, robot, seed, steps, time.perf_counter() - started, exc))
        raise
    finally:
        bar.close()
    result = episode_result(
        executor, grounding, seed, success, float(info.get("gc", 0.0)), steps, time.perf_counter() - started
    )
    result.env_steps = steps
    if not success:
        final = Observation.decode(raw["agent_pos"], raw["environment_state"], names)
        result.unmet = unmet_subtask(
            env.spec_task.plan, int(info.get("subtasks_done", 0)), final, finished=executor.finished
        )
        result.unmet += last_failed_check(result.adaptations) if result.unmet else ""
    if episode is not None:
        episode.end(result.ended_event())
    return result


def unmet_subtask(plan: Sequence[PlanStep], done: int, final: Observation, *, finished: bool) -> str:
    """Why a failed episode failed where no skill raised: the first plan step the env did not count
    as achieved, and its objects as observed at the end (an articulated object's state is its
    opening, a button's is pressed or not), so that "subtask_failed" is never a bare label."""
    if done >= len(plan):
        return ""
    step = plan[done]
    seen = []
    for role, name in step.args.items():
        state = final.objects.get(name)
        if state is None:
            seen.append(f"{role}={name} not observed")
            continue
        where = ", ".join(f"{v:.3f}" for v in state.pos)
        seen.append(f"{role}={name} at [{where}] state {round(state.state, 3) + 0.0:.3f}")
    ending = "when the plan ended" if finished else "at the step limit"
    return f"{step.subtask} (subtask {done + 1} of {len(plan)}) not achieved {ending}; observed: " + "; ".join(seen)


def last_failed_check(events: Sequence[AdaptationEvent]) -> str:
    """What the last run-time check that failed saw, for a subtask left unachieved: a step limit
    reached while a sweep was run again for a block half out of the pen says so, not only where
    the objects ended."""
    if not events:
        return ""
    last = events[-1]
    return f"; the last check that failed: {', '.join(last.checks)}: {last.observation}"


def crashed_event(task_id: str, robot: str, seed: int, steps: int, wall_seconds: float, exc: Exception) -> EpisodeEnded:
    """The end of an episode that an error broke off (the LM worker died, a bug): failed, with the reason."""
    message = f"{type(exc).__name__}: {exc}"
    return EpisodeEnded(
        task_id,
        robot,
        seed,
        False,
        None,
        steps,
        wall_seconds,
        0,
        0,
        0.0,
        0.0,
        0,
        0.0,
        0.0,
        str(FailureCategory.CRASH),
        message,
    )


def episode_result(
    executor: TaskExecutor,
    grounding: EpisodeGrounding,
    seed: int,
    success: bool | None,
    gc: float | None,
    steps: int,
    wall_seconds: float,
) -> EpisodeResult:
    """The result record of an episode from what its executor and grounding recorded."""
    adapter = executor.adapter
    return EpisodeResult(
        task_id=grounding.task_id,
        robot=grounding.robot,
        seed=seed,
        success=success,
        gc=gc,
        steps=steps,
        wall_seconds=wall_seconds,
        grounding=grounding,
        failures=list(executor.failures),
        runtime_calls=list(adapter.calls) if adapter else [],
        adaptations=list(adapter.events) if adapter else [],
        finished=executor.finished,
    )


def _bar(total: int, enabled: bool, desc: str, unit: str = "step"):
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, disable=not enabled, leave=False)
