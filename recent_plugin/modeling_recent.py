"""``RecentPolicy``: LeRobot's view of the RECENT agent.

At the first step of an episode it grounds the task's skills for the env's robot (cached across
episodes) and then returns one action per ``select_action`` from a per-batch-element executor.
"""

from __future__ import annotations

import numpy as np
import torch
from lerobot.policies.pretrained import PreTrainedPolicy
from lerobot.utils.constants import OBS_ENV_STATE, OBS_STATE

from recent_plugin.agent import EpisodeGrounding, RecentAgent
from recent_plugin.configuration_recent import RecentConfig
from recent_plugin.executor import TaskExecutor
from robosuite_envs.observation import Observation
from robosuite_envs.tasks import get_task, parse_task_string


class RecentPolicy(PreTrainedPolicy):
    config_class = RecentConfig
    name = "recent"

    def __init__(self, config: RecentConfig, **kwargs):
        super().__init__(config)
        config.validate_features()
        self.config = config
        self.agent = RecentAgent(config.agent_settings())
        self._executors: list[TaskExecutor | None] = []
        self.groundings: list[EpisodeGrounding] = []

    def get_optim_params(self) -> dict:
        return {}

    def reset(self):
        self._executors = []

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
        if len(self._executors) != len(states):
            self._executors = [None] * len(states)
        actions = []
        for b, (state, env_state, text) in enumerate(zip(states, env_states, tasks, strict=True)):
            task_id, robot = parse_task_string(text)
            obs = Observation.decode(state, env_state, get_task(task_id).object_names())
            if self._executors[b] is None:
                self._executors[b], report = self.agent.start_episode(task_id, robot, obs)
                self.groundings.append(report)
            actions.append(self._executors[b].act(obs))
        return torch.as_tensor(np.stack(actions), dtype=torch.float32)
