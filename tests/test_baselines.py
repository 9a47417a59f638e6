"""The baselines (cap, repair, agentless): prompts, how each answers an error, and their accounting.

Scripted completions drive the control flow deterministically in real robosuite episodes; the
real 1.5B writes a cap program in the slow test at the end.
"""

from __future__ import annotations

import pytest
from doubles import ScriptedInfiller

from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.baselines.program_prompt import PROGRAM, STATEMENT
from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.methods import method_named
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import build_prompt
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.robosuite_envs.suites import get_task

UR5E_BODY = """obj_pos = task.get_object_position(obj)
    bin_pos = task.get_object_position(receptacle)
    open_ur5_ee(env, task)
    ur5_grasp_at(env, task, grasp_pos=obj_pos)
    drop_pos = [bin_pos[0], bin_pos[1], bin_pos[2] + 0.1]
    ur5_release_at(env, task, place_pos=drop_pos)"""
PANDA_LINE = "open_gripper(env, task)"  # what a small model copies from the example


def _agent(ontology, method: str, texts: list[str]) -> tuple[RecentAgent, ScriptedInfiller]:
    infiller = ScriptedInfiller(texts)
    return RecentAgent(
        RecentSettings(infiller=RuleConfig(), method=method_named(method)), ontology=ontology, infiller=infiller
    ), infiller


def test_cap_prompt_shows_api_example_and_task_but_not_the_scene(ontology):
    agent, infiller = _agent(ontology, "cap", [UR5E_BODY])
    grounded, _ = agent.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    assert grounded.valid and grounded.calls[0].span_type == PROGRAM
    prefix = infiller.units[0].prefix
    assert "def put_in_bin_panda(env, task" in prefix  # the reference skill as the in-context example
    assert "#   ur5_grasp_at(env, task, grasp_pos: position [m]" in prefix
    assert "# Task: Pick the cube and place it in the bin." in prefix
    assert prefix.rstrip().endswith('"""')  # the span is the body, right after the signature and docstring
    assert "Scene objects" not in prefix and "Workspace" not in prefix


def test_agentless_prompt_adds_descriptions_objects_and_workspace(ontology):
    agent, infiller = _agent(ontology, "agentless", [UR5E_BODY])
    agent.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    prefix = infiller.units[0].prefix
    assert "# Scene objects: cube (box), bin (bin)" in prefix
    assert "# Workspace: x in [-0.40, 0.40] m" in prefix
    assert "  -- " in prefix  # each primitive's description


def test_cap_regenerates_the_whole_program_with_the_error_and_counts_a_repair(ontology):
    wrong = UR5E_BODY.replace("open_ur5_ee(env, task)", PANDA_LINE)
    agent, infiller = _agent(ontology, "cap", [wrong, UR5E_BODY])
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    assert result.success
    grounded = result.grounding.skills[0]
    assert [c.kind for c in grounded.calls] == ["ground", "repair"]
    assert [c.span_type for c in grounded.calls] == [PROGRAM, PROGRAM]
    assert "# Failed before: open_gripper is a Panda primitive" in build_prompt(infiller.units[1], 0).prefix
    # the paper's accounting: GO counts the repair's tokens (the first program is GO-pre), one interruption
    assert result.generated_tokens == 14 and result.skill_tokens == 100 and result.adaptation_tokens == 7
    assert result.go == pytest.approx(7.0) and result.go_pre == pytest.approx(7.0)
    assert result.ei == 1 and result.it == pytest.approx(0.01)


@pytest.mark.parametrize("method", ["repair", "agentless"])
def test_repair_and_agentless_rewrite_only_the_statement_the_error_points_at(ontology, method):
    wrong = UR5E_BODY.replace("open_ur5_ee(env, task)", PANDA_LINE)
    agent, infiller = _agent(ontology, method, [wrong, "open_ur5_ee(env, task)"])
    grounded, _ = agent.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    assert grounded.valid
    assert [c.span_type for c in grounded.calls] == [PROGRAM, STATEMENT]
    assert grounded.calls[1].span == PANDA_LINE and grounded.calls[1].kind == "repair"
    assert "    open_ur5_ee(env, task)\n" in grounded.code and PANDA_LINE not in grounded.code


def test_unsafe_or_empty_output_is_never_accepted(ontology):
    agent, _ = _agent(ontology, "cap", ["import os\n    os.system('true')", "", "__import__('os')"] * 2)
    grounded, _ = agent.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    assert not grounded.valid
    assert [c.category for c in grounded.calls] == ["non_executable", "empty_continuation", "non_executable"]
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0, max_steps=20)  # an invalid program is not cached
    assert result.success is False and result.steps <= 21  # nothing ran: the robot held still


@pytest.mark.parametrize(
    ("method", "repair", "span_type"),
    [
        ("cap", UR5E_BODY, PROGRAM),  # the whole program again, from the current state
        ("repair", "obj_pos = task.get_object_position(obj)", STATEMENT),  # only the failed statement
    ],
)
def test_a_run_time_failure_is_repaired_the_baselines_way(ontology, method, repair, span_type):
    ghost = UR5E_BODY.replace("get_object_position(obj)", 'get_object_position("ghost")')
    agent, infiller = _agent(ontology, method, [ghost, repair])
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    assert result.success
    assert [c.kind for c in result.runtime_calls] == ["repair"]
    assert result.runtime_calls[0].span_type == span_type
    assert "object 'ghost' not found" in infiller.units[1].hints.feedback
    assert [a.kind for a in result.adaptations] == ["repair"] and result.adaptations[0].after
    assert result.ei == 1


@pytest.mark.slow
def test_real_lm_writes_a_cap_program(ontology, llama_infiller):
    agent = RecentAgent(RecentSettings(method=method_named("cap")), ontology=ontology, infiller=llama_infiller)
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    grounded = result.grounding.skills[0]
    assert grounded.calls and grounded.calls[0].kind == "ground" and grounded.calls[0].generated_tokens > 0
    assert result.go_pre > 50.0  # a whole program: far above RECENT's localized edits
