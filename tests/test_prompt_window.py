"""Prompt windows and saved prompt states: what a span's prompt shows, and what the LM keeps of earlier prompts."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_policy_recent.recent_plugin.infillers.configs import LlamaCppConfig
from lerobot_policy_recent.recent_plugin.infillers.prompt_states import PromptStates
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import build_prompt, patch_grammar
from lerobot_policy_recent.recent_plugin.refactoring.units import Hints, cut_unit
from lerobot_policy_recent.recent_plugin.refactoring.window import dataflow_window

SKILL = '''def clear(env, task, first="cube", second="block", receptacle="bin"):
    """Put two objects into the bin."""
    bin_pos = task.get_object_position(receptacle)
    height = 0.2
    for name, dx in [[first, -0.04], [second, 0.04]]:
        obj_pos = task.get_object_position(name)
        open_gripper(env, task)
        pick(env, task, target_pos=obj_pos)
        drop = [bin_pos[0] + dx, bin_pos[1], bin_pos[2] + height]
        place(env, task, target_pos=drop)
        move(env, task, target_pos=[bin_pos[0], bin_pos[1], bin_pos[2] + height])
'''


def _window(statement: str, *, insertion: bool = False, hint: str | None = None) -> str:
    start = SKILL.index(statement)
    end = start if insertion else SKILL.index("\n", start)
    line_start = SKILL.rfind("\n", 0, start) + 1
    indent = SKILL[line_start:start]
    suffix = SKILL[end:] if not insertion else "\n" + indent + SKILL[end:]
    prefix, suffix = dataflow_window(SKILL[:line_start], indent, SKILL[start:end], suffix, (hint,))
    return prefix + indent + "<FILL>" + suffix


def test_a_span_sees_its_signature_its_blocks_and_what_it_reads():
    shown = _window("pick(env")
    assert shown.startswith('def clear(env, task, first="cube"') and '"""Put two objects into the bin."""' in shown
    assert "for name, dx in" in shown  # the block it sits in
    assert "obj_pos = task.get_object_position(name)" in shown  # what it reads
    assert "bin_pos" not in shown and "open_gripper" not in shown  # nothing it does not read
    assert "place(" not in shown  # and not the next call, which a small model copies


def test_definitions_are_followed_through_other_definitions():
    shown = _window("place(env")
    assert "drop = [bin_pos[0] + dx" in shown and "bin_pos = task.get_object_position(receptacle)" in shown
    assert "height = 0.2" in shown
    assert "obj_pos =" not in shown and "pick(" not in shown


def test_after_the_span_only_readers_of_what_it_assigns():
    shown = _window("drop = [")
    after = shown.split("<FILL>")[1]
    assert "place(env, task, target_pos=drop)" in after and "move(" not in after


def test_an_insertion_sees_the_statement_it_serves():
    shown = _window("pick(env", insertion=True, hint="obj_pos = task.get_object_position(name)")
    assert shown.split("<FILL>")[1].strip() == "pick(env, task, target_pos=obj_pos)"
    assert "obj_pos = task.get_object_position(name)" in shown  # the re-read copies its statement


def test_an_insertion_shows_what_its_own_statements_read_not_what_the_next_one_reads():
    """A sweep's literals read nothing: before it, only the signature and the blocks it sits in."""
    shown = _window("pick(env", insertion=True, hint="push(env, task, start=[0.1, 0.2, 0.8], goal=[0.1, 0.3, 0.8])")
    before, after = shown.split("<FILL>")
    assert "for name, dx in" in before and "obj_pos" not in before and "bin_pos" not in before
    assert after.strip() == "pick(env, task, target_pos=obj_pos)"


def test_code_that_does_not_parse_keeps_the_whole_function():
    prefix, suffix = "def f(env, task):\n    x = (\n", "\n    y = 1\n"
    assert dataflow_window(prefix, "    ", "g(x)", suffix) == (prefix, suffix)


def test_the_window_applies_to_localized_spans_only(ontology):
    hints = Hints(target=ontology.target("UR5e"), original_call="pick(env, task, target_pos=obj_pos)")
    start = SKILL.index("pick(env")
    span_unit = cut_unit(SKILL, start, SKILL.index("\n", start), "api_substitution", hints)
    assert "open_gripper" not in build_prompt(span_unit, 10, "dataflow").prefix
    assert "open_gripper" in build_prompt(span_unit, 10, "function").prefix
    rewrite = cut_unit(SKILL, start, SKILL.index("\n", start), "localized_repair", hints)
    assert build_prompt(rewrite, 10, "dataflow").prefix == build_prompt(rewrite, 10, "function").prefix
    with pytest.raises(ValueError, match="unknown prompt window"):
        build_prompt(span_unit, 10, "tiny")
    with pytest.raises(ValueError, match="prompt_window"):
        LlamaCppConfig(prompt_window="tiny")


def test_saved_states_are_an_lru_bounded_in_bytes_without_dominated_entries():
    states = PromptStates(budget_bytes=100)
    states.save(np.array([1, 2, 3]), "a", 40)
    states.save(np.array([1, 2, 3, 4, 5]), "b", 40)  # extends [1, 2, 3]: that one can never be the better start
    assert len(states) == 1 and states.bytes == 40
    states.save(np.array([7, 8]), "c", 40)
    found, shared = states.best(np.array([1, 2, 3, 4, 9]))
    assert (found.data, shared) == ("b", 4)
    states.save(np.array([9, 9]), "d", 40)  # over budget: the least recently used ([7, 8]) goes
    assert len(states) == 2 and states.best(np.array([7, 8])) is None
    states.save(np.array([5]), "e", 101)  # larger than the whole budget: not kept
    assert len(states) == 2


