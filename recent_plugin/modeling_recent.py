"""``RecentPolicy``: LeRobot's view of the RECENT agent.

At the first step of an episode it grounds the task's skills for the env's robot (cached across
episodes) and then returns one action per ``select_action`` from a per-batch-element executor.
Each batch element's episode is logged (``log_dir``): grounding events, every observation and
action, and its result, at the step where its env says the episode ended (the task tag's
``end=N``) or at ``reset()``. In a batched ``lerobot-eval`` an env that ended is auto-reset while
the others go on; LeRobot counts nothing after its end, so the policy logs nothing after it either
and answers that element with a zero action (one the env discards or LeRobot ignores).
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass

import numpy as np
import torch
from lerobot.policies.pretrained import PreTrainedPolicy
from lerobot.utils.constants import OBS_ENV_STATE, OBS_IMAGE, OBS_STATE

from lerobot_policy_recent.logs.events import ignore
from lerobot_policy_recent.logs.recorder import EpisodeLog, Recorder
from lerobot_policy_recent.recent_plugin.agent import EpisodeGrounding, RecentAgent
from lerobot_policy_recent.recent_plugin.configuration_recent import RecentConfig
from lerobot_policy_recent.recent_plugin.episode import crashed_event, episode_result
from lerobot_policy_recent.recent_plugin.executor import TaskExecutor
from lerobot_policy_recent.robosuite_envs.observation import ACTION_DIM, Observation
from lerobot_policy_recent.robosuite_envs.suites import get_task
from lerobot_policy_recent.robosuite_envs.tasks import parse_task_string
from lerobot_policy_recent.robosuite_envs.verdicts import Verdict, take_verdict

log = logging.getLogger(__name__)


@dataclass
class _Episode:
    """One batch element's episode: its executor, what grounding cost, and its log."""

    executor: TaskExecutor
    grounding: EpisodeGrounding
    log: EpisodeLog | None
    started: float
    seed: int  # the env's episode seed, from the task string's tag (-1 when the env had none)
    task_id: str
    robot: str
    over: bool = False  # its result is logged
    env_episode: int | None = None  # the env's episode count when it started (the task tag's ep=)


