"""Refactoring units, FIM prompts and grounding with the rule backend and the real 1.5B GGUF."""

from __future__ import annotations

import pytest
from doubles import ScriptedInfiller, sweep_unit

from lerobot_policy_recent.ontology.diagnosis import diagnose
from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import build_prompt
from lerobot_policy_recent.recent_plugin.refactoring.units import names_in_scope, unit_from_conflict
from lerobot_policy_recent.skills.repository import load_skill

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
    unit = unit_from_conflict(put_in_bin.code, conflict, ontology.target("UR5e"))
    assert unit.span == 'pick(env, task, target_pos=obj_pos, approach_axis="z")'
    assert unit.prefix.startswith("def put_in_bin(") and unit.prefix.endswith("open_gripper(env, task)\n")
    assert unit.suffix.startswith("\n    drop_pos =")
    assert unit.indent == "    " and unit.span_type == "api_substitution"
    assert unit.prefix + unit.indent + unit.span + unit.suffix == put_in_bin.code


def test_prompt_renders_hints_as_comments_before_the_span(ontology, put_in_bin):
    conflict = diagnose(ontology, put_in_bin.name, put_in_bin.code, "UR5e").conflicts[1]
    prompt = build_prompt(unit_from_conflict(put_in_bin.code, conflict, ontology.target("UR5e")), span_tokens=20)
    comments = prompt.prefix.splitlines()[-6:-1]
    assert all(line.startswith("    # ") for line in comments)
    assert "map target_pos -> grasp_pos; drop approach_axis" in prompt.prefix
    assert prompt.prefix.splitlines()[-2] == "    # Call exactly: ur5_grasp_at(env, task, grasp_pos=obj_pos)"
    assert prompt.prefix.endswith("\n    ") and prompt.stop[0] == "\n"
    # a statement, never a comment: the call the ontology determined, its arguments free (the 1.5B
    # otherwise wrote `task.move_to_position([...])`, a method of the task, on every traced move)
    assert prompt.grammar == 'root ::= "ur5_grasp_at(" [^\\n]* "\\n"?'
    assert "pick(env, task" not in prompt.suffix  # the span itself is not in the prompt's code


def test_a_call_written_over_several_lines_is_one_comment_line_and_a_one_line_span(ontology):
    """wipe_area's push spans seven lines: its "Was:" hint once left six of them as bare code in the prompt."""

    wipe = load_skill("wipe_area")
    conflict = diagnose(ontology, wipe.name, wipe.code, "Sawyer").conflicts[0]
    prompt = build_prompt(unit_from_conflict(wipe.code, conflict, ontology.target("Sawyer")), span_tokens=60)
    hints = prompt.prefix.splitlines()[4:-1]
    assert hints and all(line.startswith("        # ") for line in hints)
    assert hints[1] == (
        "        # Was: push(env, task, start_pos=[area_pos[0] - 0.09, area_pos[1] + dy, area_pos[2] + 0.02], "
        'target_pos=[area_pos[0] + 0.09, area_pos[1] + dy, area_pos[2] + 0.02], approach_axis="z")'
    )
    assert prompt.stop[0] == "\n"  # the substitute is one call, however the original was written


PICK_BETWEEN = '''def pick_between(env, task, obj="cube", other="block"):
    """Pick what lies halfway between two objects: a point no one object places."""
    a = task.get_object_position(obj)
    b = task.get_object_position(other)
    mid = [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, a[2]]
    pick(env, task, target_pos=mid, approach_axis="z")
'''


def test_a_retry_is_held_to_the_ontology_call_with_only_the_placeholders_free(ontology, put_in_bin):
    from llama_cpp import LlamaGrammar

    def prompts(robot: str, index: int):
        conflict = diagnose(ontology, put_in_bin.name, put_in_bin.code, robot).conflicts[index]
        first = build_prompt(unit_from_conflict(put_in_bin.code, conflict, ontology.target(robot)), 20)
        retry = build_prompt(
            unit_from_conflict(put_in_bin.code, conflict, ontology.target(robot), feedback="no", attempt=1), 20
        )
        return first, retry

    first, retry = prompts("UR5e", 1)
    assert first.grammar.startswith('root ::= "ur5_grasp_at(" [^')  # the first attempt's arguments are free
    assert retry.grammar.splitlines()[0] == 'root ::= "ur5_grasp_at(env, task, grasp_pos=obj_pos)" "\\n"'
    # a pick between two objects leaves Sawyer's target_object to the LM: a name, not a position
    conflict = diagnose(ontology, "pick_between", PICK_BETWEEN, "Sawyer").conflicts[0]
    retry = build_prompt(
        unit_from_conflict(PICK_BETWEEN, conflict, ontology.target("Sawyer"), feedback="no", attempt=1), 20
    )
    assert 'root ::= "sawyer_pick(env, task, target_object=" name ", target_pos=mid)"' in retry.grammar
    assert 'name ::= "obj" | "other"' in retry.grammar.splitlines()  # the names in scope, no other
    LlamaGrammar.from_string(retry.grammar, verbose=False)  # valid GBNF


