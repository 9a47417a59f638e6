"""The LeRobot plugin: discovery by distribution name, the policy factory, and a real lerobot-eval run."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import torch


def test_distribution_is_discovered_by_lerobot():
    """LeRobot's own discovery, in a fresh interpreter (here the package is imported before LeRobot)."""
    code = (
        "from lerobot.configs import PreTrainedConfig\n"
        "from lerobot.envs.configs import EnvConfig\n"
        "from lerobot.utils.import_utils import register_third_party_plugins\n"
        "register_third_party_plugins()\n"
        "print('recent' in PreTrainedConfig.get_known_choices(), 'recent' in EnvConfig.get_known_choices())\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd="/")
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split()[-2:] == ["True", "True"]


def test_policy_factory_builds_recent_and_returns_batched_actions():
    from lerobot.policies.factory import make_policy, make_pre_post_processors

    import lerobot_policy_recent  # noqa: F401
    from lerobot_policy_recent.recent_plugin.configuration_recent import RecentConfig
    from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
    from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
    from lerobot_policy_recent.robosuite_envs.lerobot_env import RecentEnvConfig

    env_cfg = RecentEnvConfig(task="cube_in_bin", robot="UR5e")
    policy = make_policy(RecentConfig(infiller=RuleConfig(), log_dir=None), env_cfg=env_cfg)
    pre, post = make_pre_post_processors(policy.config)
    env = RecentEnv(task="cube_in_bin", robot="UR5e", render_mode="none")
    obs, _ = env.reset(seed=0)
    batch = {
        "observation.state": torch.from_numpy(obs["agent_pos"])[None].repeat(2, 1),
        "observation.environment_state": torch.from_numpy(obs["environment_state"])[None].repeat(2, 1),
        "task": [env.task_description] * 2,
    }
    action = post(policy.select_action(pre(batch)))
    assert action.shape == (2, 7)
    policy.reset()
    assert policy._executors == []
    env.close()


def test_lerobot_eval_runs_two_tasks_with_batch_size_two(tmp_path):
    """The README's lerobot-eval line on two suite tasks, two envs per batch, with the camera (rule
    backend keeps it fast; the policy path is the same as with the LM); then LeRobot's ACT trains on
    the dataset it logged."""
    out = tmp_path / "eval"
    tasks = ["kinematic/press_button", "end_effector/open_drawer"]
    cmd = [
        str(Path(sys.executable).with_name("lerobot-eval")),
        "--policy.type=recent",
        "--policy.infiller.type=rule",
        "--env.type=recent",
        f"--env.task={','.join(tasks)}",
        "--env.robot=UR5e",
        "--eval.n_episodes=2",
        "--eval.batch_size=2",
        f"--output_dir={out}",
        f"--policy.log_dir={tmp_path / 'logs'}",
        f"--env.verdict_dir={tmp_path / 'logs'}",
        "--env.camera=true",
        "--env.visualization_width=64",
        "--env.visualization_height=64",
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, env={**os.environ, "TQDM_DISABLE": "1"})
    assert proc.returncode == 0, proc.stderr[-3000:]
    info = json.loads((out / "eval_info.json").read_text())
    assert info["overall"]["n_episodes"] == 4
    assert {row["task_group"] for row in info["per_task"]} == set(tasks)
    assert info["overall"]["pc_success"] == 100.0, info["per_task"]
    from lerobot_policy_recent.logs.verify import verify

    report = verify(tmp_path / "logs")  # the policy logged each batch element's episode
    assert report.ok and len(report.episodes) == 4, (report.problems, [e.problems for e in report.episodes])
    from lerobot_policy_recent.logs.layout import LogLayout
    from lerobot_policy_recent.logs.readers import read_table

    layout = LogLayout(tmp_path / "logs")
    rows = [read_table(layout.results(e))[0] for e in layout.committed()]
    by_task: dict[str, list[int]] = {}
    for row in rows:
        by_task.setdefault(row["task_id"], []).append(row["seed"])
    assert all(len(set(seeds)) == 2 for seeds in by_task.values()), by_task  # each env its own seed
    # each env's episode ends in the logs at its own last step, not at the batch's (verify checks it too);
    # the two envs of a batch ended at different steps, so the auto-reset frames would show here
    assert all(row["env_steps"] == row["num_frames"] for row in rows), rows
    assert len({row["num_frames"] for row in rows}) > 1, rows
    # the env's verdicts fill the policy's result rows (lerobot-eval keeps them from the policy)
    assert all(row["success"] is True and row["gc"] == 1.0 for row in rows), rows
    assert not list((tmp_path / "logs" / "verdicts").glob("*.json"))  # each taken once
    check_trainable_dataset(layout.dataset_dir, sum(row["num_frames"] for row in rows), tmp_path / "train")


def check_trainable_dataset(root: Path, frames: int, out: Path) -> None:
    """The logged dataset is one LeRobot trains on: named features, reward/done/success, arm joints, video."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    dataset = LeRobotDataset("local/recent_episodes", root=root, video_backend="pyav")
    assert dataset.num_episodes == 4 and dataset.num_frames == frames
    assert dataset.meta.video_keys == ["observation.images.front"]
    assert all(dataset.features[k]["names"] for k in ("observation.state", "observation.environment_state", "action"))
    assert {"next.reward", "next.done", "next.success"} <= set(dataset.features)
    names = dataset.features["observation.state"]["names"]
    last = dataset[frames - 1]
    joints = last["observation.state"][names.index("joint0_pos") : names.index("joint5_pos") + 1]
    assert bool(last["next.done"]) and float(joints.abs().max()) > 0.1  # UR5e's arm joints are logged
    cmd = [
        str(Path(sys.executable).with_name("lerobot-train")),
        "--policy.type=act",
        "--dataset.repo_id=local/recent_episodes",
        f"--dataset.root={root}",
        "--steps=3",
        "--batch_size=2",
        "--num_workers=0",
        "--policy.device=cpu",
        "--policy.push_to_hub=false",
        "--policy.pretrained_backbone_weights=null",  # no network here: ResNet from scratch
        "--save_checkpoint=false",
        "--wandb.enable=false",
        f"--output_dir={out}",
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env={**os.environ, "TQDM_DISABLE": "1"})
    assert proc.returncode == 0 and "End of training" in proc.stdout + proc.stderr, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]  # the video decodes with LeRobot's defaults
