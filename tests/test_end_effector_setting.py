"""The end-effector setting as the paper defines it: the Franka Hand's name-based source API, targets
that take names (the 2F-85's picks and places, the vacuum's attach and detach), and the rewiring
between names and positions, one source call for several target calls where a target needs them."""

from __future__ import annotations

import pytest
from doubles import ScriptedInfiller

from lerobot_policy_recent.ontology.diagnosis import diagnose
from lerobot_policy_recent.ontology.skill_code import named_positions
from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
from lerobot_policy_recent.skills.repository import load_skill


def _conflict(ontology, skill, robot: str, original: str):
    diagnosis = diagnose(ontology, skill.name, skill.code, robot, source=skill.source_embodiment)
    return next(c for c in diagnosis.conflicts if c.original == original)


def _lines(code: str) -> list[str]:
    return [line.strip() for line in code.splitlines()]


def test_a_place_on_the_vacuum_is_a_move_over_the_receptacle_then_a_detach(ontology, rule_infiller):
    """The cup lets go where it is (the paper's ``detach_vacuum_handle(env)``): the ontology puts it
    over the place's receptacle first, with the receptacle's name the place was given."""
    fill = load_skill("fill_box")
    place = _conflict(ontology, fill, "Suction", "place")
    assert place.span_type == "preparatory_step" and place.substitute.name == "detach_vacuum_handle"
    assert place.preparatory_calls() == ["move_gripper_to(obj_name=obj_name)"] and place.dropped == ("pointing_to",)
    grounded = ground_skill(fill, ontology.target("Suction"), ontology, rule_infiller)
    assert grounded.valid and grounded.generated_tokens == 0
    lines = _lines(grounded.code)
    at = lines.index("move_gripper_to(env, task, obj_name=box)")
    assert lines[at + 1] == "detach_vacuum_handle(env, task)"
    assert "attach_vacuum_handle(env, task, handle_name=obj)" in lines


def test_a_handle_grasp_the_cup_has_no_primitive_for_is_traced_on_the_named_handle(ontology, rule_infiller):
    opening = load_skill("open_drawer")
    grounded = ground_skill(opening, ontology.target("Suction"), ontology, rule_infiller)
    assert grounded.valid
    grasp, release = grounded.diagnosis.conflicts
    assert grasp.span_type == release.span_type == "path_tracing"
    assert [step.render() for step in grasp.path] == [
        "deactivate_vacuum()",
        "task.get_object_position(handle_name) + 0.1z",
        "task.get_object_position(handle_name)",
        "activate_vacuum()",
    ]
    assert "move_to_position(env, task, pos=task.get_object_position(drawer))" in _lines(grounded.code)
    # letting go of a handle is only an actuation: that one call, not a move
    assert release.substitute.name == "deactivate_vacuum" and [s.render() for s in release.path] == [
        "deactivate_vacuum()"
    ]


def test_a_hand_closed_only_to_push_is_dropped_on_the_cup_and_a_grip_is_not(ontology, rule_infiller):
    """The Franka Hand closes its fingers to sweep blocks into the pen (nothing opens them again). On
    the cup, switching suction on instead lifted the row's blocks as it pushed: the call is dropped.
    Where the skill opens the hand again (a lid's knob gripped, swung, let go) the close is a grip,
    and stays one; on the 2F-85 the fingers close as they did."""
    sweep = load_skill("sweep_into_pen")
    close = _conflict(ontology, sweep, "Suction", "close_gripper")
    assert close.omitted and close.substitute is None and "has no fingers to close" in close.reason
    grounded = ground_skill(sweep, ontology.target("Suction"), ontology, rule_infiller)
    assert grounded.valid and "activate_vacuum" not in grounded.code and "    pass\n" in grounded.code
    grip = _conflict(ontology, load_skill("open_hinged_box"), "Suction", "close_gripper")
    assert not grip.omitted and grip.substitute.name == "activate_vacuum"
    assert not _conflict(ontology, sweep, "Robotiq85", "close_gripper").omitted

    vacuum = ScriptedInfiller(["activate_vacuum(env, task)"])  # an LM that writes the counterpart anyway
    wrote = ground_skill(sweep, ontology.target("Suction"), ontology, vacuum, max_retries=0)
    assert not wrote.valid and "the ontology drops this call" in wrote.verdict.message