def test_a_run_time_patch_retry_is_held_to_the_statements_its_check_wrote(ontology, put_in_bin):
    """An in-situ sweep's first attempt begins as the check's call does, the rest of the line free;
    its retry may only write the check's call (a new arm's push primitive, which the 1.5B otherwise
    renamed to one the robot lacks)."""
    from llama_cpp import LlamaGrammar

    sweep = "jaco_shove(env, task, begin_xyz=[0.178, 0.069, 0.854], end_xyz=[0.178, -0.056, 0.854])"

    def prompt(attempt: int):
        target, observation = ontology.target("JacoRobotiq85"), "obstacle lies on the release target"
        return build_prompt(sweep_unit(put_in_bin.code, "place(", target, sweep, observation, attempt), 0)

    first = prompt(0).grammar
    assert first.splitlines()[0] == 'root ::= "jaco_shove(" rest "\\n"?'
    LlamaGrammar.from_string(first, verbose=False)
    retry = prompt(1).grammar
    assert retry.splitlines()[0] == f'root ::= "{sweep}" "\\n"'
    LlamaGrammar.from_string(retry, verbose=False)


def test_a_traced_push_is_one_move_per_waypoint_and_its_retry_is_held_to_all_of_them(ontology, rule_infiller):
    from llama_cpp import LlamaGrammar

    wipe, pushing = load_skill("wipe_area"), load_skill("push_to_region")
    grounded = ground_skill(
        wipe, ontology.target("Suction"), ontology, rule_infiller
    )  # the push's positions are list literals
    assert grounded.valid and grounded.generated_tokens == 0
    moves = [line.strip() for line in grounded.code.splitlines() if "move_to_position" in line]
    assert moves == [
        "move_to_position(env, task, pos=[area_pos[0] - 0.09, area_pos[1] + dy, area_pos[2] + 0.02 + 0.1])",
        "move_to_position(env, task, pos=[area_pos[0] - 0.09, area_pos[1] + dy, area_pos[2] + 0.02])",
        "move_to_position(env, task, pos=[area_pos[0] + 0.09, area_pos[1] + dy, area_pos[2] + 0.02])",
        "move_to_position(env, task, pos=[area_pos[0] + 0.09, area_pos[1] + dy, area_pos[2] + 0.02 + 0.1])",
    ]
    conflict = diagnose(ontology, pushing.name, pushing.code, "Robotiq85").conflicts[0]
    unit = unit_from_conflict(pushing.code, conflict, ontology.target("Robotiq85"))  # names: indexed, closed hand first
    assert unit.hints.substitute_call.splitlines() == [
        "close_robotiq85(env, task)",
        "move_to_position(env, task, pos=[start[0], start[1], start[2] + 0.1])",
        "move_to_position(env, task, pos=start)",
        "move_to_position(env, task, pos=goal)",
        "move_to_position(env, task, pos=[goal[0], goal[1], goal[2] + 0.1])",
    ]
    first = build_prompt(unit, span_tokens=30)
    assert (
        first.stop == ("\n\n",) and "# Call exactly: close_robotiq85(env, task); then move_to_position(" in first.prefix
    )
    # lookup drafts: a first attempt writes the later lines at the body's indentation, a held retry as the call has them
    assert first.draft.splitlines() == [
        line if i == 0 else unit.indent + line for i, line in enumerate(unit.hints.substitute_call.splitlines())
    ]
    retry = build_prompt(
        unit_from_conflict(pushing.code, conflict, ontology.target("Robotiq85"), feedback="no", attempt=1), 30
    )
    assert retry.draft == unit.hints.substitute_call
    assert retry.grammar.splitlines()[0].startswith('root ::= "close_robotiq85(env, task)\\nmove_to_position(')
    LlamaGrammar.from_string(retry.grammar, verbose=False)


