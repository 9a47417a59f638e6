"""The RECENT agent: from a task id and a robot to a task executor of grounded skills.

It owns what lives across episodes — the ontology, the infiller (the loaded LM) and a cache of
grounded skills keyed by everything that could change the result — and nothing per-step.
"""

from __future__ import annotations

import hashlib
import logging
import time
from dataclasses import dataclass, field
from itertools import takewhile
from pathlib import Path

from lerobot_policy_recent.logs.events import Emit, EpisodeStarted, ignore
from lerobot_policy_recent.ontology.builder import Ontology, build_ontology
from lerobot_policy_recent.recent_plugin.baselines import BASELINES
from lerobot_policy_recent.recent_plugin.baselines.adapter import BaselineAdapter
from lerobot_policy_recent.recent_plugin.baselines.generate import generate_skill
from lerobot_policy_recent.recent_plugin.baselines.program_prompt import ProgramContext
from lerobot_policy_recent.recent_plugin.executor import Adapter, PlannedSkill, TaskExecutor
from lerobot_policy_recent.recent_plugin.grounding.ablations import GROUNDING_MODES
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill, ground_skill
from lerobot_policy_recent.recent_plugin.infillers import Infiller, make_infiller
from lerobot_policy_recent.recent_plugin.insitu.adapter import InSituAdapter
from lerobot_policy_recent.recent_plugin.insitu.checks import SceneFacts
from lerobot_policy_recent.robosuite_envs.embodiments import ROBOT_BASE_XY, get_embodiment
from lerobot_policy_recent.robosuite_envs.observation import Observation
from lerobot_policy_recent.robosuite_envs.primitives import api_functions
from lerobot_policy_recent.robosuite_envs.suites import get_task
from lerobot_policy_recent.robosuite_envs.tasks import TaskSpec
from lerobot_policy_recent.skills.repository import LIBRARY, Skill, serve_skill

log = logging.getLogger(__name__)

MODES = (*GROUNDING_MODES, *BASELINES)  # what --mode / --policy.mode accept


@dataclass(frozen=True)
class AgentSettings:
    backend: str = "llamacpp"
    model: str = "qwen2.5-coder-1.5b"
    n_threads: int | None = None
    max_retries: int = 2
    seed: int = 0
    max_skill_steps: int = 3000
    base_url: str | None = None  # the completions server of the openai backend
    lm_device: str | None = None  # transformers backend: cuda | cpu (None: CUDA when available)
    lm_dtype: str = "auto"  # transformers backend: auto | float32 | float16 | bfloat16
    lm_quantization: str | None = None  # transformers backend on CUDA: 8bit | 4bit
    offline_validation: bool = True  # serve only validated skills (False: the paper's ablation)
    skill_library: str | None = None  # a directory of skills (+ validation/); None: the bundled Panda skills
    mode: str = "recent"  # recent | name-similarity | full-regen | no-ontology (ablations) | cap | repair | agentless (baselines)
    insitu: bool = True  # run-time checks patch upcoming segments (False: the paper's "w/o in-situ" ablation)
    max_repairs: int = 2  # reactive repairs of failed segments, per skill
    fast_path: bool = False  # render spans the ontology or a run-time check fully decides without the LM (zero tokens)


@dataclass
class EpisodeGrounding:
    """What grounding cost for one episode: the skills and the seconds until the first executable code."""

    task_id: str
    robot: str
    skills: list[GroundedSkill] = field(default_factory=list)
    igt_seconds: float = 0.0
    cached: bool = False