def test_a_reactive_repair_shows_the_window_and_writes_at_most_its_statements_lines(ontology):
    """A repair's prompt is windowed like a revision's: what the recomputation reads before the span,
    the retried statement (and nothing further) after it. Its first attempt writes the recomputation's lines, each beginning
    as that line does (what it assigns); the values are the LM's."""
    from llama_cpp import LlamaGrammar

    recompute = (
        "bin_pos = task.get_object_position(receptacle)\ndrop = [bin_pos[0] + dx, bin_pos[1], bin_pos[2] + height]"
    )
    hints = Hints(
        target=ontology.target("UR5e"),
        original_call="place(env, task, target_pos=drop)",
        substitute_call=recompute,
        reason="read bin_pos, drop again before retrying",
    )
    start = SKILL.index("place(env")
    repair = build_prompt(cut_unit(SKILL, start, start, "reactive_repair", hints), 10, "dataflow")
    assert "height = 0.2" in repair.prefix and "open_gripper" not in repair.prefix
    # the retried call alone, not the later readers of bin_pos
    assert [line.strip() for line in repair.suffix.strip().splitlines()] == ["place(env, task, target_pos=drop)"]
    assert repair.grammar.splitlines()[0] == 'root ::= "bin_pos = " rest "\\n" [ ]* "drop = " rest "\\n"?'
    LlamaGrammar.from_string(repair.grammar, verbose=False)
    assert patch_grammar('größe = task.get_object_position("Würfel")').startswith('root ::= "größe = " rest')
    assert patch_grammar("if held:\n    drop = bin_pos") is None  # not one line per statement: lines, at most
    assert patch_grammar("drop = [\n    bin_pos[0],\n    bin_pos[1]]") is None
    whole = build_prompt(cut_unit(SKILL, start, start, "reactive_repair", hints), 10, "function")
    assert "open_gripper" in whole.prefix


UNROLLED = """def two(env, task, first="cube", second="block"):
    name = first
    obj_pos = task.get_object_position(name)
    pick(env, task, target_pos=obj_pos)
    place(env, task, target_pos=obj_pos)
    name = second
    obj_pos = task.get_object_position(name)
    pick(env, task, target_pos=obj_pos)
"""


def test_the_readers_after_a_span_end_where_its_names_are_assigned_again():
    """An unrolled loop's next item reads ``obj_pos`` too, but a value assigned anew, not the span's."""
    start = UNROLLED.index("obj_pos = task")
    end = UNROLLED.index("\n", start)
    _, suffix = dataflow_window(UNROLLED[: start - 4], "    ", UNROLLED[start:end], UNROLLED[end:])
    assert suffix.strip().splitlines() == [
        "pick(env, task, target_pos=obj_pos)",
        "    place(env, task, target_pos=obj_pos)",
    ]


def test_only_the_latest_definition_before_the_span_is_shown():
    """An unrolled loop's earlier item assigned ``name`` and ``obj_pos`` too; the span reads the latest."""
    start = UNROLLED.rindex("pick(env")
    end = UNROLLED.index("\n", start)
    prefix, _ = dataflow_window(UNROLLED[: start - 4], "    ", UNROLLED[start:end], UNROLLED[end:])
    assert [line.strip() for line in prefix.splitlines()[1:]] == [
        "name = second",
        "obj_pos = task.get_object_position(name)",
    ]
    branched = (
        'def lift(env, task, obj="cube"):\n'
        "    pos = task.get_object_position(obj)\n"
        "    if pos[2] < 0.9:\n"
        "        pos = [pos[0], pos[1], 0.9]\n"
        "    pick(env, task, target_pos=pos)\n"
    )
    start = branched.index("pick(env")
    prefix, _ = dataflow_window(branched[: start - 4], "    ", "pick(env, task, target_pos=pos)", "\n")
    assert "pos = task.get_object_position(obj)" in prefix  # a definition in a block may not have run
    counted = 'def lift(env, task, obj="cube"):\n    height = 0.1\n    height += 0.05\n    move(env, task, z=height)\n'
    start = counted.index("move(env")
    prefix, _ = dataflow_window(counted[: start - 4], "    ", "move(env, task, z=height)", "\n")
    assert "height = 0.1" in prefix and "height += 0.05" in prefix  # an augmented assignment reads the old value


def test_the_logs_record_the_prompt_the_model_was_sent(ontology):
    """An LM call's record holds the backend's own prompt (its window), not a re-rendering of the unit."""
    from lerobot_policy_recent.recent_plugin.grounding.attempts import infill_until_valid
    from lerobot_policy_recent.recent_plugin.grounding.gate import Verdict
    from lerobot_policy_recent.recent_plugin.infillers.base import Completion

    start = SKILL.index("pick(env")
    hints = Hints(target=ontology.target("UR5e"), original_call="pick(env, task, target_pos=obj_pos)")
    unit = cut_unit(SKILL, start, SKILL.index("\n", start), "api_substitution", hints)
    sent = build_prompt(unit, 10, "dataflow").shown()

    class Sent:
        name, model = "scripted", "scripted"

        def infill(self, unit):
            return Completion("ur5_grasp_at(env, task, grasp_pos=obj_pos)", 9, 0.01, prompt=sent)

        def count_tokens(self, text):
            return len(text.split())

    calls = []
    infill_until_valid(
        Sent(),
        lambda feedback, attempt: unit,
        lambda u, text: (Verdict(True), text),
        kind="ground",
        max_retries=0,
        calls=calls,
    )
    assert calls[0].prompt == sent and "open_gripper" not in calls[0].prompt