def test_a_retry_the_grammar_holds_to_one_text_is_answered_without_decoding(ontology, put_in_bin, llama_infiller):
    """A retry of a call with no placeholder admits one text: llama.cpp returns it without running the
    model, as decoding it would have written it (the same text; the count within the final line break)."""
    from lerobot_policy_recent.recent_plugin.infillers.llamacpp import QWEN

    def unit(robot: str, attempt: int):
        conflict = diagnose(ontology, put_in_bin.name, put_in_bin.code, robot).conflicts[1]
        return unit_from_conflict(
            put_in_bin.code, conflict, ontology.target(robot), feedback="no" if attempt else None, attempt=attempt
        )

    assert build_prompt(unit("UR5e", 0), 20).forced is None  # a first attempt is free FIM
    between = diagnose(ontology, "pick_between", PICK_BETWEEN, "Sawyer").conflicts[0]
    open_retry = unit_from_conflict(PICK_BETWEEN, between, ontology.target("Sawyer"), feedback="no", attempt=1)
    assert build_prompt(open_retry, 20).forced is None  # the object's name is left to the LM
    retry = unit("UR5e", 1)
    prompt = build_prompt(retry, llama_infiller.count_tokens(retry.span), llama_infiller.prompt_window)
    assert prompt.forced == "ur5_grasp_at(env, task, grasp_pos=obj_pos)\n"
    answered = llama_infiller.infill(retry)
    decoded = llama_infiller.lm.generate(
        QWEN.render(prompt.prefix, prompt.suffix),
        max_tokens=prompt.max_tokens,
        stops=(*prompt.stop, *QWEN.stops),
        gbnf=prompt.grammar,
    )
    assert answered.forced and answered.text == decoded.text == "ur5_grasp_at(env, task, grasp_pos=obj_pos)"
    assert decoded.generated_tokens - answered.generated_tokens in (0, 1)
    assert answered.prompt_tokens == 0 and answered.prompt == prompt.shown()


def test_rule_backend_grounds_with_zero_tokens(ontology, put_in_bin, rule_infiller):
    grounded = ground_skill(put_in_bin, ontology.target("UR5e"), ontology, rule_infiller)
    assert grounded.valid
    changed = {
        line for line in grounded.diff().splitlines() if line[:1] in "+-" and not line.startswith(("+++", "---"))
    }
    assert changed == RULE_DIFF_LINES
    assert grounded.generated_tokens == 0 and grounded.go == 0.0


def test_rejected_span_is_retried_with_feedback_then_accepted(ontology, put_in_bin):
    infiller = ScriptedInfiller(
        [
            "ur5_release_at(env, task, place_pos=drop_pos)",
            "ur5_grasp_at(env, task, grasp_pos=obj_pos, approach_distance=0.1)",  # hallucinated kwarg
            "ur5_grasp_at(env, task, grasp_pos=obj_pos)",
            "ur5_open_gripper(env, task)",  # hallucinated API name
            "ur5_release_at(env, task, place_pos=drop_pos)",  # a valid call, but not the substitute
            "",  # empty continuation
            "open_ur5_ee(env, task)",
        ]
    )
    grounded = ground_skill(put_in_bin, ontology.target("UR5e"), ontology, infiller, max_retries=3)
    assert grounded.valid
    assert [c.category for c in grounded.calls] == [
        None,
        "hallucinated_kwarg",
        None,
        "hallucinated_name",
        "hallucinated_api",
        "empty_continuation",
        None,
    ]
    assert "substitutes open_ur5_ee()" in grounded.calls[4].message
    assert grounded.retries == 4 and grounded.generated_tokens == 49 and grounded.go == 49.0


def test_the_point_a_pick_grasps_at_names_the_object_a_pick_that_takes_both_expects(
    ontology, put_in_bin, rule_infiller
):
    """Sawyer's pick takes the object's name beside its position; ``obj_pos`` was read for ``obj``, so
    the name is ``obj`` and the ontology renders it. A point placed by two objects names neither."""
    conflict = diagnose(ontology, put_in_bin.name, put_in_bin.code, "Sawyer").conflicts[1]
    assert conflict.span_type == "parameter_binding" and not conflict.unfilled
    grounded = ground_skill(put_in_bin, ontology.target("Sawyer"), ontology, rule_infiller)
    assert grounded.valid and "sawyer_pick(env, task, target_object=obj, target_pos=obj_pos)" in grounded.code
    between = diagnose(ontology, "pick_between", PICK_BETWEEN, "Sawyer").conflicts[0]
    unit = unit_from_conflict(PICK_BETWEEN, between, ontology.target("Sawyer"))
    assert unit.span_type == "interface_rewiring" and unit.hints.unfilled == ("target_object",)
    assert unit.hints.substitute_call == "sawyer_pick(env, task, target_object=<object_name>, target_pos=mid)"
    facts = "\n".join(unit.hints.facts)  # what the decision is and what it can be made from, not the answer
    assert "target_object is the object the hand grasps" in facts
    assert "obj (an object name, a parameter: 'cube' by default)" in facts and "other (an object name" in facts


def test_a_name_based_place_onto_a_point_api_releases_at_the_receptacles_own_position(ontology, rule_infiller):
    """The Franka Hand's place(obj_name=base) onto UR5e's release point: the point is base's own
    position (a release point at an object's own position puts the load onto it), so the ontology renders it
    and no LM is asked; a pose-taking URScript gets that position in its base frame, with the held
    rotation. Before, the point was left to the LM, which got it right 13 times in 30 at first."""

    tower = load_skill("stack_tower")
    conflict = diagnose(ontology, tower.name, tower.code, "UR5e", source="FrankaHand").conflicts[2]
    assert conflict.unfilled == () and "obj_name" not in conflict.dropped
    grounded = ground_skill(tower, ontology.target("UR5e"), ontology, rule_infiller)
    assert grounded.valid, grounded.verdict
    assert "ur5_release_at(env, task, place_pos=task.get_object_position(base))" in grounded.code
    assert "ur5_release_at(env, task, place_pos=task.get_object_position(middle))" in grounded.code
    script = ground_skill(tower, ontology.target("UR5eScript"), ontology, rule_infiller)
    assert script.valid, script.verdict
    assert "task.to_frame(task.get_object_position(base), 'base') + quat_to_rotvec(" in script.code