class RecentAgent:
    def __init__(
        self,
        settings: AgentSettings | None = None,
        *,
        infiller: Infiller | None = None,
        ontology: Ontology | None = None,
    ):
        """Load the LM now, before any task arrives, so IGT measures grounding and not model loading."""
        self.settings = settings or AgentSettings()
        s = self.settings
        self.infiller = infiller or infiller_for(s)
        self.ontology = ontology or build_ontology()
        self._ontology_hash = hashlib.sha256(self.ontology.to_turtle().encode()).hexdigest()
        self._cache: dict[tuple[str, ...], GroundedSkill] = {}
        self.library = Path(s.skill_library) if s.skill_library else LIBRARY

    def ground(self, skill_name: str, robot: str, task: TaskSpec | None = None) -> tuple[GroundedSkill, bool]:
        """Ground ``skill_name`` for ``robot``, reusing a cached result unless code, ontology or LM changed.

        A baseline method writes the program from a prompt that shows ``task`` (its instruction and scene).
        """
        skill = self.skill(skill_name)
        baseline = self.settings.mode in BASELINES
        key = (
            skill.name,
            skill.code_sha256,
            robot,
            self._ontology_hash,
            self.infiller.name,
            self.infiller.model,
            self.settings.mode,
            task.task_id if baseline and task is not None else "",
        )
        if key in self._cache:
            return self._cache[key], True
        if baseline:
            grounded = generate_skill(
                skill,
                robot,
                self.ontology,
                self.infiller,
                self.settings.mode,
                program_context(task),
                max_retries=self.settings.max_retries,
            )
        else:
            grounded = ground_skill(
                skill,
                robot,
                self.ontology,
                self.infiller,
                max_retries=self.settings.max_retries,
                mode=self.settings.mode,
            )
        if grounded.valid:
            self._cache[key] = grounded
        else:
            log.warning(
                "grounding %s for %s failed: %s",
                skill_name,
                robot,
                grounded.verdict.message if grounded.verdict else "",
            )
        return grounded, False

    def start_episode(
        self, task_id: str, robot: str, first_obs: Observation, emit: Emit = ignore
    ) -> tuple[TaskExecutor, EpisodeGrounding]:
        """Ground the task's skills (the events of grounding go to ``emit`` once IGT is measured)."""
        started = time.perf_counter()
        task = get_task(task_id)
        embodiment = get_embodiment(robot)
        report = EpisodeGrounding(task_id=task_id, robot=robot)
        plan, cached = [], []
        for step in task.plan:
            grounded, hit = self.ground(step.skill, robot, task)
            cached.append(hit)
            report.skills.append(grounded)
            plan.append(PlannedSkill(grounded, dict(step.args)))
        report.cached = all(cached)
        report.igt_seconds = time.perf_counter() - started
        for grounded, hit in zip(report.skills, cached, strict=True):
            for event in grounded.events(cached=hit):
                emit(event)
        runnable = list(takewhile(lambda p: p.grounded.valid, plan))  # run what can run, then hold still
        executor = TaskExecutor(
            runnable,
            api_functions(embodiment.api),
            first_obs,
            embodiment.name,
            max_steps=self.settings.max_skill_steps,
            adapter=self.adapter(task, robot, emit),
            emit=emit,
        )
        return executor, report

    def started_event(self, task_id: str, robot: str, seed: int, task: str, variations: str = "") -> EpisodeStarted:
        """The first event of an episode's log: what runs, on what, with which LM and method."""
        s = self.settings
        return EpisodeStarted(
            task_id,
            robot,
            seed,
            task,
            self.infiller.name,
            self.infiller.model,
            s.mode if s.insitu else f"{s.mode} (no in-situ)",
            variations,
            get_task(task_id).object_names(),
        )

    def skill(self, name: str) -> Skill:
        """The repository's skill ``name`` as this agent serves it (validated unless the ablation says not)."""
        return serve_skill(name, self.library, require_validated=self.settings.offline_validation)

    def adapter(self, task: TaskSpec, robot: str, emit: Emit = ignore) -> Adapter:
        """A fresh run-time adapter for one episode (its calls and events are that episode's).

        RECENT's is the in-situ adapter; a baseline's regenerates after failures, its own way.
        """
        if self.settings.mode in BASELINES:
            return BaselineAdapter(
                method=self.settings.mode,
                robot=robot,
                api=self.ontology.api(robot),
                apis=self.ontology.apis,
                infiller=self.infiller,
                context=program_context(task),
                skills={step.skill: self.skill(step.skill) for step in task.plan},
                max_retries=self.settings.max_retries,
                max_repairs=self.settings.max_repairs,
                emit=emit,
            )
        scene = SceneFacts(
            kinds={o.name: o.kind for o in task.objects},
            sizes={o.name: tuple(o.size) for o in task.objects if o.size is not None},
            base_xy=ROBOT_BASE_XY,
            reach=self.ontology.arms[robot].reach,
            push_path=self.ontology.path_of("push_object"),
        )
        return InSituAdapter(
            robot=robot,
            api=self.ontology.api(robot),
            apis=self.ontology.apis,
            infiller=self.infiller,
            scene=scene,
            insitu=self.settings.insitu,
            max_retries=self.settings.max_retries,
            max_repairs=self.settings.max_repairs,
            emit=emit,
        )


def infiller_for(s: AgentSettings) -> Infiller:
    """The LM (or rule renderer) these settings name; behind the fast path if they ask for it."""
    return behind_fast_path(
        make_infiller(
            s.backend,
            s.model,
            n_threads=s.n_threads,
            seed=s.seed,
            base_url=s.base_url,
            device=s.lm_device,
            dtype=s.lm_dtype,
            quantization=s.lm_quantization,
        ),
        s,
    )


def behind_fast_path(infiller: Infiller, s: AgentSettings) -> Infiller:
    """``infiller``, or with ``s.fast_path`` the fast path in front of it (spans the ontology decides: no LM)."""
    if not s.fast_path or infiller.name == "rule":
        return infiller
    from lerobot_policy_recent.recent_plugin.infillers.fast_path import FastPathInfiller

    return FastPathInfiller(infiller)


def program_context(task: TaskSpec | None) -> ProgramContext:
    """What a baseline's prompt shows of the task: its instruction and the scene's objects."""
    if task is None:
        return ProgramContext(instruction="")
    return ProgramContext(task.instruction, tuple(f"{o.name} ({o.kind})" for o in task.objects))
