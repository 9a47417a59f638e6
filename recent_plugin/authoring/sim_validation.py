"""Validate(skill, Panda) in simulation: run a reference skill on the source robot across the paper's seeds.

A skill is served to grounding only with a record whose code hash matches the file and whose
every seed passed: its precondition checks held at the start and its expected effects (the
subtask's success predicate among them) were observed at the end. Records are JSON files in
``skills/library/validation/`` and are committed with the skills.
"""

from __future__ import annotations

import time

from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.methods.recent import Recent
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
from lerobot_policy_recent.robosuite_envs.observation import Observation
from lerobot_policy_recent.robosuite_envs.suites import SEEDS, validation_task
from lerobot_policy_recent.skills.records import ValidationRecord
from lerobot_policy_recent.skills.repository import Skill


# Testable conditions of skill metadata, read off the env's exact observation (its ground truth included):
# validation judges the skill, as a success predicate does, and is not the robot's own guess.
def _holding(obs: Observation) -> bool:
    return obs.truth is not None and bool(obs.truth.held)


PRECONDITION_CHECKS = {
    "end_effector_free": lambda obs, objects: not _holding(obs),
    "object_visible": lambda obs, objects: all(name in obs.objects for name in objects),
}
EFFECT_CHECKS = {
    "end_effector_free": lambda obs, objects: not _holding(obs),
    "object_grasped": lambda obs, objects: _holding(obs),
}


def validate(skill: Skill, seeds: tuple[int, ...] = SEEDS, *, agent=None, on_episode=None) -> ValidationRecord:
    """Run ``skill`` unmodified on its source robot in its subtask's task, once per seed."""
    library = str(skill.path.parent)  # the agent must serve this very file
    agent = agent or RecentAgent(
        RecentSettings(infiller=RuleConfig(), method=Recent(offline_validation=False), skill_library=library)
    )
    task = validation_task(skill.subtask)
    objects = list(task.plan[0].args.values())
    record = ValidationRecord(skill.name, skill.code_sha256, skill.source_embodiment, task.task_id, list(seeds))
    env = RecentEnv(task=task.task_id, robot=skill.source_embodiment, render_mode="none")
    try:
        for seed in seeds:
            started = time.perf_counter()
            reason = _validate_once(skill, agent, env, task.task_id, seed, objects)
            record.seconds[str(seed)] = round(time.perf_counter() - started, 2)
            if reason:
                record.failures[str(seed)] = reason
            else:
                record.passed.append(seed)
            if on_episode:
                on_episode(seed, reason)
    finally:
        env.close()
    record.validated_at = time.strftime("%Y-%m-%d")
    return record


def _validate_once(skill: Skill, agent, env: RecentEnv, task_id: str, seed: int, objects: list[str]) -> str:
    """Empty string when the seed passes, else why it did not."""
    env.reset(seed=seed)
    first = env._env.observe()
    for condition in skill.preconditions:
        check = PRECONDITION_CHECKS.get(condition)
        if check and not check(first, objects):
            return f"precondition {condition} does not hold at the start"
    result = run_episode(agent, task_id, skill.source_embodiment, seed=seed, env=env, to_completion=True)
    refused = next((g for g in result.grounding.skills if not g.valid), None)
    if refused is not None:  # nothing ran: say why, not that the predicate never held
        return f"not run: {refused.verdict.message if refused.verdict else 'its code was refused before execution'}"
    if result.failures:
        failure = result.failures[0]
        return f"[{failure.category}] line {failure.line}: {failure.message}"
    if not result.success:
        return f"the {skill.subtask} success predicate never held"
    last = env._env.observe()
    for condition in skill.effects:
        check = EFFECT_CHECKS.get(condition)
        if check and not check(last, objects):
            return f"expected effect {condition} not observed at the end"
    return ""