def test_same_role_literals_are_translated(ontology, rule_infiller):
    """approach_axis='z' (Panda) and pointing_to='down' (Robotiq85) share a role; the value is mapped too.
    The 2F-85 picks by name: ``obj_pos`` holds exactly the position read for ``obj``, so that name is it."""

    grounded = ground_skill(load_skill("pick_and_lift"), ontology.target("Robotiq85"), ontology, rule_infiller)
    assert grounded.valid
    assert "pick_robotiq85(env, task, obj_name=obj, pointing_to='down')" in grounded.code


def test_unrecoverable_after_retry_limit(ontology, put_in_bin):
    grounded = ground_skill(
        put_in_bin, ontology.target("UR5e"), ontology, ScriptedInfiller(["import os"] * 3), max_retries=2
    )
    assert not grounded.valid
    assert str(grounded.verdict.category) == "non_executable" and "unrecoverable" in grounded.verdict.message
    assert len(grounded.calls) == 3


def test_a_call_the_robot_cannot_make_in_any_form_is_refused_without_asking_the_lm(ontology):
    """IIWAKRL has no place: every answer could only call what it lacks, so none is asked for."""
    from lerobot_policy_recent.recent_plugin.failures import is_refusal

    asked = ScriptedInfiller([])  # any call would pop from an empty list
    grounded = ground_skill(load_skill("stack_tower"), ontology.target("IIWAKRL"), ontology, asked)
    assert not grounded.valid and grounded.calls == [] and asked.units == []
    assert str(grounded.verdict.category) == "unsupported"
    assert grounded.verdict.message.startswith("refused: line 5: IIWAKRL has no primitive with the effects of place")
    assert is_refusal(grounded.verdict.category, grounded.verdict.message)


def test_llamacpp_tokenizes_fim_markers_as_special_tokens(llama_infiller):
    ids = llama_infiller.lm.tokenize("<|fim_prefix|><|fim_suffix|><|fim_middle|>", True)
    assert ids == [151659, 151661, 151660]


@pytest.mark.parametrize("robot", ["UR5e", "Sawyer", "Robotiq85", "Suction"])
def test_real_lm_grounds_put_in_bin(ontology, put_in_bin, llama_infiller, robot):
    """The 1.5B GGUF fills each conflicting span; the result passes validation and only those lines change."""
    grounded = ground_skill(put_in_bin, ontology.target(robot), ontology, llama_infiller)
    assert grounded.valid, [c.message for c in grounded.calls]
    removed = [line for line in grounded.diff().splitlines() if line.startswith("-") and not line.startswith("---")]
    assert len(removed) == 3
    assert all(c.generated_tokens > 0 and c.seconds > 0 for c in grounded.calls)
    assert 0 < grounded.generated_tokens < grounded.skill_tokens
    for conflict in grounded.diagnosis.conflicts:
        assert f"{conflict.substitute.name}(env, task" in grounded.code


@pytest.mark.slow
def test_small_model_runs_the_same_pipeline(ontology, put_in_bin):
    """The 0.5B is part of the model-size ablation; it may fail to ground, but must never run unvalidated code."""
    from lerobot_policy_recent.recent_plugin.infillers import make_infiller

    grounded = ground_skill(
        put_in_bin, ontology.target("UR5e"), ontology, make_infiller("llamacpp", "qwen2.5-coder-0.5b")
    )
    assert grounded.valid or grounded.verdict.category is not None


def test_fast_path_renders_decided_spans_and_asks_the_lm_only_for_the_rest(ontology, put_in_bin):
    """put_in_bin and a Franka Hand stack_tower onto UR5e: the ontology decides every span. A pick at
    the point halfway between two objects onto Sawyer, whose pick also takes the object's name: no
    one object places the point, so the name is the LM's, and only that span is asked."""
    from dataclasses import replace

    from lerobot_policy_recent.recent_plugin.infillers.fast_path import FastPathInfiller

    lm = ScriptedInfiller(["sawyer_pick(env, task, target_object=obj, target_pos=mid)"])
    fast = FastPathInfiller(lm)
    ur5e = ground_skill(put_in_bin, ontology.target("UR5e"), ontology, fast)
    tower = ground_skill(load_skill("stack_tower"), ontology.target("UR5e"), ontology, fast)
    assert ur5e.valid and tower.valid and not lm.units and ur5e.generated_tokens == tower.generated_tokens == 0
    assert sum(c.rendered for c in ur5e.calls + tower.calls) == 8  # three spans of put_in_bin, five of the tower
    between = replace(put_in_bin, name="pick_between", entry="pick_between", code=PICK_BETWEEN)
    sawyer = ground_skill(between, ontology.target("Sawyer"), ontology, fast)
    assert sawyer.valid and [u.span_type for u in lm.units] == ["interface_rewiring"]
    assert "sawyer_pick(env, task, target_object=obj, target_pos=mid)" in sawyer.code