def test_a_press_with_the_fist_keeps_its_depth_on_the_cup(ontology, rule_infiller):
    """The Panda presses the cap with its closed fingertips, 13.7 mm below its grip site, sent 1 cm
    above the cap; the cup's face lies 2.3 mm below its own, so every point straight over the cap
    goes 11.4 mm lower (it stopped 7.7 mm above the cap and pressed nothing). A sweep's points lie
    beside the blocks and keep their height; the 2F-85 closes its fingers and keeps every point."""
    press = load_skill("press_button")
    grounded = ground_skill(press, ontology.target("Suction"), ontology, rule_infiller)
    assert grounded.valid and grounded.generated_tokens == 0
    assert "move_to_position(env, task, pos=[cap_pos[0], cap_pos[1], cap_pos[2] + 0.01 - 0.0114])" in _lines(
        grounded.code
    )
    descent = [c for c in grounded.diagnosis.conflicts if c.original == "move"][1]
    assert "11.4 mm lower" in descent.reason
    sweep = ground_skill(load_skill("sweep_into_pen"), ontology.target("Suction"), ontology, rule_infiller)
    assert "0.0114" not in sweep.code
    fingers = ground_skill(press, ontology.target("Robotiq85"), ontology, rule_infiller)
    assert "0.0114" not in fingers.code


def test_the_2f85_takes_the_franka_hands_calls_by_name_as_renames(ontology, rule_infiller):
    for name in ("fill_box", "open_drawer", "stack_tower", "put_in_drawer"):
        skill = load_skill(name)
        conflicts = diagnose(ontology, skill.name, skill.code, "Robotiq85", source="FrankaHand").conflicts
        assert conflicts and all(c.span_type == "api_substitution" for c in conflicts), name
    grounded = ground_skill(load_skill("stack_tower"), ontology.target("Robotiq85"), ontology, rule_infiller)
    assert grounded.valid and "place_robotiq85(env, task, obj_name=base)" in _lines(grounded.code)


def test_a_name_becomes_a_position_by_the_task_query_in_the_targets_units_and_frame(ontology):
    """A name determines where the object is, and a receptacle's name where a position API lets go:
    at the receptacle's own position, which the controllers read as a release onto it."""
    fill = load_skill("fill_box")
    pick = _conflict(ontology, fill, "UR5e", "pick")
    assert pick.span_type == "parameter_binding" and pick.mapping[0].conversion.apply("obj") == (
        "task.get_object_position(obj)"
    )
    krl = _conflict(ontology, fill, "IIWAKRL", "pick")  # no pick there: moves and gripper calls, in millimetres
    assert krl.span_type == "path_tracing" and krl.path[1].render() == "task.get_object_position(obj_name) + 0.1z"
    assert krl.path[1].conversion.template == "[1000 * v for v in {}]"
    place = _conflict(ontology, fill, "UR5e", "place")
    assert place.span_type == "parameter_binding" and not place.unfilled
    (receptacle,) = (m for m in place.mapping if m.target == "place_pos")
    assert receptacle.source == "obj_name" and receptacle.conversion.apply("box") == "task.get_object_position(box)"


