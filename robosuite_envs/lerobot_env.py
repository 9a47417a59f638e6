"""The LeRobot env type ``recent``: ``lerobot-eval --env.type=recent --env.task=cube_in_bin --env.robot=UR5e``."""

from __future__ import annotations

from dataclasses import dataclass, field

import gymnasium as gym
from lerobot.configs import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_IMAGE, OBS_STATE

from lerobot_policy_recent.robosuite_envs.observation import ACTION_DIM, AGENT_POS_DIM, ENV_STATE_DIM
from lerobot_policy_recent.robosuite_envs.primitives.session import CONTROL_FREQ
from lerobot_policy_recent.robosuite_envs.suites import SUITES
from lerobot_policy_recent.robosuite_envs.variations import parse_variations


@EnvConfig.register_subclass("recent")
@dataclass
class RecentEnvConfig(EnvConfig):
    """Our robosuite tasks; ``task`` may list several comma-separated task ids or a whole suite
    (``kinematic``, ``end_effector``); ``variations``: off, on, all, or a comma list; ``camera``:
    also observe the front camera (``observation.image``), which the policy logs as video."""

    task: str = "cube_in_bin"
    robot: str = "UR5e"
    variations: str = "off"
    fps: int = CONTROL_FREQ
    episode_length: int | None = None
    render_mode: str = "rgb_array"
    visualization_width: int = 128
    visualization_height: int = 128
    camera: bool = False
    # Where each finished episode's success and GC go, for the policy's result rows (it cannot see
    # them); the same directory as --policy.log_dir. None: the rows leave them empty.
    verdict_dir: str | None = "outputs/recent_logs"
    features: dict[str, PolicyFeature] = field(
        default_factory=lambda: {
            ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(ACTION_DIM,)),
            "agent_pos": PolicyFeature(type=FeatureType.STATE, shape=(AGENT_POS_DIM,)),
            "environment_state": PolicyFeature(type=FeatureType.ENV, shape=(ENV_STATE_DIM,)),
        }
    )
    features_map: dict[str, str] = field(
        default_factory=lambda: {ACTION: ACTION, "agent_pos": OBS_STATE, "environment_state": OBS_ENV_STATE}
    )

    def __post_init__(self):
        if self.camera:
            self.features["pixels"] = PolicyFeature(
                type=FeatureType.VISUAL, shape=(self.visualization_height, self.visualization_width, 3)
            )
            self.features_map["pixels"] = OBS_IMAGE
        from lerobot_policy_recent.descriptions.embodiments import get_embodiment
        from lerobot_policy_recent.robosuite_envs.suites import get_task

        for task_id in self.task_ids:
            get_task(task_id)  # unknown names fail here, listing the valid ones
        get_embodiment(self.robot)
        parse_variations(self.variations)

    @property
    def task_ids(self) -> list[str]:
        ids = []
        for name in (t.strip() for t in (self.task or "").split(",") if t.strip()):
            ids += [t.task_id for t in SUITES[name]] if name in SUITES else [name]
        return ids

    @property
    def gym_kwargs(self) -> dict:
        return {
            "robot": self.robot,
            "variations": self.variations,
            "max_episode_steps": self.episode_length,
            "render_mode": self.render_mode,
            "visualization_width": self.visualization_width,
            "visualization_height": self.visualization_height,
            "verdict_dir": self.verdict_dir,
            "camera": self.camera,
        }

    def create_envs(self, n_envs: int, use_async_envs: bool = False) -> dict[str, dict[int, gym.vector.VectorEnv]]:
        from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv

        env_cls = gym.vector.AsyncVectorEnv if use_async_envs and n_envs > 1 else gym.vector.SyncVectorEnv
        extra = {"context": "forkserver"} if env_cls is gym.vector.AsyncVectorEnv else {}
        envs = {}
        for task_id in self.task_ids:

            def make(task_id: str = task_id) -> RecentEnv:
                return RecentEnv(task=task_id, **self.gym_kwargs)

            envs[task_id] = {0: env_cls([make] * n_envs, autoreset_mode=gym.vector.AutoresetMode.SAME_STEP, **extra)}
        return envs