@pytest.mark.slow
def test_the_real_lm_names_what_no_one_object_places(ontology, llama_infiller, put_in_bin):
    """What the ontology cannot decide, the 1.5B does: the object Sawyer's pick is told to expect at a
    point halfway between two objects. The hint states what the name is and the names in scope;
    the answer is one of them (a retry is held to them)."""
    from dataclasses import replace

    from lerobot_policy_recent.recent_plugin.infillers.fast_path import FastPathInfiller

    between = replace(put_in_bin, name="pick_between", entry="pick_between", code=PICK_BETWEEN)
    grounded = ground_skill(between, ontology.target("Sawyer"), ontology, FastPathInfiller(llama_infiller))
    assert grounded.valid, grounded.verdict
    assert [c.rendered for c in grounded.calls if c.accepted] == [False]
    (line,) = [line.strip() for line in grounded.code.splitlines() if "sawyer_pick(" in line]
    assert line in (f"sawyer_pick(env, task, target_object={name}, target_pos=mid)" for name in ("obj", "other"))


def test_a_span_that_changes_a_carried_over_argument_is_rejected(ontology):
    """The 1.5B once repeated the suffix's approach height where the press height belongs."""

    press = load_skill("press_button")
    lift = "ur5_move_to(env, task, target_pos=[cap_pos[0], cap_pos[1], cap_pos[2] + 0.08], timeout_s=3.0)"
    press_down = lift.replace("+ 0.08", "+ 0.010")
    approach = lift.replace("3.0", "6.0")
    texts = [lift, lift, press_down, approach, "close_ur5_ee(env, task)"]  # last line first
    infiller = ScriptedInfiller(texts)
    grounded = ground_skill(press, ontology.target("UR5e"), ontology, infiller)
    assert grounded.valid
    assert [c.accepted for c in grounded.calls] == [True, False, True, True, True]
    assert "keep target_pos=[cap_pos[0], cap_pos[1], cap_pos[2] + 0.01]" in grounded.calls[1].message
    assert grounded.code.count("+ 0.08]") == 2 and grounded.code.count("+ 0.01") == 1


def test_a_multiline_span_without_the_substitute_is_rejected(ontology):
    """In a loop body a span's later lines are indented; it is still parsed and held to the substitute."""

    wipe = load_skill("wipe_area")
    moves_instead = (  # valid code in place, but no push: the span alone did not parse, so went unchecked
        "start = [area_pos[0] - 0.09, area_pos[1] + dy, area_pos[2] + 0.02]\n"
        "        sawyer_move_to(env, task, target_pos=start)"
    )
    push = (
        "sawyer_push(env, task, from_pos=[area_pos[0] - 0.09, area_pos[1] + dy, area_pos[2] + 0.02], "
        "to_pos=[area_pos[0] + 0.09, area_pos[1] + dy, area_pos[2] + 0.02])"
    )
    grounded = ground_skill(wipe, ontology.target("Sawyer"), ontology, ScriptedInfiller([moves_instead, push]))
    assert grounded.valid and [c.accepted for c in grounded.calls] == [False, True]
    assert "substitutes sawyer_push() here, but the span calls ['sawyer_move_to']" in grounded.calls[0].message


def test_a_traced_path_that_drops_a_waypoints_offset_is_rejected(ontology):
    """The 1.5B wrote `pos=start` for the first move of a traced sweep: the hand went straight down onto
    the block's path instead of above it. Each move is held to its own waypoint, in order."""
    from lerobot_policy_recent.recent_plugin.grounding.grounder import _check_span

    pushing = load_skill("push_to_region")
    conflict = diagnose(ontology, pushing.name, pushing.code, "Suction").conflicts[0]
    unit = unit_from_conflict(pushing.code, conflict, ontology.target("Suction"))
    right = unit.hints.substitute_call.replace("\n", "\n" + unit.indent)
    assert _check_span(right, unit) is None
    wrong = right.replace("pos=[start[0], start[1], start[2] + 0.1]", "pos=start, pointing_to='down'", 1)
    verdict = _check_span(wrong, unit)
    assert verdict is not None and not verdict.ok and "keep pos=[start[0], start[1], start[2] + 0.1]" in verdict.message


