"""Generated code is untrusted: the AST policy admits only the target robot's API."""

from __future__ import annotations

import pytest

from lerobot_policy_recent.recent_plugin.failures import FailureCategory as F
from lerobot_policy_recent.recent_plugin.grounding.gate import security_gate, validate_program

GOOD = """def put_in_bin(env, task, obj="cube", receptacle="bin"):
    obj_pos = task.get_object_position(obj)
    bin_pos = task.get_object_position(receptacle)
    open_ur5_ee(env, task)
    ur5_grasp_at(env, task, grasp_pos=obj_pos, timeout_s=5.0)
    drop_pos = [bin_pos[0], bin_pos[1], bin_pos[2] + 0.1]
    for attempt in range(1):
        ur5_release_at(env, task, place_pos=drop_pos)
"""


def _body(*lines: str) -> str:
    return "def put_in_bin(env, task):\n" + "".join(f"    {line}\n" for line in lines)


HOSTILE = [
    (_body("import os"), F.NON_EXECUTABLE),
    (_body("from subprocess import run"), F.NON_EXECUTABLE),
    ("import os\n" + _body("pass"), F.NON_EXECUTABLE),
    (_body("x = env.__class__.__subclasses__()"), F.NON_EXECUTABLE),
    (_body("x = env._session"), F.NON_EXECUTABLE),
    (_body("open('/etc/passwd')"), F.NON_EXECUTABLE),
    (_body("eval('1+1')"), F.NON_EXECUTABLE),
    (_body("exec('x=1')"), F.NON_EXECUTABLE),
    (_body("getattr(env, 'obs')"), F.NON_EXECUTABLE),
    (_body("globals()['x'] = 1"), F.NON_EXECUTABLE),
    (_body("while True:", "    pass"), F.NON_EXECUTABLE),
    (_body("for i in range(10**9):", "    pass"), F.NON_EXECUTABLE),
    (_body("x = [[0 for a in range(9999)] for b in range(9999)]"), F.NON_EXECUTABLE),  # a comprehension loops too
    (_body("x = list(range(9999))"), F.NON_EXECUTABLE),
    (_body("x = [v for v in task.get_object_names()]"), F.NON_EXECUTABLE),
    (_body("x = 'a' * 100000"), F.NON_EXECUTABLE),
    (_body("x = [0] * 100000"), F.NON_EXECUTABLE),
    (_body("x = 2 ** 4096"), F.NON_EXECUTABLE),
    (_body("x = env.obs.objects"), F.HALLUCINATED_API),
    (_body("env.step([0]*7)"), F.HALLUCINATED_API),
    (_body("pick(env, task, target_pos=[0, 0, 1])"), F.HALLUCINATED_API),
    (_body("ur5_grasp_at(env, task, grasp_pos=[0, 0, 1], approach_distance=0.1)"), F.HALLUCINATED_KWARG),
    (_body("ur5_grasp_at(env, task)"), F.HALLUCINATED_KWARG),
    (_body("ur5_grasp_at(env, task, [0, 0, 1])"), F.HALLUCINATED_KWARG),
    (_body("ur5_grasp_at(env, task, grasp_pos=[0, 1])"), F.HALLUCINATED_KWARG),
    (_body("open_ur5_ee(env, task, velocity='fast')"), F.HALLUCINATED_KWARG),
    (_body("ur5_grasp_at(env, task, grasp_pos=ball_position)"), F.HALLUCINATED_NAME),
    (_body("ur5_open_gripper(env, task)"), F.HALLUCINATED_NAME),
    (_body("ur5_grasp_at(env, task, grasp_pos=[0, 0, 1]"), F.NON_EXECUTABLE),
    (_body("f = lambda: 1"), F.NON_EXECUTABLE),
    (_body("def inner():", "    pass"), F.NON_EXECUTABLE),
    (_body("g = ur5_grasp_at", "g(env, task, grasp_pos=[0, 0, 1])"), F.NON_EXECUTABLE),
    (_body("try:", "    pass", "except Exception:", "    pass"), F.NON_EXECUTABLE),
    # what the 1.5B once wrote in place of Sawyer's push: valid Python that rebinds the robot handles
    (
        _body("for dy in [0.0, 0.1]:", "    env, task, start_pos = [0, dy, 1],", "    return env, task"),
        F.NON_EXECUTABLE,
    ),
    (_body("task = None"), F.NON_EXECUTABLE),
    ("", F.EMPTY_CONTINUATION),
    ("def other(env, task):\n    pass\n", F.HALLUCINATED_NAME),
]


# Safe code with a wrong interface: it passes the security gate and fails when it runs, with Python's error.
INTERFACE_ONLY = {
    _body("pick(env, task, target_pos=[0, 0, 1])"),
    _body("ur5_grasp_at(env, task, grasp_pos=[0, 0, 1], approach_distance=0.1)"),
    _body("ur5_grasp_at(env, task)"),
    _body("ur5_grasp_at(env, task, [0, 0, 1])"),
    _body("ur5_grasp_at(env, task, grasp_pos=[0, 1])"),
    _body("open_ur5_ee(env, task, velocity='fast')"),
    _body("ur5_grasp_at(env, task, grasp_pos=ball_position)"),
    _body("ur5_open_gripper(env, task)"),
}


