"""The RECENT agent: from a task id and a robot to a task executor of grounded skills.

It owns what lives across episodes — the ontology, the infiller (the loaded LM) and a cache of
grounded skills keyed by everything that could change the result, in memory and on disk (a new
process reads back what an earlier one grounded) — and nothing per-step.
"""

from __future__ import annotations

import json
import logging
import time
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from itertools import takewhile
from pathlib import Path

from lerobot_policy_recent.logs.events import Emit, EpisodeStarted, ignore
from lerobot_policy_recent.ontology.builder import Ontology, build_ontology
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.executor import Adapter, PlannedSkill, TaskExecutor
from lerobot_policy_recent.recent_plugin.grounding.budget import BudgetedInfiller, CallBudget
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill
from lerobot_policy_recent.recent_plugin.grounding.store import GroundingStore, default_store, grounding_code_digest
from lerobot_policy_recent.recent_plugin.infillers import Infiller
from lerobot_policy_recent.recent_plugin.infillers.base import samples
from lerobot_policy_recent.recent_plugin.methods import Adaptation, Grounding
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.robosuite_envs.calibrate import calibration
from lerobot_policy_recent.robosuite_envs.calibration import Calibration
from lerobot_policy_recent.robosuite_envs.observation import Observation
from lerobot_policy_recent.robosuite_envs.primitives.binding import bind_primitives
from lerobot_policy_recent.robosuite_envs.suites import get_task
from lerobot_policy_recent.robosuite_envs.tasks import TaskSpec
from lerobot_policy_recent.skills.repository import LIBRARY, Skill, serve_skill, task_calls

log = logging.getLogger(__name__)


@dataclass
class EpisodeGrounding:
    """What grounding cost for one episode: the skills and the seconds until the first executable code."""

    task_id: str
    robot: str
    skills: list[GroundedSkill] = field(default_factory=list)
    igt_seconds: float = 0.0
    cached: bool = False


def lm_calls(grounded: GroundedSkill) -> int:
    """The LM calls that produced a grounding (spans the fast path rendered were none)."""
    return sum(1 for call in grounded.calls if not call.rendered)


def lm_call_limit(task: TaskSpec, max_lm_calls: int, library: Path = LIBRARY) -> int:
    """LM calls ``task`` may make, grounding and run time together, the same for every method (0: no
    limit): ``max_lm_calls``, or for a task that scales it, as many calls per primitive call of its
    reference skills if that is more (a paper-length task has a span per call to ground)."""
    if max_lm_calls and task.lm_calls_per_primitive:
        calls = task_calls([step.skill for step in task.plan], library).primitives
        return max(max_lm_calls, task.lm_calls_per_primitive * calls)
    return max_lm_calls