def test_a_span_that_adds_a_statement_or_a_return_is_rejected(ontology):
    """The 1.5B once appended ``return hole_pos`` to a place it was asked for; a span holds the call."""
    from lerobot_policy_recent.recent_plugin.grounding.grounder import _check_span

    peg = load_skill("insert_peg")
    place = next(c for c in diagnose(ontology, peg.name, peg.code, "UR5e").conflicts if c.original == "place")
    unit = unit_from_conflict(peg.code, place, ontology.target("UR5e"))
    call = unit.hints.substitute_call
    assert _check_span(call, unit) is None
    for added, words in (
        (f"{call}\nreturn hole_pos", "return hole_pos"),
        (f"{call}\nclose_ur5_ee(env, task)", "after the 1"),
    ):
        verdict = _check_span(added.replace("\n", "\n" + unit.indent), unit)
        assert verdict is not None and not verdict.ok and words in verdict.message


def test_every_skill_on_every_robot_from_either_source_api_cuts_its_units(ontology):
    """A placeholder may belong to a preparatory call rather than the substitute (a skill read against
    the other source API leaves such ones): the hint's facts skip it."""
    from lerobot_policy_recent.skills.repository import list_skills, load_skill

    for name in list_skills():
        skill = load_skill(name)
        for robot in ontology.apis:
            for source in ("Panda", "FrankaHand"):
                for conflict in diagnose(ontology, skill.name, skill.code, robot, source=source).conflicts:
                    unit_from_conflict(skill.code, conflict, ontology.target(robot))


def test_a_skills_grounding_samples_alike_whatever_was_grounded_before_it():
    """A skill grounded in an earlier episode of the worker is served from the cache, so it must be
    the grounding this episode would make itself. Its calls draw with seeds from the episode, the
    skill and their place in its grounding, not their place in the episode (after other skills in
    another task: other seeds, another record)."""
    from lerobot_policy_recent.recent_plugin.grounding.budget import BudgetedInfiller, CallBudget
    from lerobot_policy_recent.recent_plugin.infillers.base import Completion

    class Sampling:
        name, model, samples = "sampling", "fixed", True

        def __init__(self):
            self.seeds: list[int] = []

        def infill(self, unit, *, temperature=0.0, seed=0):
            self.seeds.append(seed)
            return Completion("pass", generated_tokens=1, seconds=0.0)

    def stack_seeds(calls_before: int) -> list[int]:
        lm, budget = Sampling(), CallBudget(0)
        earlier = BudgetedInfiller(lm, budget, temperature=0.2, seed=3, scope="grounding put_in_bin")
        for _ in range(calls_before):
            earlier.infill(None)
        del lm.seeds[:]
        stack = BudgetedInfiller(lm, budget, temperature=0.2, seed=3, scope="grounding stack")
        stack.infill(None)
        stack.infill(None)
        return lm.seeds

    assert stack_seeds(0) == stack_seeds(4) and len(set(stack_seeds(0))) == 2
    other_episode = Sampling()
    BudgetedInfiller(other_episode, CallBudget(0), temperature=0.2, seed=7, scope="grounding stack").infill(None)
    assert other_episode.seeds[0] != stack_seeds(0)[0]  # episode seeds stay real repetitions


def test_a_first_answer_is_held_to_as_many_lines_as_the_ontology_asks_and_told_why_a_name_is_the_one(ontology):
    """The 1.5B went on past a cup's detach into the suffix's calls, copied `target_pos` from a hint
    written as a call, and put a block "on" the block it held: the span's grammar stops at the
    statements asked for, and the hints state where the names come from."""
    from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import hint_lines, statement_lines

    stack = load_skill("stack")
    cup = unit_from_conflict(
        stack.code, diagnose(ontology, "stack", stack.code, "Suction").conflicts[-1], ontology.target("Suction")
    )
    assert build_prompt(cup, 32).grammar == statement_lines(2)
    reason = hint_lines(cup)[0]
    assert "after move_gripper_to over what place's target_pos names" in reason and "=target_pos" not in reason
    jaw = unit_from_conflict(
        stack.code, diagnose(ontology, "stack", stack.code, "Robotiq85").conflicts[-1], ontology.target("Robotiq85")
    )
    assert (
        "obj_name is what the held object is put on or into: target, whose position places place's target_pos"
        in hint_lines(jaw)
    )


def _drop_near_side():
    """The README's own skill: a Panda put_in_bin whose drop point two objects place (examples/skills)."""
    from pathlib import Path

    from lerobot_policy_recent.skills.repository import serve_skill

    return serve_skill("put_in_bin", Path(__file__).parents[1] / "examples" / "skills")


PLACE_ON_HELD = "place_robotiq85(env, task, obj_name=obj, pointing_to='down')"