def test_a_panda_call_on_the_franka_hands_api_of_the_same_name_is_a_conflict(ontology, put_in_bin):
    """Both source APIs have a ``pick``: one takes a position, the other a name. The same name is not
    the same interface; the position read from ``obj`` names ``obj``, and the drop point above the bin,
    placed by ``bin_pos`` alone, names the receptacle the name-based place takes."""
    conflicts = diagnose(ontology, put_in_bin.name, put_in_bin.code, "FrankaHand").conflicts
    pick, place = (next(c for c in conflicts if c.original == name) for name in ("pick", "place"))
    assert pick.substitute.name == "pick" and pick.span_type == "parameter_binding"
    assert pick.mapping[0].conversion.apply("obj_pos") == "obj"
    assert place.substitute.name == "place" and place.span_type == "parameter_binding" and not place.unfilled
    (receptacle,) = (m for m in place.mapping if m.target == "obj_name")
    assert receptacle.source == "target_pos" and receptacle.conversion.apply("drop_pos") == "receptacle"


@pytest.mark.parametrize("robot", ["Robotiq85", "Suction", "FrankaHand"])
@pytest.mark.parametrize(
    ("skill", "receptacle"),
    [("put_in_bin", "receptacle"), ("place_on_plate", "target"), ("move_to_region", "region"), ("insert_peg", "hole")],
)
def test_a_drop_point_placed_by_one_object_names_it_for_a_name_based_place(
    ontology, rule_infiller, robot, skill, receptacle
):
    """A derived-position rewiring: the ontology renders the receptacle, the LM is not asked, and the
    held object is never put "on itself" (the place's name is not the pick's)."""
    grounded = ground_skill(load_skill(skill), ontology.target(robot), ontology, rule_infiller)
    assert grounded.valid and grounded.generated_tokens == 0
    places = [line for line in _lines(grounded.code) if f"obj_name={receptacle}" in line]
    assert places and all(("pick" not in line and "attach" not in line) for line in places)


@pytest.mark.parametrize("robot", ["Robotiq85", "Suction", "FrankaHand"])
def test_a_drop_point_beside_the_receptacles_centre_is_traced_not_named(ontology, rule_infiller, robot):
    """clear_into_bin lets go of each object over one corner of the bin (``bin_pos[0] + dx``). A place
    by name lets go over the bin's centre: the four objects ended in one pile in the middle (0/4 on
    each name-based hand, and valid). The place is traced with the robot's moves at the corner."""
    grounded = ground_skill(load_skill("clear_into_bin"), ontology.target(robot), ontology, rule_infiller)
    assert grounded.valid and grounded.generated_tokens == 0
    lines = _lines(grounded.code)
    assert not [line for line in lines if "obj_name=receptacle" in line]
    corner = [line for line in lines if "bin_pos[0] + dx, bin_pos[1] + dy, bin_pos[2] + 0.005]" in line]
    assert corner and all(line.startswith("move_to_position(") for line in corner)
    (place,) = (c for c in grounded.diagnosis.conflicts if c.original == "place")
    assert place.span_type == "path_tracing" and "lets go beside receptacle's centre" in place.reason


def test_a_point_is_beside_its_object_only_where_an_offset_moves_it_off_the_centre():
    from lerobot_policy_recent.ontology.skill_code import position_names

    names = position_names(
        "def skill(env, task, bin='bin'):\n"
        "    bin_pos = task.get_object_position(bin)\n"
        "    drop = [bin_pos[0], bin_pos[1], bin_pos[2] + 0.1]\n"
        "    for dx in [-0.04, 0.04]:\n"
        "        corner = [bin_pos[0] + dx, bin_pos[1], bin_pos[2] + 0.05]\n"
    )
    assert [names.beside(e) for e in ("drop", "corner", "bin_pos", "[bin_pos[0], bin_pos[1] - 0.06, 0.9]")] == [
        None,
        "bin",
        None,
        "bin",
    ]
    assert names.beside("[bin_pos[0], bin_pos[1], 0.9]") is None and names.beside(None) is None


@pytest.mark.slow
def test_clear_into_bin_on_the_franka_hand_puts_one_object_in_each_corner(panda_agent):
    """The traced corner places run: the four objects end in the bin, none on another."""
    from lerobot_policy_recent.recent_plugin.episode import run_episode
    from lerobot_policy_recent.robosuite_envs.splits import DEV_SEEDS

    result = run_episode(panda_agent, "kinematic/clear_counter", "FrankaHand", seed=DEV_SEEDS[0])
    assert result.success, result.failures