class RecentPolicy(PreTrainedPolicy):
    config_class = RecentConfig
    name = "recent"

    def __init__(self, config: RecentConfig, **kwargs):
        super().__init__(config)
        config.validate_features()
        self.config = config
        self.agent = RecentAgent(config.agent_settings())
        self._episodes: list[_Episode | None] = []
        self._ended: set[int] = set()  # batch elements whose env's episode ended since the last reset()
        self.groundings: list[EpisodeGrounding] = []
        self.recorder: Recorder | None = None
        self._warned_verdicts = False
        if config.log_dir:
            self.recorder = Recorder(config.log_dir, [s.strip() for s in config.log_sinks.split(",") if s.strip()])
            # lerobot-eval never resets after the last episode: commit it when the program ends, while
            # threads can still start (the dataset writer needs them; plain atexit runs too late).
            threading._register_atexit(self.close_logs)

    @property
    def _executors(self) -> list[TaskExecutor | None]:
        return [e.executor if e else None for e in self._episodes]

    def close_logs(self) -> None:
        """Commit the episodes still running and close the log files (also run at interpreter exit)."""
        if self.recorder is not None:
            self.reset()
            self.recorder.close()
            self.recorder = None

    def get_optim_params(self) -> dict:
        return {}

    def reset(self):
        """End every batch element's episode (its result goes to the logs) before the next begins."""
        for episode in self._episodes:
            if episode is not None:
                self._end(episode)
        self._episodes, self._ended = [], set()

    def _end(self, episode: _Episode) -> None:
        """Write the episode's result to its log (once), with the env's verdict where it wrote one."""
        if episode.over:
            return
        episode.over = True
        if episode.log is None:
            return
        verdict = self._verdict(episode)
        result = episode_result(
            episode.executor,
            episode.grounding,
            episode.seed,
            verdict.success if verdict else None,
            verdict.gc if verdict else None,
            episode.log.frame_index,
            time.perf_counter() - episode.started,
        )
        result.env_steps = verdict.steps if verdict else None
        episode.log.end(result.ended_event())

    def _verdict(self, episode: _Episode) -> Verdict | None:
        """The env's verdict on the ended episode, where it wrote one (``--env.verdict_dir``, the same
        directory as ``--policy.log_dir``); the logs only, never the policy's decisions."""
        if not self.config.log_dir or episode.seed < 0:
            return None
        verdict = take_verdict(self.config.log_dir, episode.task_id, episode.robot, episode.seed)
        if verdict is None and not self._warned_verdicts:
            self._warned_verdicts = True
            log.warning(
                "no verdict from the env for %s on %s (seed %d) in %s/verdicts: the logs record success and GC "
                "as unknown; pass --env.verdict_dir=%s (the same directory as --policy.log_dir)",
                episode.task_id,
                episode.robot,
                episode.seed,
                self.config.log_dir,
                self.config.log_dir,
            )
        return verdict

    def forward(self, batch: dict[str, torch.Tensor]):
        raise NotImplementedError("RECENT grounds skill code at deployment time; it has nothing to train")

    @torch.no_grad()
    def predict_action_chunk(self, batch: dict[str, torch.Tensor], **kwargs) -> torch.Tensor:
        return self.select_action(batch).unsqueeze(1)

    @torch.no_grad()
    def select_action(self, batch: dict[str, torch.Tensor], **kwargs) -> torch.Tensor:
        states = batch[OBS_STATE].detach().cpu().numpy()
        env_states = batch[OBS_ENV_STATE].detach().cpu().numpy()
        tasks = batch.get("task") or [""] * len(states)
        if isinstance(tasks, str):
            tasks = [tasks]
        if len(self._episodes) != len(states):
            self._episodes, self._ended = [None] * len(states), set()
        actions = []
        for b, (state, env_state, text) in enumerate(zip(states, env_states, tasks, strict=True)):
            task_id, robot, seed, ended_at, env_episode = parse_task_string(text)
            episode = self._episodes[b]
            if ended_at is not None or (episode is not None and env_episode != episode.env_episode):
                # its env ended at the last step (or was reset since: an auto-reset episode, which LeRobot does not
                # count): the result goes to the logs now, and nothing more of this element until reset()
                self._ended.add(b)
                if episode is not None:
                    self._end(episode)
            if b in self._ended:
                actions.append(np.zeros(ACTION_DIM, dtype=np.float32))  # discarded by the env, ignored by LeRobot
                continue
            obs = Observation.decode(state, env_state, get_task(task_id).object_names())
            if episode is None:
                episode = self._episodes[b] = self._start(task_id, robot, seed, obs)
                episode.env_episode = env_episode
            try:
                action = episode.executor.act(obs)
            except Exception as exc:  # the LM worker died, a bug: the log says so, and lerobot-eval sees the error
                self._episodes[b] = None
                _end_crashed(episode.log, task_id, robot, episode.seed, episode.started, exc)
                raise
            if episode.log is not None:
                episode.log.step(state, env_state, action, _camera_frame(batch, b))
            actions.append(action)
        return torch.as_tensor(np.stack(actions), dtype=torch.float32)

    def _start(self, task_id: str, robot: str, env_seed: int | None, obs: Observation) -> _Episode:
        started = time.perf_counter()
        seed = env_seed if env_seed is not None else -1  # -1: the env was reset without a seed
        log = None
        if self.recorder is not None:
            log = self.recorder.start_episode(self.agent.started_event(task_id, robot, seed))
        try:
            executor, report = self.agent.start_episode(
                task_id, robot, obs, emit=log.emit if log else ignore, seed=seed
            )
        except Exception as exc:
            _end_crashed(log, task_id, robot, seed, started, exc)
            raise
        self.groundings.append(report)
        return _Episode(executor, report, log, started, seed, task_id, robot)


def _camera_frame(batch: dict, b: int) -> np.ndarray | None:
    """The env's front camera for batch element ``b`` (``--env.camera=true``), as the HxWx3 bytes the logs keep."""
    image = batch.get(OBS_IMAGE)
    if image is None:
        return None
    chw = image[b].detach().cpu().float().clamp(0.0, 1.0)
    return (chw.permute(1, 2, 0) * 255).round().to(torch.uint8).numpy()


def _end_crashed(log: EpisodeLog | None, task_id: str, robot: str, seed: int, started: float, exc: Exception) -> None:
    """End a logged episode that an error broke off, with the error as its result (the logs stay whole)."""
    if log is not None:
        log.end(crashed_event(task_id, robot, seed, log.frame_index, time.perf_counter() - started, exc))
