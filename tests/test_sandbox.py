"""Hostile skill code: refused by the gate where a static rule is exact, else stopped by name at run time.

Each span below passed ``validate_program`` and ``security_gate`` before the run-time budget
existed, and then hung the process or allocated gigabytes. Now each is refused before it runs or
fails its segment as ``budget_exceeded``, and the executor stays usable.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest

from lerobot_policy_recent.recent_plugin.executor import SkillExecutor
from lerobot_policy_recent.recent_plugin.failures import FailureCategory
from lerobot_policy_recent.recent_plugin.grounding.gate import security_gate
from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
from lerobot_policy_recent.recent_plugin.sandbox import BudgetExceeded, Meter, SkillBudget, format_problem
from lerobot_policy_recent.robosuite_envs.observation import ObjectState, Observation
from lerobot_policy_recent.robosuite_envs.primitives import api_functions
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession

SKILL = """def put_in_bin(env, task, obj="cube", receptacle="bin"):
    obj_pos = task.get_object_position(obj)
{hostile}
    ur5_grasp_at(env, task, grasp_pos=obj_pos)
"""


def _skill(hostile: str) -> str:
    return SKILL.format(hostile="\n".join("    " + line for line in hostile.strip("\n").splitlines()))


def _obs() -> Observation:
    return Observation(
        eef_pos=np.array([0.0, 0.0, 1.0]),
        eef_quat=np.array([1.0, 0.0, 0.0, 0.0]),
        gripper_opening=0.0,
        objects={"cube": ObjectState(np.array([0.0, -0.1, 0.82]), np.array([0, 0, 0, 1.0]))},
    )


@pytest.fixture
def grounded(ontology, put_in_bin, rule_infiller):
    return ground_skill(put_in_bin, ontology.target("UR5e"), ontology, rule_infiller)


REFUSED = {
    "four nested range loops": (
        "n = 0\nfor a in range(1000):\n    for b in range(1000):\n        for c in range(1000):\n"
        "            for d in range(1000):\n                n = n + 1",
        "nested loops of 1,000,000 iterations",
    ),
    "three-deep comprehension": (
        "grid = [[[a for a in range(1000)] for b in range(1000)] for c in range(1000)]",
        "nested loops of 1,000,000 iterations",
    ),
    "a copy repeated": ("xs = list(obj_pos) * 9999 * 9999", "sequence repetition"),
    "a literal repeated in place": ("xs = [1]\nxs *= [2]", "sequence repetition"),
    "a format width": ("s = '%0999999999d' % 0", "width or precision of 999999999"),
    "a starred format width": ("s = '%*d' % (5, 0)", "'*' width"),
    "a power": ("n = 3 ** 64", "power and shift"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_the_gate_refuses_what_a_static_rule_bounds_and_says_why(case):
    span, reason = REFUSED[case]
    verdict = security_gate(_skill(span), "put_in_bin", api_functions("ur5e"))
    assert not verdict.ok and verdict.category == FailureCategory.NON_EXECUTABLE and reason in verdict.message


def test_helper_functions_and_recursion_are_refused_with_the_reason():
    helper = _skill("x = 1") + "\n\ndef lift(env, task):\n    return 1\n"
    verdict = security_gate(helper, "put_in_bin", api_functions("ur5e"))
    assert not verdict.ok and "helper function 'lift' is not allowed" in verdict.message
    verdict = security_gate(_skill("put_in_bin(env, task)"), "put_in_bin", api_functions("ur5e"))
    assert not verdict.ok and "may not call itself" in verdict.message


STOPPED = {
    "a loop that grows the list it walks": ("xs = [obj]\nfor v in xs:\n    xs += [v]", "without an action"),
    "a list multiplied in place": ("xs = [obj, obj]\nxs *= 9999\nxs *= 9999", "a value of 199,960,002 items"),
    "a number squared 64 times": ("n = 3\nfor i in range(64):\n    n = n * n", "an integer of"),
    "a list doubled in place by slices": (
        "xs = [obj]\nfor i in range(64):\n    xs[0:0] = xs",
        "a value of 1,048,576 items",
    ),
    "a string doubled by formatting": (
        "s = obj\nfor i in range(64):\n    s = '%s%s' % (s, s)",
        "a value of 1,048,576 items",
    ),
    "a list doubled 64 times": ("xs = [obj]\nfor i in range(64):\n    xs = xs + xs", "a value of 1,048,576 items"),
    "a format width from a variable": ("f = '%0999999999d'\ns = f % 0", "a huge string"),
    "a format width with a float": ("f = '%0999999999f'\ns = f % 1.5", "a huge string"),
    "a nested value handed to a primitive": (
        "x = [obj]\nfor i in range(200):\n    x = [x, x]\nur5_move_to(env, task, target_pos=x)",
        "nested over",
    ),
    "a comprehension over variables": (
        "r = list(range(1000))\ngrid = [[[a for a in r] for b in r] for c in r]",
        "without an action",
    ),
    "copies in a comprehension": (
        "r = list(range(1000))\nbig = r + r\ncopies = [list(big) for i in r]",
        "1,000,000 over its run",
    ),
    "a nested value compared": ("x = [obj]\nfor i in range(200):\n    x = [x, x]\nsame = x == [x, x]", "nested over"),
    "a nested tuple hashed": ("t = (obj,)\nfor i in range(200):\n    t = (t, t)\nd = {t: 1}", "nested over"),
    "a nested value formatted": ("x = [obj]\nfor i in range(200):\n    x = [x, x]\ns = '%s' % (x,)", "nested over"),
    "the largest of nested values": ("x = [obj]\nfor i in range(200):\n    x = [x, x]\nm = max(x, [x])", "nested over"),
    "summing lists": ("r = [[obj]]\ns = sum(r, [])", "skill code sums numbers only"),
}


@pytest.mark.parametrize("case", sorted(STOPPED))
def test_code_that_passes_the_gate_is_stopped_by_name_at_run_time(case, grounded):
    span, reason = STOPPED[case]
    code = _skill(span)
    assert security_gate(code, "put_in_bin", api_functions("ur5e")).ok  # nothing static says no
    executor = SkillExecutor(
        replace(grounded, code=code),
        {"obj": "cube"},
        api_functions("ur5e"),
        RobotSession("UR5e", _obs()),
        # only the case about time runs under a short time budget: on a loaded host the others must be
        # stopped by the limit they are about (items, size, nesting), not by the clock first
        budget=SkillBudget(
            step_seconds=0.3 if "without an action" in reason else 60.0,
            max_created_items=10**6 if "over its run" in reason else 2 * 10**7,
        ),
    )
    assert executor.step() is None and executor.failed  # stopped in the hostile segment, before any action
    failure = executor.failure
    assert failure.category == FailureCategory.BUDGET_EXCEEDED and failure.line >= 3 and reason in failure.message


def test_a_skill_within_its_budget_runs_as_before(grounded):
    """Ordinary arithmetic, lists and loops go through the meter and give the same values."""
    code = _skill(
        "lift = [obj_pos[0], obj_pos[1], obj_pos[2] + 0.1]\nwide = lift + [1.0]\n"
        "name = '%s-%d' % (obj, 3)\nfor i in range(3):\n    lift[2] += 0.01\nsquares = [i * i for i in range(4)]"
    )
    executor = SkillExecutor(
        replace(grounded, code=code), {"obj": "cube"}, api_functions("ur5e"), RobotSession("UR5e", _obs())
    )
    assert executor.step() is not None  # the grasp's first action: every statement before it ran
    ns = executor.namespace
    assert ns["lift"] == pytest.approx([0.0, -0.1, 0.95]) and ns["wide"][-1] == 1.0
    assert ns["name"] == "cube-3" and ns["squares"] == [0, 1, 4, 9] and not executor.failed


def test_the_meter_charges_before_it_builds():
    meter = Meter(SkillBudget(max_value_items=1000))
    meter.enter()
    with pytest.raises(BudgetExceeded, match="1,000,000 items"):
        meter.binop("*", [0] * 1000, 1000)  # refused before the list is made
    assert meter.binop("+", "ab", "cd") == "abcd" and meter.created == 4
    assert format_problem("%5.2f and %s") is None and "1001" in format_problem("%1001s")


def test_time_between_actions_is_what_the_skill_spent():
    """The meter counts the skill's own advances, not what the executor does between them (an LM call)."""
    meter = Meter(SkillBudget(step_seconds=0.05))
    meter.new_step()
    meter.enter()
    meter.leave()
    time.sleep(0.1)  # outside the skill: a repair's LM call, say
    meter.enter()
    meter.tick()  # fine: the skill itself has spent almost nothing
    time.sleep(0.06)
    with pytest.raises(BudgetExceeded, match="without an action"):
        meter.tick()
