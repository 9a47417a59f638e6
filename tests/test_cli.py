"""The `recent` command: help on every subcommand, JSON outputs, clear errors."""

from __future__ import annotations

import json

import pytest

from lerobot_policy_recent.scripts.cli import main


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["run"],
        ["ground"],
        ["model"],
        ["model", "fetch"],
        ["model", "list"],
        ["ontology"],
        ["ontology", "diagnose"],
        ["skills"],
        ["skills", "list"],
    ],
)
def test_every_subcommand_has_help(argv, capsys):
    with pytest.raises(SystemExit) as exit_:
        main([*argv, "--help"])
    assert exit_.value.code == 0
    assert "usage: recent" in capsys.readouterr().out


def test_ground_json_has_the_documented_keys(capsys):
    assert main(["ground", "--skill", "put_in_bin", "--robot", "UR5e", "--infiller.type", "rule", "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert {"diff", "go", "generated_tokens", "skill_tokens", "lm_seconds", "retries", "valid"} <= set(record)
    assert record["valid"] and "+    ur5_grasp_at(env, task, grasp_pos=obj_pos)" in record["diff"]


def test_a_skill_that_cannot_be_grounded_says_so_not_that_it_is_compatible(capsys, monkeypatch):
    """Robotiq85 has no push (the paper's API moves and grips only); without tracing its path, a Panda
    skill that pushes does not ground."""
    from lerobot_policy_recent.ontology.builder import Ontology

    monkeypatch.setattr(Ontology, "path_tracers", lambda self, source, primitive, target: [])
    assert main(["ground", "--skill", "push_to_region", "--robot", "Robotiq85", "--infiller.type", "rule"]) == 1
    out = capsys.readouterr().out
    assert "Robotiq85 lacks a primitive the skill needs, so nothing was generated" in out
    assert "directly compatible" not in out
    assert "push -> refused: Robotiq85 has no primitive with the effects of push" in out
    assert "REJECTED (unsupported: refused: line " in out


def test_diagnose_json(capsys):
    assert main(["ontology", "diagnose", "--skill", "put_in_bin", "--robot", "UR5e", "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert [c["original"] for c in record["conflicts"]] == ["open_gripper", "pick", "place"]
    assert {w["kind"] for w in record["warnings"]} == {
        "object_at_target",
        "object_grasped",
        "target_clear",
        "fingers_clear",
        "target_reachable",  # checked on every robot: the world can draw a target out of reach
    }


def test_unknown_names_are_clear_errors(capsys):
    assert main(["ground", "--skill", "juggle", "--robot", "UR5e", "--infiller.type", "rule"]) == 2
    assert "unknown skill 'juggle'; known skills: arrange_in_row, " in capsys.readouterr().err
    assert main(["ontology", "diagnose", "--skill", "put_in_bin", "--robot", "R2D2"]) == 2
    assert "known robots" in capsys.readouterr().err


def test_envs_list_json_counts_the_world(capsys):
    assert main(["envs", "list", "--json"]) == 0
    world = json.loads(capsys.readouterr().out)
    assert world["embodiments"][:5] == ["Panda", "UR5e", "Sawyer", "Robotiq85", "Suction"]
    assert {"Jaco", "Kinova3", "XArm7"} <= set(world["embodiments"])  # arms added by the data path
    assert world["primitives"] >= 40 and world["subtasks"] >= 16
    assert world["suites"] == {"kinematic": 20, "end_effector": 12, "kinematic-v1": 26, "end_effector-v1": 16}
    assert "obstacle" in world["variations"]
    calls = world["calls_per_task"]  # the paper's way of counting (test_skill_code has the rules)
    assert set(calls) == set(world["suites"]) and calls["kinematic"]["max"] >= 50
    assert calls["kinematic"]["mean"] >= 24.6 and calls["end_effector"]["mean"] >= 29  # the paper's length
    split = world["split"]  # the held-out split, as the world issue specifies it
    assert split["seeds"]["test"] == [0, 1, 42, 123, 2024] and split["seeds"]["dev"]
    assert split["test_draw"] == {"kinematic": None, "end_effector": None}  # no test draw before a snapshot
    assert split["kinematic"]["test"] == [] and len(split["kinematic"]["retired_test"]) == 6
    assert not set(split["kinematic"]["test"]) & set(split["kinematic"]["dev"])
    assert len(split["kinematic"]["dev"]) + len(split["kinematic"]["test"]) == world["suites"]["kinematic"]


def test_envs_show_prints_instruction_plan_and_objects(capsys):
    assert main(["envs", "show", "end_effector/cabinet_routine"]) == 0
    out = capsys.readouterr().out
    assert "Put the cube away in the drawer" in out and "5. close_hinged_box" in out and "drawer" in out
    assert main(["envs", "show", "kinematic/nothing"]) == 2
    assert "known tasks: cube_in_bin, kinematic/serve_then_clear" in capsys.readouterr().err
