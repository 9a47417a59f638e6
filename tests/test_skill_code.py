"""The skill-code module: spans are character offsets even where a line holds non-ASCII text
(``ast`` columns are UTF-8 bytes), and segments and data flow come from one place."""

from __future__ import annotations

from lerobot_policy_recent.ontology.skill_code import (
    body_span,
    dependency_indices,
    entry_function,
    recomputed_indices,
    segment_statements,
    statement_span,
)

CODE = (
    "def f(env, task):\n"
    '    """Docstring: Würfel."""\n'
    '    name = "Würfel"; pos = task.get_object_position(name)\n'
    "    goal = [pos[0], pos[1], pos[2] + 0.1]\n"
    '    for n in ["a", "b"]:\n'
    "        pick(env, task, target_pos=goal)\n"
)


def test_spans_count_characters_not_utf8_bytes():
    start, end = body_span(CODE, "f")
    assert CODE[start:end].startswith('name = "Würfel";') and CODE[start:end].endswith("target_pos=goal)")
    start, end = statement_span(CODE, "f", 3)
    assert CODE[start:end] == 'name = "Würfel"'
    start, end = statement_span(CODE, "f", 4)
    assert CODE[start:end] == "goal = [pos[0], pos[1], pos[2] + 0.1]"


def test_segments_unroll_literal_loops_and_data_flow_finds_what_a_call_needs():
    statements = segment_statements(CODE, entry_function(CODE, "f"))
    sources = [source for _, source in statements]
    assert sources == [
        'name = "Würfel"',
        "pos = task.get_object_position(name)",
        "goal = [pos[0], pos[1], pos[2] + 0.1]",
        "n = 'a'",
        "pick(env, task, target_pos=goal)",
        "n = 'b'",
        "pick(env, task, target_pos=goal)",
    ]
    nodes = [node for node, _ in statements]
    # the last pick needs goal, which needs pos (a task query, no primitive), which needs name
    assert dependency_indices(nodes[:-1], nodes[-1], {"pick"}) == [0, 1, 2]
    # run again, only the task query and what derives from it may compute another value; the name stays
    assert recomputed_indices(nodes[:-1], nodes[-1], {"pick"}) == [1, 2]
    # an offset added to a value read anew is added again; one added to a constant is not
    code = (
        "def g(env, task):\n    lift = 0.02\n    lift += 0.01\n    z = task.get_object_position('cube')[2]\n"
        "    z += lift\n    pick(env, task, target_pos=[0, 0, z + lift])\n"
    )
    nodes = [node for node, _ in segment_statements(code, entry_function(code, "g"))]
    assert dependency_indices(nodes[:-1], nodes[-1], {"pick"}) == [0, 1, 2, 3]
    assert recomputed_indices(nodes[:-1], nodes[-1], {"pick"}) == [2, 3]
    # a read the hand now holds the object of is kept (where the tool lay, not where it is carried),
    # and what derives from it alone computes what it holds already
    code = (
        "def h(env, task):\n    tool_pos = task.get_object_position('rake')\n    grip_z = tool_pos[2] + 0.025\n"
        "    obj_pos = task.get_object_position('cube')\n    move(env, task, target_pos=[obj_pos[0], obj_pos[1], grip_z])\n"
    )
    nodes = [node for node, _ in segment_statements(code, entry_function(code, "h"))]
    assert recomputed_indices(nodes[:-1], nodes[-1], {"move"}) == [0, 1, 2]
    assert recomputed_indices(nodes[:-1], nodes[-1], {"move"}, frozenset({"tool_pos"})) == [2]


def test_calls_are_counted_as_the_paper_counts_them():
    """Primitive calls, literal loops unrolled (a list, a range of constants), position reads apart."""
    from lerobot_policy_recent.ontology.skill_code import count_calls

    code = """def skill(env, task, n=3):
    \"\"\"Doc.\"\"\"
    p = task.get_object_position("cube")
    open_gripper(env, task)
    for dy in [-0.1, 0.0, 0.1]:
        push(env, task, start_pos=[p[0], p[1] + dy, p[2]], target_pos=p)
    for _ in range(2):
        q = task.get_object_position("cube")
        move(env, task, target_pos=q)
    for _ in range(n):  # not literal: counted once
        close_gripper(env, task)
    if p[2] > 0.1:
        place(env, task, target_pos=p)
    else:
        pick(env, task, target_pos=p)
    helper(p)
"""
    counted = count_calls(code, "skill", {"open_gripper", "push", "move", "close_gripper", "place", "pick"})
    assert (counted.primitives, counted.position_reads) == (1 + 3 + 2 + 1 + 2, 1 + 2)


def test_a_point_straight_over_an_object_is_told_from_one_beside_it():
    """Where a fist presses (straight over what a position read names) and where it pushes from (beside it)."""
    from lerobot_policy_recent.ontology.skill_code import parse_expression, position_names

    names = position_names(
        "def f(env, task, button='button', cube='cube'):\n"
        "    cap_pos = task.get_object_position(button)\n"
        "    obj_pos = task.get_object_position(cube)\n"
        "    move(env, task, target_pos=[cap_pos[0], cap_pos[1], cap_pos[2] + 0.01])\n"
    )
    over = [
        names.straight_over(parse_expression(text))
        for text in (
            "[cap_pos[0], cap_pos[1], cap_pos[2] + 0.01]",
            "[cap_pos[0] - 0.06, cap_pos[1], cap_pos[2]]",
            "[cap_pos[0], obj_pos[1], obj_pos[2]]",
            "[goal[0], goal[1], 0.9]",
            "cap_pos",
        )
    ]
    assert over == ["button", None, None, None, None]
    assert parse_expression("[1, 2") is None and parse_expression("") is None