@pytest.mark.parametrize(("code", "category"), HOSTILE, ids=[f"hostile{i}" for i in range(len(HOSTILE))])
def test_the_security_gate_blocks_everything_unsafe_and_lets_wrong_interfaces_run(ontology, code, category):
    verdict = security_gate(code, "put_in_bin", ontology.api("UR5e").names())
    if code in INTERFACE_ONLY:
        assert verdict.ok, verdict.message  # it fails at run time instead (test_baselines)
    else:
        assert not verdict.ok and verdict.category == category, verdict.message


def test_a_verdict_lists_every_violation_at_once(ontology):
    code = _body("open_gripper(env, task)", "ur5_grasp_at(env, task, grasp_pos=ball)", "x = env.sim")
    verdict = validate_program(code, ontology.api("UR5e"), "put_in_bin", ontology.apis)
    assert verdict.category == F.HALLUCINATED_API and verdict.line == 2  # the first one leads
    assert verdict.message.startswith("3 problems:")
    assert "open_gripper is a Panda primitive" in verdict.message and "'ball' is not defined" in verdict.message
    assert "line 4: attribute access .sim" in verdict.message


def test_grounded_program_is_accepted(ontology):
    verdict = validate_program(GOOD, ontology.api("UR5e"), "put_in_bin", ontology.apis)
    assert verdict.ok, verdict.message


@pytest.mark.parametrize(("code", "category"), HOSTILE, ids=[f"hostile{i}" for i in range(len(HOSTILE))])
def test_hostile_or_broken_code_is_rejected_before_execution(ontology, code, category):
    verdict = validate_program(code, ontology.api("UR5e"), "put_in_bin", ontology.apis)
    assert not verdict.ok
    assert verdict.category == category, verdict.message


def test_a_position_where_an_object_name_belongs_names_the_candidates(ontology):
    """The rejection is the retry's cue: it lists the variables that hold object names."""
    code = GOOD.replace("open_ur5_ee(env, task)", "sawyer_open_gripper(env, task)").replace(
        "ur5_grasp_at(env, task, grasp_pos=obj_pos, timeout_s=5.0)",
        "sawyer_pick(env, task, target_object=obj_pos, target_pos=obj_pos)",
    )
    verdict = validate_program(code.split("    drop_pos")[0], ontology.api("Sawyer"), "put_in_bin", ontology.apis)
    assert verdict.category == F.HALLUCINATED_KWARG
    assert verdict.message.endswith("expects an object name, but obj_pos holds a position; names here: obj, receptacle")


def test_a_receptacle_that_is_the_held_object_is_rejected_with_the_role(ontology):
    """A name-based place of the object the hand holds puts it "on itself": valid by name and
    keyword, wrong by role. The move a cup's detach needs is held to the same rule."""
    placed = """def put_in_bin(env, task, obj="cube", receptacle="bin"):
    pick_robotiq85(env, task, obj_name=obj)
    place_robotiq85(env, task, obj_name={place})
"""
    wrong = validate_program(placed.format(place="obj"), ontology.api("Robotiq85"), "put_in_bin")
    assert not wrong.ok and wrong.category == F.HALLUCINATED_KWARG and wrong.line == 3
    assert "what the held object is put on or into" in wrong.message and "held since line 2" in wrong.message
    assert validate_program(placed.format(place="receptacle"), ontology.api("Robotiq85"), "put_in_bin").ok
    cup = """def put_in_bin(env, task, obj="cube", receptacle="bin"):
    attach_vacuum_handle(env, task, handle_name=obj)
    move_gripper_to(env, task, obj_name=obj)
    detach_vacuum_handle(env, task)
    move_gripper_to(env, task, obj_name=obj)
"""
    verdict = validate_program(cup, ontology.api("Suction"), "put_in_bin")
    assert not verdict.ok and verdict.line == 3  # after the detach, the cup holds nothing: line 5 is fine


def test_a_franka_hand_pick_by_name_traced_in_millimetres_validates(ontology, rule_infiller):
    """KRL has no pick: the Franka Hand's pick(obj_name=obj) is traced as LIN moves to the object's
    point in mm, ``[1000 * v for v in task.get_object_position(obj)]``. A loop over the fixed-size
    point a position query returns is bounded, as one over a frame query's is."""
    from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
    from lerobot_policy_recent.skills.repository import load_skill

    grounded = ground_skill(load_skill("put_in_drawer"), ontology.target("IIWAKRL"), ontology, rule_infiller)
    assert grounded.valid, grounded.verdict
    assert "krl_lin(env, task, xyz_mm=[1000 * v for v in task.get_object_position(obj)])" in grounded.code