def test_a_receptacle_that_is_the_held_object_is_rejected_at_its_span_and_the_retry_may_not_name_it(ontology):
    """Where no one object places the drop point, the name a place takes is the LM's. The span is judged
    while the grasp before it is still to be grounded, so the whole program's role check could not
    see what the hand holds: it passed ``obj_name=obj`` there, then blamed the grasp's span three
    times and failed the skill. The diagnosis knows it from the source's data flow: the hint says it,
    the span is rejected with the reason, and the answers' grammar leaves the held object out, in
    quotes too (a scripted LM, which ignores grammars, writes it)."""
    from llama_cpp import LlamaGrammar

    from lerobot_policy_recent.recent_plugin.infillers.fast_path import FastPathInfiller

    skill = _drop_near_side()
    conflict = diagnose(ontology, skill.name, skill.code, "Robotiq85").conflicts[-1]
    assert conflict.unfilled == ("obj_name",) and conflict.held == ("obj", 6)
    first = build_prompt(unit_from_conflict(skill.code, conflict, ontology.target("Robotiq85")), 20)
    assert "    # The hand holds obj here (taken at line 6)\n" in first.prefix
    retry = unit_from_conflict(skill.code, conflict, ontology.target("Robotiq85"), feedback="no", attempt=1)
    for grammar in (first.grammar, build_prompt(retry, 20).grammar):  # the first answer is held as the retry is
        assert (
            grammar.splitlines()[0]
            == 'root ::= "place_robotiq85(env, task, obj_name=" name-0 ", pointing_to=\'down\')" "\\n"'
        )
        assert 'name-0 ::= "receptacle"' in grammar.splitlines()
        LlamaGrammar.from_string(grammar, verbose=False)

    lm = ScriptedInfiller(
        [PLACE_ON_HELD, PLACE_ON_HELD.replace("=obj", '="cube"'), PLACE_ON_HELD.replace("obj,", "receptacle,")]
    )
    grounded = ground_skill(skill, ontology.target("Robotiq85"), ontology, FastPathInfiller(lm))
    assert grounded.valid, grounded.verdict
    assert [c.accepted for c in grounded.calls if not c.rendered] == [False, False, True]
    held = (
        "place_robotiq85's obj_name is what the held object is put on or into, but obj is the object held since line 6"
    )
    assert [c.message for c in grounded.calls if not c.rendered][:2] == [
        f"obj_name=obj: {held}",
        f"obj_name='cube': {held}",
    ]
    assert "place_robotiq85(env, task, obj_name=receptacle, pointing_to='down')" in grounded.code


def test_a_cups_move_over_the_receptacle_may_not_name_the_held_object_either(ontology):
    """On the cup the place is a preparatory move over the receptacle, then the detach: the move's
    object is the open decision, and the same exclusion holds it."""
    from lerobot_policy_recent.recent_plugin.infillers.fast_path import FastPathInfiller

    skill = _drop_near_side()
    lm = ScriptedInfiller(
        ["move_gripper_to(env, task, obj_name=obj)\ndetach_vacuum_handle(env, task)"]
        + ["move_gripper_to(env, task, obj_name=receptacle)\ndetach_vacuum_handle(env, task)"]
    )
    grounded = ground_skill(skill, ontology.target("Suction"), ontology, FastPathInfiller(lm))
    assert grounded.valid, grounded.verdict
    rejected = next(c for c in grounded.calls if not c.accepted)
    assert rejected.message.startswith("obj_name=obj: move_gripper_to's obj_name is what the hand moves over")
    conflict = grounded.diagnosis.conflicts[-1]
    retry = build_prompt(
        unit_from_conflict(skill.code, conflict, ontology.target("Suction"), feedback="no", attempt=1), 20
    )
    assert retry.grammar.splitlines()[0].startswith('root ::= "move_gripper_to(env, task, obj_name=" name-0 ")')
    assert 'name-0 ::= "receptacle"' in retry.grammar.splitlines()
    assert "move_gripper_to(env, task, obj_name=receptacle)" in grounded.code


DROP_NEAR_THE_BIN = '''def drop_near_the_bin(env, task, obj="cube"):
    """Drop obj into the bin, a little towards where it came from."""
    obj_pos = task.get_object_position(obj)
    bin_pos = task.get_object_position("bin")
    open_gripper(env, task)
    pick(env, task, target_pos=obj_pos, approach_axis="z")
    near_side = [bin_pos[0] + 0.1 * (obj_pos[0] - bin_pos[0]), bin_pos[1], bin_pos[2] + 0.1]
    place(env, task, target_pos=near_side, approach_axis="z")
'''


