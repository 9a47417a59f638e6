"""Bad input gets one line naming the file, field or option, the value and what is allowed, and a
non-zero exit; or a warning where the run can still be right. Never a traceback, never a silent 0."""

from __future__ import annotations

import dataclasses
import logging
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lerobot_policy_recent.scripts.cli import main, underscored

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["run", "--seed", "-1"], "argument --seed: -1 is below 0: it must be an integer >= 0"),
        (["run", "--max-steps", "0"], "argument --max_steps: 0 is below 1: it must be an integer >= 1"),
        (["run", "--max_steps", "-3"], "argument --max_steps: -3 is below 1: it must be an integer >= 1"),
        (["run", "--seed", "x"], "argument --seed: 'x' is not an integer"),
    ],
)
def test_out_of_range_options_are_refused_by_name(argv, says, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2 and says in capsys.readouterr().err


def test_a_zero_skill_step_budget_is_refused_by_name(capsys):
    code = main(
        ["ground", "--skill", "put_in_bin", "--robot", "UR5e", "--infiller.type", "rule", "--max_skill_steps", "0"]
    )
    assert code == 2 and "--max_skill_steps must be >= 1, got 0" in capsys.readouterr().err


def test_the_skill_budget_is_set_by_option_and_refused_out_of_range(capsys):
    from lerobot_policy_recent.scripts.cli import build_parser
    from lerobot_policy_recent.scripts.common import settings_from_args

    args = build_parser().parse_args(
        ["ground", "--skill", "put_in_bin", "--robot", "UR5e", "--skill_budget.step_seconds", "0.5"]
    )
    assert settings_from_args(args).skill_budget.step_seconds == 0.5
    code = main(
        [
            "ground",
            "--skill",
            "put_in_bin",
            "--robot",
            "UR5e",
            "--infiller.type",
            "rule",
            "--skill_budget.max_value_items",
            "0",
        ]
    )
    assert code == 2 and "--skill_budget.max_value_items must be > 0, got 0" in capsys.readouterr().err


def test_dashes_and_underscores_name_the_same_option():
    assert underscored(["run", "--log-dir=x", "--max-steps", "3", "--task", "a-b", "--", "--keep-me"]) == [
        "run",
        "--log_dir=x",
        "--max_steps",
        "3",
        "--task",
        "a-b",
        "--",
        "--keep-me",
    ]


def test_verify_on_an_empty_directory_fails_and_says_why(tmp_path, capsys):
    assert main(["logs", "verify", str(tmp_path)]) == 1
    assert "holds no logged episode" in capsys.readouterr().out


def test_a_primitive_module_that_does_not_import_is_named(tmp_path, monkeypatch):
    from lerobot_policy_recent.robosuite_envs.primitives import import_primitive_module

    monkeypatch.syspath_prepend(str(tmp_path))
    (tmp_path / "broken_prims.py").write_text("def grab(env, task):\n    yield from (\n")
    with pytest.raises(
        ValueError, match=rf"{tmp_path / 'broken_prims.py'}:2: primitive module 'broken_prims' does not parse"
    ):
        import_primitive_module("broken_prims")
    (tmp_path / "raising_prims.py").write_text("raise RuntimeError('no controller here')\n")
    with pytest.raises(
        ValueError,
        match=r"raising_prims.py: primitive module 'raising_prims' raised on import: RuntimeError: no controller here",
    ):
        import_primitive_module("raising_prims")
    (tmp_path / "needy_prims.py").write_text("import no_such_driver\n")
    with pytest.raises(
        ValueError, match=r"needy_prims.py: primitive module 'needy_prims': No module named 'no_such_driver'"
    ):
        import_primitive_module("needy_prims")


def test_an_unknown_robosuite_gripper_names_the_robot_file_field():
    from lerobot_policy_recent.descriptions.embodiments import get_embodiment
    from lerobot_policy_recent.robosuite_envs.tabletop import check_robosuite_names

    lab = dataclasses.replace(
        get_embodiment("UR5e"), gripper="Robotiq58Gripper", spec_dir="/lab/robots", api="lab_ur5e"
    )
    with pytest.raises(
        ValueError,
        match=r"/lab/robots/lab_ur5e.yaml: robot.gripper: unknown robosuite gripper class 'Robotiq58Gripper'; known: .*Robotiq85Gripper",
    ):
        check_robosuite_names(lab)


def test_a_robot_module_with_a_syntax_error_is_one_line_from_the_cli(tmp_path):
    from test_calibration import IIWA_YAML

    folder = tmp_path / "robots"
    folder.mkdir()
    (folder / "lab_iiwa.yaml").write_text(IIWA_YAML)
    (folder / "iiwa_prims.py").write_text("def iiwa_grab(env, task, point)\n    yield\n")
    env = {**os.environ, "RECENT_ROBOTS": str(folder), "RECENT_CACHE_DIR": str(tmp_path / "cache")}
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "lerobot_policy_recent.scripts.cli",
            "run",
            "--task",
            "kinematic/lift_cube",
            "--robot",
            "LabIIWA",
        ]
        + ["--infiller.type", "rule", "--no_log"],
        env=env,
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr[-2000:]
    assert f"{folder / 'iiwa_prims.py'}:1: primitive module 'iiwa_prims' does not parse" in done.stderr


def test_a_skill_refused_by_the_gate_says_which_statement_and_rule(ontology, rule_infiller):
    from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
    from lerobot_policy_recent.skills.repository import load_skill

    skill = load_skill("put_in_bin")
    lines = skill.code.splitlines()
    body = next(i for i, line in enumerate(lines) if "pick(" in line)
    lines.insert(body, "    for i in range(2000):\n        lift = i")
    grounded = ground_skill(
        dataclasses.replace(skill, code="\n".join(lines) + "\n"), ontology.target("UR5e"), ontology, rule_infiller
    )
    assert not grounded.valid and not grounded.calls  # refused as written: no attempt spent on a span
    message = grounded.verdict.message
    assert f"line {body + 1}:" in message and "range() bounds must be integer literals up to 1000" in message
    assert "'put_in_bin' as written is refused by the security gate" in message


def test_a_policy_logging_without_the_envs_verdicts_warns_once(tmp_path, caplog):
    """--policy.log_dir without the matching --env.verdict_dir: the rows cannot hold success; say so."""
    from lerobot.policies.factory import make_policy

    from lerobot_policy_recent.recent_plugin.configuration_recent import RecentConfig
    from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
    from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
    from lerobot_policy_recent.robosuite_envs.lerobot_env import RecentEnvConfig

    config = RecentConfig(infiller=RuleConfig(), log_dir=str(tmp_path / "logs"), log_sinks="mcap")
    policy = make_policy(config, env_cfg=RecentEnvConfig(task="cube_in_bin", robot="UR5e"))
    env = RecentEnv(task="cube_in_bin", robot="UR5e", render_mode="none", max_episode_steps=2)  # no verdict_dir
    try:
        import torch

        obs, _ = env.reset(seed=3)
        with caplog.at_level(logging.WARNING):
            for _ in range(3):
                batch = {
                    "observation.state": torch.from_numpy(obs["agent_pos"])[None],
                    "observation.environment_state": torch.from_numpy(obs["environment_state"])[None],
                    "task": [env.task_description],
                }
                action = policy.select_action(batch)
                obs, *_ = env.step(np.asarray(action[0]))
        assert "pass --env.verdict_dir" in caplog.text and caplog.text.count("no verdict from the env") == 1
    finally:
        policy.close_logs()
        env.close()
