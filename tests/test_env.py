"""The gym env: LeRobot conventions, seeded resets, bad actions rejected."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_policy_recent.descriptions.embodiments import get_embodiment
from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
from lerobot_policy_recent.robosuite_envs.observation import (
    AGENT_POS_DIM,
    AGENT_POS_NAMES,
    ENV_STATE_DIM,
    JOINTS_AT,
    MAX_ARM_DOF,
)
from lerobot_policy_recent.robosuite_envs.tasks import parse_task_string


@pytest.fixture(scope="module")
def env():
    env = RecentEnv(task="cube_in_bin", robot="UR5e", render_mode="none")
    yield env
    env.close()


def test_observation_layout_and_task_string(env):
    obs, info = env.reset(seed=0)
    assert obs["agent_pos"].shape == (AGENT_POS_DIM,) and obs["environment_state"].shape == (ENV_STATE_DIM,)
    assert env.observation_space.contains(obs) and info == {
        "is_success": False,
        "gc": 0.0,
        "subtasks_done": 0,
        "held": (),
    }
    assert parse_task_string(env.task_description)[:2] == ("cube_in_bin", "UR5e")
    env.reset(seed=42)  # each env of a vectorised lerobot-eval tells the policy its own seed
    assert parse_task_string(env.task_description)[:4] == ("cube_in_bin", "UR5e", 42, None)
    assert env.task == env.task_description
    cube_present = obs["environment_state"][7]
    assert cube_present == 1.0


def test_the_task_tag_says_where_the_episode_ended_until_the_next_reset():
    """A vectorised lerobot-eval auto-resets an env that ended; its tag tells the policy the episode is over."""
    env = RecentEnv(task="cube_in_bin", robot="UR5e", render_mode="none", max_episode_steps=3)
    try:
        env.reset(seed=7)
        for _ in range(3):
            assert parse_task_string(env.task_description).ended_at is None
            *_, truncated, _ = env.step(np.zeros(7))
        episode = parse_task_string(env.task_description).episode
        assert truncated and parse_task_string(env.task_description) == ("cube_in_bin", "UR5e", 7, 3, episode)
        env.reset()  # an auto-reset: no seed; the tag keeps the last seed, forgets the end, counts a new episode
        assert parse_task_string(env.task_description) == ("cube_in_bin", "UR5e", 7, None, episode + 1)
    finally:
        env.close()


def test_arm_joint_states_are_observed_and_padded(env):
    """The arm's encoders are part of the state: positions then velocities, a 6-DoF arm zero-padded."""
    obs, _ = env.reset(seed=0)
    robot = env._env.robots[0]
    dof = get_embodiment("UR5e").arm_dof
    assert dof == len(robot.robot_arm_joints) == 6 and len(AGENT_POS_NAMES) == AGENT_POS_DIM
    q = obs["agent_pos"][JOINTS_AT : JOINTS_AT + MAX_ARM_DOF]
    np.testing.assert_allclose(q[:dof], env._env.sim.data.qpos[robot._ref_arm_joint_pos_indexes], atol=1e-6)
    assert q[dof:].tolist() == [0.0] * (MAX_ARM_DOF - dof)
    moved, *_ = env.step(np.array([0.5, 0, 0, 0, 0, 0, -1.0]))
    assert (
        np.abs(moved["agent_pos"][JOINTS_AT + MAX_ARM_DOF : JOINTS_AT + MAX_ARM_DOF + dof]).max() > 1e-3
    )  # velocities read too


def test_same_seed_same_scene_other_seed_other_scene(env):
    a, _ = env.reset(seed=1)
    b, _ = env.reset(seed=1)
    c, _ = env.reset(seed=2)
    np.testing.assert_allclose(a["environment_state"], b["environment_state"])
    assert not np.allclose(a["environment_state"][:3], c["environment_state"][:3])


@pytest.mark.parametrize("bad", [np.zeros(6), np.full(7, np.nan)])
def test_bad_actions_are_rejected_not_stepped(env, bad):
    env.reset(seed=0)
    with pytest.raises(ValueError, match="shape|NaN"):
        env.step(bad)


def test_unknown_names_list_the_valid_ones():
    with pytest.raises(KeyError, match="known tasks: cube_in_bin"):
        RecentEnv(task="stack_everything")
    with pytest.raises(KeyError, match="known embodiments: Panda, UR5e, Sawyer, Robotiq85, Suction"):
        RecentEnv(robot="R2D2")


def test_passes_gymnasium_env_checker():
    from gymnasium.utils.env_checker import check_env

    env = RecentEnv(
        task="cube_in_bin", robot="Suction", render_mode="rgb_array", visualization_width=64, visualization_height=64
    )
    check_env(env)  # raises on any violation of the gymnasium API (spaces, seeding, step/reset contracts)
    frame = env.render()
    assert frame.shape == (64, 64, 3) and frame.dtype == np.uint8
    env.close()


def test_robot_base_sits_where_the_reach_check_assumes(env):
    """The in-situ reach check reads the base from the calibration; the episode's env has it there."""
    from lerobot_policy_recent.robosuite_envs.calibrate import calibration

    env.reset(seed=0)
    sim_env = env._env
    robot = sim_env.robots[0].robot_model
    base = sim_env.sim.data.body_xpos[sim_env.sim.model.body_name2id(robot.root_body)]
    assert np.allclose(base, calibration(env.embodiment.name).base_xyz, atol=1e-4)
