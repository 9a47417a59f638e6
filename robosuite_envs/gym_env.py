"""A gymnasium env around :class:`RecentTabletopEnv`, in LeRobot's observation conventions.

Observations: ``agent_pos`` and ``environment_state`` (object slots), see
:mod:`lerobot_policy_recent.robosuite_envs.observation`, as the robot senses them (with the ``sensing_noise``
variation, noisy); with ``camera=True`` also ``pixels``, the front camera (HxWx3 uint8, LeRobot's
``observation.image``), which the policy logs and never acts on. ``info["is_success"]`` is true once every subtask of the plan succeeded (in
order), ``info["gc"]`` is the fraction that did; the reward is ``gc``. An episode terminates on
success and truncates at ``max_episode_steps``.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from lerobot_policy_recent.descriptions.embodiments import get_embodiment
from lerobot_policy_recent.robosuite_envs.observation import ACTION_DIM, AGENT_POS_DIM, ENV_STATE_DIM, MAX_OBJECTS
from lerobot_policy_recent.robosuite_envs.primitives.session import CONTROL_FREQ
from lerobot_policy_recent.robosuite_envs.suites import get_task
from lerobot_policy_recent.robosuite_envs.tasks import task_string
from lerobot_policy_recent.robosuite_envs.variations import apply_build_variations, episode_variations, parse_variations
from lerobot_policy_recent.robosuite_envs.verdicts import write_verdict


class RecentEnv(gym.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": CONTROL_FREQ}

    def __init__(
        self,
        task: str = "cube_in_bin",
        robot: str = "UR5e",
        max_episode_steps: int | None = None,
        render_mode: str = "rgb_array",
        visualization_width: int = 128,
        visualization_height: int = 128,
        render_camera: str = "frontview",
        variations: str | tuple[str, ...] = (),
        verdict_dir: str | None = None,
        camera: bool = False,
    ):
        """``verdict_dir``: where each finished episode's success and GC are written for the logs
        (``lerobot-eval``'s policy cannot see them; :mod:`~lerobot_policy_recent.robosuite_envs.verdicts`)."""
        super().__init__()
        self.verdict_dir = verdict_dir
        self._seed: int | None = None
        self._last_seed: int | None = None
        self._resets = 0  # the episode count the task tag shows
        self._judged = False  # this episode ended (its end is in the task tag, its verdict written)
        self.spec_task = get_task(task)
        if len(self.spec_task.objects) > MAX_OBJECTS:
            raise ValueError(
                f"task {task!r} has {len(self.spec_task.objects)} objects; at most {MAX_OBJECTS} fit the observation"
            )
        self.embodiment = get_embodiment(robot)
        self.variations = parse_variations(variations) if isinstance(variations, str) else tuple(variations)
        self.render_mode = render_mode
        self._max_episode_steps = max_episode_steps or self.spec_task.max_steps
        self._render_size = (visualization_height, visualization_width)
        self._render_camera = render_camera
        self.task_description = task_string(self.spec_task, self.embodiment.name)
        self.task = self.task_description
        self.camera = camera
        if camera and render_mode != "rgb_array":
            raise ValueError(
                f"camera=True renders the front view: it needs render_mode='rgb_array', not {render_mode!r}"
            )
        spaces_ = {
            "agent_pos": spaces.Box(-np.inf, np.inf, (AGENT_POS_DIM,), np.float32),
            "environment_state": spaces.Box(-np.inf, np.inf, (ENV_STATE_DIM,), np.float32),
        }
        if camera:
            spaces_["pixels"] = spaces.Box(0, 255, (visualization_height, visualization_width, 3), np.uint8)
        self.observation_space = spaces.Dict(spaces_)
        self.action_space = spaces.Box(-1.0, 1.0, (ACTION_DIM,), np.float32)
        self._env = None
        self._steps = 0

    @property
    def episode_variations(self) -> tuple[str, ...]:
        """The variations of the current episode (with ``mix``, those drawn for its task and seed)."""
        return self._env.variations if self._env is not None else episode_variations(self.variations, "", None)

    def _make(self, seed: int | None, variations: tuple[str, ...]):
        from lerobot_policy_recent.robosuite_envs.tabletop import build_env

        return build_env(
            self.spec_task, self.embodiment, seed=seed, variations=variations, offscreen=self.render_mode == "rgb_array"
        )

    def _observation(self) -> dict[str, np.ndarray]:
        agent, env_state = self._env.sensed().encode(self.spec_task.object_names())
        observation = {"agent_pos": agent, "environment_state": env_state}
        if self.camera:
            observation["pixels"] = self.render()
        return observation

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        variations = episode_variations(self.variations, self.spec_task.task_id, seed)
        if self._env is not None and (
            self._env.variations != variations  # mix: another set this episode
            or self._env.task_spec != apply_build_variations(self.spec_task, variations, seed)  # odd_obstacle per seed
        ):
            self._env.close()  # the plan and possibly the objects change: the model is built anew
            self._env = None
        if self._env is None:
            self._env = self._make(seed, variations)
        if seed is not None:
            self._env.rng = np.random.default_rng(seed)
        self._seed, self._judged = seed, False
        self._resets += 1
        self._tag(ended_at=None)
        self._env.reset()
        self._steps = 0
        return self._observation(), self._info()

    def step(self, action):
        action = np.asarray(action, dtype=np.float64)
        if action.shape != (ACTION_DIM,):
            raise ValueError(
                f"action must have shape ({ACTION_DIM},) [dx dy dz dax day daz gripper], got {action.shape}"
            )
        if not np.all(np.isfinite(action)):
            raise ValueError(f"action contains NaN or inf and was not stepped: {action.tolist()}")
        self._env.step(np.clip(action, -1.0, 1.0))
        self._steps += 1
        info = self._info()
        truncated = self._steps >= self._max_episode_steps
        if (info["is_success"] or truncated) and not self._judged:
            self._judged = True  # success is latched: the first verdict is the episode's
            self._tag(ended_at=self._steps)
            if self.verdict_dir and self._seed is not None:
                write_verdict(
                    self.verdict_dir,
                    self.spec_task.task_id,
                    self.embodiment.name,
                    self._seed,
                    info["is_success"],
                    info["gc"],
                    self._steps,
                )
        return self._observation(), info["gc"], info["is_success"], truncated, info

    def _tag(self, *, ended_at: int | None) -> None:
        """The task string LeRobot reads each step: the task, robot, the last seed, the episode's count and
        where it ended (:func:`~lerobot_policy_recent.robosuite_envs.tasks.parse_task_string`)."""
        seed = self._seed if self._seed is not None else self._last_seed
        self._last_seed = seed  # an unseeded (auto-)reset keeps the seed the tag showed
        self.task_description = self.task = task_string(
            self.spec_task, self.embodiment.name, seed, ended_at, self._resets
        )

    def true_environment_state(self) -> np.ndarray:
        """The objects' exact poses and extents, in ``environment_state``'s layout: simulator truth, for
        logs only (the observation is what perception reports, noise included)."""
        return self._env.observe().encode(self.spec_task.object_names())[1]

    def _info(self) -> dict:
        """``is_success``: every plan step achieved; ``gc``: the fraction achieved (goal-conditioned);
        ``held``: the simulator's ground truth of what the gripper holds (for logs, never the policy)."""
        truth = self._env.observe().truth
        return {
            "is_success": bool(self._env._check_success()),
            "gc": self._env.goal_conditioned_success,
            "subtasks_done": int(sum(self._env.achieved)),
            "held": tuple(sorted(truth.held)) if truth is not None else (),
        }

    def render(self):
        if self._env is None:
            raise RuntimeError("call reset() before render()")
        height, width = self._render_size
        frame = self._env.sim.render(camera_name=self._render_camera, width=width, height=height)
        return np.ascontiguousarray(frame[::-1])

    def close(self):
        if self._env is not None:
            self._env.close()
            self._env = None