def test_a_name_in_quotes_is_one_the_skill_knows(ontology):
    """Offered any quoted name, the 1.5B wrote ``obj_name="cube1"`` for the receptacle, and it
    validated. A quoted name is one the skill writes for a task query (``"bin"`` here), and the
    answer's grammar offers exactly the names in scope less the held object's."""
    from dataclasses import replace

    from lerobot_policy_recent.recent_plugin.infillers.fast_path import FastPathInfiller

    skill = replace(_drop_near_side(), name="drop_near_the_bin", entry="drop_near_the_bin", code=DROP_NEAR_THE_BIN)
    conflict = diagnose(ontology, skill.name, skill.code, "Robotiq85").conflicts[-1]
    unit = unit_from_conflict(skill.code, conflict, ontology.target("Robotiq85"))
    assert names_in_scope(unit) == ("obj", '"bin"')
    assert 'name-0 ::= "\\"bin\\""' in build_prompt(unit, 20).grammar.splitlines()
    lm = ScriptedInfiller([PLACE_ON_HELD.replace("=obj", '="cube1"'), PLACE_ON_HELD.replace("=obj", '="bin"')])
    grounded = ground_skill(skill, ontology.target("Robotiq85"), ontology, FastPathInfiller(lm))
    assert grounded.valid, grounded.verdict
    rejected, accepted = [c for c in grounded.calls if not c.rendered]
    assert rejected.message == "obj_name='cube1': no object of that name is in scope (names here: obj, \"bin\")"
    assert accepted.accepted and "place_robotiq85(env, task, obj_name=\"bin\", pointing_to='down')" in grounded.code
    # the check reads the call's holes whatever else it leaves open
    from lerobot_policy_recent.recent_plugin.grounding.grounder import _check_span

    call = "place_robotiq85(env, task, obj_name=<object_name>, pointing_to=<str>)"
    unit = replace(unit, hints=replace(unit.hints, substitute_call=call))
    verdict = _check_span("place_robotiq85(env, task, obj_name='cube1', pointing_to='down')", unit)
    assert verdict is not None and "no object of that name is in scope" in verdict.message


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["Robotiq85", "Suction"])
def test_the_real_lm_grounds_the_readme_skill_onto_a_robot_that_places_by_name(ontology, llama_infiller, robot):
    """The README's main job: the 1.5B names the receptacle (``receptacle``) at its first answer, whose
    grammar holds it to the names in scope its role allows (unheld, it wrote the held object, ``obj``)."""
    from lerobot_policy_recent.recent_plugin.infillers.fast_path import FastPathInfiller

    grounded = ground_skill(_drop_near_side(), ontology.target(robot), ontology, FastPathInfiller(llama_infiller))
    assert grounded.valid, grounded.verdict
    assert "obj_name=receptacle" in grounded.code and [c.accepted for c in grounded.calls if not c.rendered] == [True]


def test_a_skill_that_declares_where_the_held_object_ends_has_its_receptacle_decided_by_the_ontology(ontology):
    """The same skill with ``placements: [{object: obj, over: receptacle}]``: the hand holds obj at the
    place, and obj ends over receptacle, so the place by name takes receptacle, with no LM. A point
    that one object's position places keeps naming that object, whatever the metadata says."""
    from dataclasses import replace

    from lerobot_policy_recent.ontology.skill_code import PositionNames
    from lerobot_policy_recent.recent_plugin.infillers.fast_path import FastPathInfiller
    from lerobot_policy_recent.skills.repository import Placement

    declared = replace(_drop_near_side(), placements=(Placement("obj", "receptacle"),))
    assert declared.placed_over == {"obj": "receptacle"}
    lm = ScriptedInfiller([])
    for robot, call in (
        ("Robotiq85", "place_robotiq85(env, task, obj_name=receptacle"),
        ("Suction", "move_gripper_to(env, task, obj_name=receptacle)"),
    ):
        grounded = ground_skill(declared, ontology.target(robot), ontology, FastPathInfiller(lm))
        assert grounded.valid and call in grounded.code and not lm.units, robot
    conflict = diagnose(ontology, declared.name, declared.code, "Robotiq85", "Panda", declared.placed_over).conflicts[
        -1
    ]
    assert not conflict.unfilled and conflict.by_placements == "target_pos"
    hint = "obj_name is what the held object is put on or into: receptacle, where the skill's placements put obj"
    assert hint in "\n".join(unit_from_conflict(declared.code, conflict, ontology.target("Robotiq85")).hints.facts)
    names = PositionNames({"bin_pos": "receptacle"}, declared={"bin_pos": "obj", "drop": "receptacle"})
    assert names.of("bin_pos") == "receptacle" and names.of("drop") == "receptacle" and names.of("elsewhere") is None


def test_the_rule_backend_declines_an_open_decision_once_and_says_why(ontology, rule_infiller):
    """The rule backend decides nothing the ontology leaves open: one call, no retries of an empty
    answer, and a reason that names the argument and what would decide it."""
    grounded = ground_skill(_drop_near_side(), ontology.target("Robotiq85"), ontology, rule_infiller)
    assert not grounded.valid and len(grounded.calls) == 1 and grounded.calls[0].declined
    assert grounded.verdict.message.startswith("unrecoverable: could not ground 'place' at line 12 after 1 attempt(s);")
    assert "the ontology leaves obj_name of place_robotiq85 open, and the rule backend decides nothing" in (
        grounded.verdict.message
    )
