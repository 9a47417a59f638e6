"""Refactoring units, FIM prompts and grounding with the rule backend and the real 1.5B GGUF."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from ontology.diagnosis import diagnose
from recent_plugin.grounding.fim_prompt import build_prompt
from recent_plugin.grounding.grounder import ground_skill
from recent_plugin.grounding.units import unit_from_conflict
from recent_plugin.infillers.base import Completion

RULE_DIFF_LINES = {
    "-    open_gripper(env, task)",
    "+    open_ur5_ee(env, task)",
    '-    pick(env, task, target_pos=obj_pos, approach_axis="z")',
    "+    ur5_grasp_at(env, task, grasp_pos=obj_pos)",
    '-    place(env, task, target_pos=drop_pos, approach_axis="z")',
    "+    ur5_release_at(env, task, place_pos=drop_pos)",
}


def test_unit_cuts_exactly_the_span_with_function_window(ontology, put_in_bin):
    conflict = diagnose(ontology, put_in_bin.name, put_in_bin.code, "UR5e").conflicts[1]
    unit = unit_from_conflict(put_in_bin.code, conflict, "UR5e")
    assert unit.span == 'pick(env, task, target_pos=obj_pos, approach_axis="z")'
    assert unit.prefix.startswith("def put_in_bin(") and unit.prefix.endswith("open_gripper(env, task)\n")
    assert unit.suffix.startswith("\n    drop_pos =")
    assert unit.indent == "    " and unit.span_type == "api_substitution"
    assert unit.prefix + unit.indent + unit.span + unit.suffix == put_in_bin.code


def test_prompt_renders_hints_as_comments_before_the_span(ontology, put_in_bin):
    conflict = diagnose(ontology, put_in_bin.name, put_in_bin.code, "UR5e").conflicts[1]
    prompt = build_prompt(unit_from_conflict(put_in_bin.code, conflict, "UR5e"), span_tokens=20)
    comments = prompt.prefix.splitlines()[-6:-1]
    assert all(line.startswith("    # ") for line in comments)
    assert "map target_pos -> grasp_pos; drop approach_axis" in prompt.prefix
    assert "ur5_grasp_at(env, task, grasp_pos=<position>)" in prompt.prefix
    assert prompt.prefix.endswith("\n    ") and prompt.stop == ("\n",)
    assert "pick(env, task" not in prompt.suffix  # the span itself is not in the prompt's code


def test_rule_backend_grounds_with_zero_tokens(ontology, put_in_bin, rule_infiller):
    grounded = ground_skill(put_in_bin, "UR5e", ontology, rule_infiller)
    assert grounded.valid
    changed = {line for line in grounded.diff().splitlines() if line[:1] in "+-" and not line.startswith(("+++", "---"))}
    assert changed == RULE_DIFF_LINES
    assert grounded.generated_tokens == 0 and grounded.go == 0.0


@dataclass
class ScriptedInfiller:
    """Replays fixed completions: exercises the retry path deterministically (the LM path is tested below)."""

    texts: list[str]
    name: str = "scripted"
    model: str = "fixed"

    def infill(self, unit):
        return Completion(self.texts.pop(0), generated_tokens=7, seconds=0.01)

    def count_tokens(self, text):
        return 100


def test_rejected_span_is_retried_with_feedback_then_accepted(ontology, put_in_bin):
    infiller = ScriptedInfiller(
        [
            "ur5_release_at(env, task, place_pos=drop_pos)",
            "ur5_grasp_at(env, task, grasp_pos=obj_pos, approach_distance=0.1)",  # hallucinated kwarg
            "ur5_grasp_at(env, task, grasp_pos=obj_pos)",
            "ur5_open_gripper(env, task)",  # hallucinated API name
            "",  # empty continuation
            "open_ur5_ee(env, task)",
        ]
    )
    grounded = ground_skill(put_in_bin, "UR5e", ontology, infiller, max_retries=2)
    assert grounded.valid
    assert [c.category for c in grounded.calls] == [None, "hallucinated_kwarg", None, "hallucinated_name", "empty_continuation", None]
    assert grounded.retries == 3 and grounded.generated_tokens == 42 and grounded.go == 42.0


def test_unrecoverable_after_retry_limit(ontology, put_in_bin):
    grounded = ground_skill(put_in_bin, "UR5e", ontology, ScriptedInfiller(["import os"] * 3), max_retries=2)
    assert not grounded.valid
    assert str(grounded.verdict.category) == "non_executable" and "unrecoverable" in grounded.verdict.message
    assert len(grounded.calls) == 3


def test_llamacpp_tokenizes_fim_markers_as_special_tokens(llama_infiller):
    ids = llama_infiller.llm.tokenize(b"<|fim_prefix|><|fim_suffix|><|fim_middle|>", add_bos=False, special=True)
    assert ids == [151659, 151661, 151660]


def test_real_lm_grounds_put_in_bin_for_ur5e(ontology, put_in_bin, llama_infiller):
    """The 1.5B GGUF fills each conflicting span; the result passes validation and only those lines change."""
    grounded = ground_skill(put_in_bin, "UR5e", ontology, llama_infiller)
    assert grounded.valid, [c.message for c in grounded.calls]
    removed = [line for line in grounded.diff().splitlines() if line.startswith("-") and not line.startswith("---")]
    assert len(removed) == 3
    assert all(c.generated_tokens > 0 and c.seconds > 0 for c in grounded.calls)
    assert 0 < grounded.generated_tokens < grounded.skill_tokens
    for name in ("open_ur5_ee(", "ur5_grasp_at(", "ur5_release_at("):
        assert name in grounded.code


@pytest.mark.slow
def test_small_model_runs_the_same_pipeline(ontology, put_in_bin):
    """The 0.5B is part of the model-size ablation; it may fail to ground, but must never run unvalidated code."""
    from recent_plugin.infillers import make_infiller

    grounded = ground_skill(put_in_bin, "UR5e", ontology, make_infiller("llamacpp", "qwen2.5-coder-0.5b"))
    assert grounded.valid or grounded.verdict.category is not None