class RecentAgent:
    def __init__(
        self,
        settings: RecentSettings | None = None,
        *,
        infiller: Infiller | None = None,
        ontology: Ontology | None = None,
        store: GroundingStore | bool | None = None,
    ):
        """Load the LM now, before any task arrives, so IGT measures grounding and not model loading.

        ``infiller``: an LM already loaded (agents of several methods share one); the method may put
        something in front of it (the fast path). ``store``: where grounded skills persist across
        processes. True: the default store (unless ``$RECENT_GROUNDING_CACHE=off``); False: none;
        None: the default store only when the agent builds its LM from ``settings`` (an LM handed in
        may be anything, and its groundings must never be served to a real one).
        """
        self.settings = settings or RecentSettings()
        s = self.settings
        self.lm = s.method.model(infiller or s.infiller.build(s.lm_seed))
        self.infiller = s.method.infiller(self.lm)  # names the LM in cache keys and logs
        self.ontology = ontology or build_ontology()
        self._ontology_hash = self.ontology.content_hash()
        self._cache: dict[tuple[str, ...], GroundedSkill] = {}
        if store is None:
            store = infiller is None
        self.store = default_store() if store is True else store or None
        self._lm_key: str | None = None
        self.library = Path(s.skill_library) if s.skill_library else LIBRARY

    def ground(
        self,
        skill_name: str,
        robot: str | Target,
        task: TaskSpec | None = None,
        budget: CallBudget | None = None,
        seed: int | None = None,
    ) -> tuple[GroundedSkill, bool]:
        """Ground ``skill_name`` for ``robot`` (a name, or a target already resolved) the configured
        method's way, reusing a cached result.

        The cache key holds everything that could change the result: the code, the ontology, the
        LM (its weights' sha256 and the backend's settings), the method and the budgets (a
        baseline's prompt also shows ``task``). ``budget``: the task's LM calls; a cached
        grounding takes the calls that produced it, and one that needed more than are left is
        grounded again within what is left. ``seed``: the episode's; when the LM samples
        (``temperature`` > 0) each episode seed grounds afresh, so seeds are real repetitions.
        """
        target = robot if isinstance(robot, Target) else self.ontology.target(robot)
        skill = self.skill(skill_name)
        method = self.settings.method
        key = self.grounding_key(skill, target, task)
        if self.settings.temperature > 0 and samples(self.lm):
            key = (*key, f"episode seed {seed}")
        cached = self._cache.get(key) or (self.store.get(key) if self.store else None)
        if cached is not None and (budget is None or budget.affords(lm_calls(cached))):
            self._cache[key] = cached
            if budget is not None:
                budget.charge(lm_calls(cached))
            return cached, True
        grounded = method.ground(
            Grounding(
                skill,
                target,
                self.ontology,
                self.episode_lm(budget, seed, scope=f"grounding {skill.name}"),
                task,
                max_retries=self.settings.max_retries,
            )
        )
        if grounded.valid:
            self._cache[key] = grounded
            if self.store:
                self.store.put(key, grounded)
        else:
            log.warning(
                "grounding %s for %s failed: %s",
                skill_name,
                target.name,
                grounded.verdict.message if grounded.verdict else "",
            )
        return grounded, False

    def grounding_key(self, skill: Skill, target: Target, task: TaskSpec | None = None) -> tuple[str, ...]:
        """Everything a grounding of ``skill`` for ``target`` depends on: the cache key, in memory and on disk."""
        method = self.settings.method
        return (
            skill.name,
            skill.code_sha256,
            json.dumps(skill.placed_over, sort_keys=True),  # metadata the ontology decides by
            target.name,
            self._ontology_hash,  # every robot's API spec and MJCF, the schema and the relations
            self.infiller.name,
            self.infiller.model,
            method.name,
            method.grounding_key(task),
            self.lm_key(),
            grounding_code_digest(),  # the prompts and checks of this version of the package
        )

    def budget(self, task: TaskSpec) -> CallBudget | None:
        """A fresh LM call budget for ``task`` (None for the rule backend: it makes no LM calls)."""
        if self.lm.name == "rule":
            return None
        return CallBudget(lm_call_limit(task, self.settings.max_lm_calls, self.library))

    def episode_lm(self, budget: CallBudget | None, seed: int | None = None, *, scope: str = "run time") -> Infiller:
        """The method's infiller over the LM for one episode: every LM call taken from ``budget``, and
        sampled (``temperature`` > 0) from a generator seeded by ``lm_seed``, the episode ``seed`` and
        the call's place in its ``scope`` (a skill's grounding, or the run time)."""
        if budget is None:
            return self.infiller
        s = self.settings
        episode_seed = zlib.crc32(f"{s.lm_seed}:{seed}".encode())
        lm = BudgetedInfiller(self.lm, budget, temperature=s.temperature, seed=episode_seed, scope=scope)
        return s.method.infiller(lm)

    def lm_key(self) -> str:
        """The LM and budgets a grounding depends on: the weights' sha256, the backend's settings, the
        seed and the retry budget (computed once: hashing a local GGUF file reads it)."""
        if self._lm_key is None:
            from lerobot_policy_recent.recent_plugin.models import model_sha256

            settings = self.settings.to_dict()
            model = getattr(self.settings.infiller, "model", None)
            self._lm_key = json.dumps(
                {
                    "model_sha256": model_sha256(model) if model else None,
                    "infiller": settings["infiller"],
                    "lm_seed": self.settings.lm_seed,
                    "temperature": self.settings.temperature,
                    "max_retries": self.settings.max_retries,
                },
                sort_keys=True,
                default=str,
            )
        return self._lm_key

    def start_episode(
        self,
        task_id: str,
        robot: str,
        first_obs: Observation,
        emit: Emit = ignore,
        seed: int | None = None,
        on_grounded: Callable[[str], None] | None = None,
    ) -> tuple[TaskExecutor, EpisodeGrounding]:
        """Ground the task's skills (the events of grounding go to ``emit`` once IGT is measured;
        ``on_grounded(skill)`` hears each skill as it is done, for a progress display)."""
        if self.settings.method.on_source:
            self._check_source(task_id, robot)
        target = self.ontology.target(robot)  # resolved once: grounding, adaptation and execution share it
        bind_primitives(target)  # a robot whose YAML and module disagree stops here, before anything is grounded
        started = time.perf_counter()
        task = get_task(task_id)
        report = EpisodeGrounding(task_id=task_id, robot=robot)
        budget = self.budget(task)
        plan, cached = [], []
        for step in task.plan:
            grounded, hit = self.ground(step.skill, target, task, budget, seed)
            if on_grounded is not None:
                on_grounded(step.skill)
            cached.append(hit)
            report.skills.append(grounded)
            plan.append(PlannedSkill(grounded, dict(step.args)))
        report.cached = all(cached)
        report.igt_seconds = time.perf_counter() - started
        for grounded, hit in zip(report.skills, cached, strict=True):
            for event in grounded.events(cached=hit):
                emit(event)
        runnable = list(takewhile(lambda p: p.grounded.valid, plan))  # run what can run, then hold still
        measured = calibration(robot)  # measured once per embodiment and machine, then read from the cache
        executor = TaskExecutor(
            runnable,
            target,
            first_obs,
            max_steps=self.settings.max_skill_steps,
            budget=self.settings.skill_budget,
            adapter=self.adapter(task, target, measured, emit, budget, seed),
            emit=emit,
            calibration=measured,
        )
        return executor, report

    def started_event(self, task_id: str, robot: str, seed: int, variations: str = "") -> EpisodeStarted:
        """The first event of an episode's log: what runs, on what, with which LM and method.

        ``task`` is the plain instruction (the dataset's task); the task id, robot and method have fields of their own.
        """
        s = self.settings
        spec = get_task(task_id)
        return EpisodeStarted(
            task_id,
            robot,
            seed,
            spec.instruction,
            self.infiller.name,
            self.infiller.model,
            s.method.label,
            variations,
            spec.object_names(),
        )

    def source_robot(self, task_id: str) -> str:
        """The robot a task's reference skills are written for (the ceiling row runs its episodes there)."""
        robots = sorted({self.skill(step.skill).source_embodiment for step in get_task(task_id).plan})
        if len(robots) != 1:
            raise ValueError(f"{task_id}: its skills come from {len(robots)} source robots ({', '.join(robots)})")
        return robots[0]

    def _check_source(self, task_id: str, robot: str) -> None:
        """A method that runs on the source robot (the bench's ceiling row) refuses any other robot."""
        source = self.source_robot(task_id)
        if source != robot:
            raise ValueError(
                f"method {self.settings.method.name!r} runs a task on its skills' source robot "
                f"({source}), not on {robot}: pass --robot {source}, or use it in `recent bench`, "
                "which runs each target's episode there"
            )

    def skill(self, name: str) -> Skill:
        """The repository's skill ``name`` as this agent serves it (validated unless the ablation says not)."""
        return serve_skill(name, self.library, require_validated=self.settings.method.require_validated())

    def adapter(
        self,
        task: TaskSpec,
        target: Target,
        measured: Calibration,
        emit: Emit = ignore,
        budget: CallBudget | None = None,
        seed: int | None = None,
    ) -> Adapter:
        """A fresh run-time adapter for one episode (its calls and events are that episode's), the
        method's own, its LM calls taken from the task's ``budget`` (and sampled for its ``seed``)."""
        return self.settings.method.adapter(
            Adaptation(
                target=target,
                calibration=measured,
                ontology=self.ontology,
                infiller=self.episode_lm(budget, seed),
                task=task,
                skill=self.skill,
                max_retries=self.settings.max_retries,
                max_repairs=self.settings.max_repairs,
                emit=emit,
                lm_budget_binds=budget is not None and budget.limit > 0,
            )
        )