def test_a_point_names_an_object_only_where_that_object_alone_places_it():
    from lerobot_policy_recent.ontology.skill_code import position_names

    code = """def skill(env, task, obj="cube", bin="bin"):
    obj_pos = task.get_object_position(obj)
    bin_pos = task.get_object_position(bin)
    drop = [bin_pos[0], bin_pos[1], bin_pos[2] + 0.1]
    between = [(obj_pos[0] + bin_pos[0]) / 2, bin_pos[1], 0.2]
    queried = [bin_pos[0], bin_pos[1], task.get_object_position(obj)[2]]
    for dx in [-0.04, 0.04]:
        corner = [bin_pos[0] + dx, bin_pos[1], bin_pos[2] + 0.05]
"""
    names = position_names(code)
    assert names.variables == {"obj_pos": "obj", "bin_pos": "bin", "drop": "bin", "corner": "bin"}
    assert names.of("[bin_pos[0], bin_pos[1], obj_pos[2] + 0.15]") == "bin"  # the height may come from another
    assert names.of("[obj_pos[0], bin_pos[1], 0.1]") is None  # two objects place it
    assert names.of("[bin_pos[0] + offset, bin_pos[1], 0.1]") is None  # a variable of unknown origin


def test_a_position_names_its_object_only_where_the_code_read_it_from_one():
    code = """def skill(env, task, obj="cube", other="block"):
    obj_pos = task.get_object_position(obj)
    lid = task.get_object_position("lid")
    raised = task.get_object_position(other)
    raised[2] = raised[2] + 0.1
    again = task.get_object_position(obj)
    again = [0.0, 0.0, 0.9]
    target = other
    moved = task.get_object_position(target)
    for name in [obj, other]:
        each = task.get_object_position(name)
"""
    assert named_positions(code) == {"obj_pos": "obj", "lid": "'lid'", "each": "name"}


@pytest.mark.parametrize("robot", ["Suction", pytest.param("Robotiq85", marks=pytest.mark.slow)])
def test_a_franka_hand_skill_grounded_by_the_ontology_alone_fills_the_box(panda_agent, robot):
    """The one-to-many rewiring executes: on the cup the place is a move over the box and a detach."""
    from lerobot_policy_recent.recent_plugin.episode import run_episode
    from lerobot_policy_recent.robosuite_envs.splits import DEV_SEEDS

    result = run_episode(panda_agent, "end_effector/fill_open_box", robot, seed=DEV_SEEDS[0])
    assert result.success, result.failures
    (fill,) = result.grounding.skills
    assert fill.valid and fill.generated_tokens == 0


@pytest.mark.parametrize(
    ("robot", "opening"),
    [("Robotiq85", "open_robotiq85"), ("Suction", "deactivate_vacuum"), ("FrankaHand", "open_gripper")],
)
def test_a_tool_put_back_where_it_stood_is_traced_with_the_hands_moves(ontology, rule_infiller, robot, opening):
    """drag_with_tool's last place lets go of the rake at the rake's own earlier point: no object is
    there for a place by name (before, the name-based place was told to put the rake on itself, and
    no grounding validated). The place's path is traced with the hand's moves and its opening."""
    skill = load_skill("drag_with_tool")
    place = diagnose(ontology, skill.name, skill.code, robot).conflicts[-1]
    assert place.span_type == "path_tracing" and "puts tool back at its own earlier point" in place.reason
    grounded = ground_skill(skill, ontology.target(robot), ontology, rule_infiller)
    assert grounded.valid, grounded.verdict
    back = "move_to_position(env, task, pos=[tool_pos[0], tool_pos[1], grip_z + 0.004 + 0.05])"
    assert f"    {opening}(env, task)\n    {back}\n" in grounded.code
