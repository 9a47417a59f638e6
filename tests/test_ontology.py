"""The ontology decides conflicts without an LM: spans, substitutes and parameter mappings."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
import yaml

from lerobot_policy_recent.ontology.builder import EmbodimentSource, build_ontology, default_embodiment_sources
from lerobot_policy_recent.ontology.diagnosis import diagnose
from lerobot_policy_recent.ontology.mjcf import read_gripper
from lerobot_policy_recent.ontology.specs import SpecError, load_api_spec
from lerobot_policy_recent.robosuite_envs.primitives.binding import bind_primitives

EXPECTED_UR5E = [
    (5, "open_gripper(env, task)", "open_ur5_ee", {}, ()),
    (
        6,
        'pick(env, task, target_pos=obj_pos, approach_axis="z")',
        "ur5_grasp_at",
        {"target_pos": "grasp_pos"},
        ("approach_axis",),
    ),
    (
        8,
        'place(env, task, target_pos=drop_pos, approach_axis="z")',
        "ur5_release_at",
        {"target_pos": "place_pos"},
        ("approach_axis",),
    ),
]


def test_diagnosis_of_put_in_bin_for_ur5e_is_exact(ontology, put_in_bin):
    result = diagnose(ontology, put_in_bin.name, put_in_bin.code, "UR5e")
    got = [
        (
            c.span.line,
            c.span.text(put_in_bin.code),
            c.substitute.name,
            {m.source: m.target for m in c.mapping},
            c.dropped,
        )
        for c in result.conflicts
    ]
    assert got == EXPECTED_UR5E
    assert all(c.span_type == "api_substitution" for c in result.conflicts)


def test_suction_substitutes_follow_the_paper(ontology):
    """open_gripper -> deactivate_vacuum and close_gripper -> activate_vacuum, derived from effects alone."""
    assert [p.name for p in ontology.substitutes("Panda", "open_gripper", "Suction")] == ["deactivate_vacuum"]
    assert [p.name for p in ontology.substitutes("Panda", "close_gripper", "Suction")] == ["activate_vacuum"]
    assert [p.name for p in ontology.substitutes("Panda", "pick", "Suction")] == ["attach_vacuum_handle"]


def test_source_robot_has_no_conflicts(ontology, put_in_bin):
    assert diagnose(ontology, put_in_bin.name, put_in_bin.code, "Panda").compatible


def test_substitution_relations_come_from_effects(ontology):
    assert [p.name for p in ontology.substitutes("Panda", "close_gripper", "UR5e")] == ["close_ur5_ee"]
    assert [p.name for p in ontology.substitutes("UR5e", "ur5_move_to", "Panda")] == ["move"]
    assert ontology.substitutes("Panda", "pick", "Panda") == []


def test_a_push_on_a_robot_without_one_is_traced_with_its_cartesian_moves(ontology):
    """The end-effector APIs only move and grip: a push becomes the Panda push's path, one move per waypoint."""
    from lerobot_policy_recent.skills.repository import load_skill

    pushing = load_skill("push_to_region")
    assert [p.name for p in ontology.path_tracers("Panda", "push", "Robotiq85")] == ["move_to_position"]
    assert ontology.path_tracers("Panda", "push", "UR5e") == []  # it has a push of its own
    robotiq = diagnose(ontology, pushing.name, pushing.code, "Robotiq85").conflicts[0]
    assert robotiq.span_type == "path_tracing" and robotiq.substitute.name == "move_to_position"
    assert [(s.source, s.offset) for s in robotiq.path] == [
        ("start_pos", (0.0, 0.0, 0.1)),
        ("start_pos", (0.0, 0.0, 0.0)),
        ("target_pos", (0.0, 0.0, 0.0)),
        ("target_pos", (0.0, 0.0, 0.1)),
    ]
    assert robotiq.preparatory == ("close_robotiq85",)  # the push's closed hand, decidable before execution
    suction = diagnose(ontology, pushing.name, pushing.code, "Suction").conflicts[0]
    assert suction.span_type == "path_tracing" and suction.preparatory == ()  # a vacuum needs a flat face to engage


def test_gripper_mechanism_is_inferred_from_mjcf(ontology, tmp_path):
    assert {robot: g.mechanism for robot, g in ontology.grippers.items()} == {
        "Panda": "parallel_jaw",
        "UR5e": "parallel_jaw",
        "Sawyer": "parallel_jaw",
        "Robotiq85": "parallel_jaw",
        "Suction": "suction",
        "FrankaHand": "parallel_jaw",
        "Jaco": "multi_finger",  # three fingers, three actuators
        "JacoRobotiq85": "parallel_jaw",
        "Kinova3": "parallel_jaw",
        "XArm7": "parallel_jaw",
        "XArm7Robotiq85": "parallel_jaw",
        "IIWA": "parallel_jaw",
        "UR5eScript": "parallel_jaw",
        "IIWAKRL": "parallel_jaw",
    }
    cup = tmp_path / "cup.xml"
    cup.write_text(
        '<mujoco><worldbody><body name="cup"/></worldbody><actuator><adhesion body="cup" gain="5"/></actuator></mujoco>'
    )
    assert read_gripper(str(cup)).mechanism == "suction"


def test_turtle_round_trips(ontology):
    import pyoxigraph as ox

    store = ox.Store()
    store.load(ontology.to_turtle().encode(), format=ox.RdfFormat.TURTLE)
    assert len(store) == len(ontology.store)


PAPER_SCALE = {
    "robots": 5,
    "primitives": 40,
    "capabilities": 29,
    "parameters": 82,
    "preconditions": 67,
    "effects": 66,
    "substitution_relations": 40,
    "triples": 1232,
}


def test_stats_cli_meets_the_paper_scale(capsys):
    from lerobot_policy_recent.scripts.cli import main

    assert main(["ontology", "stats", "--json"]) == 0
    stats = json.loads(capsys.readouterr().out)
    assert set(stats) == {*PAPER_SCALE, "build_seconds"}
    for key, minimum in PAPER_SCALE.items():
        assert stats[key] >= minimum, key


def _expected_table():
    return yaml.safe_load((Path(__file__).parent / "data" / "expected_diagnoses.yaml").read_text())


def _conflict_key(c) -> tuple:
    return (
        c["line"],
        c["original"],
        c["substitute"],
        c["span_type"],
        tuple(sorted(c["mapping"].items())),
        tuple(c["dropped"]),
        tuple(c["unfilled"]),
        tuple(sorted(c.get("conversions", {}).items())),
    )


def test_every_skill_and_target_pair_matches_the_committed_table(ontology):
    """Precision and recall of determined conflicts are 1.0, and the warnings are exactly the expected ones."""
    from lerobot_policy_recent.skills.repository import list_skills, load_skill

    table = _expected_table()
    assert set(table) == set(list_skills())
    for name, per_robot in table.items():
        skill = load_skill(name)
        assert set(per_robot) == set(ontology.robot_names()) - {skill.source_embodiment}
        for robot, expected in per_robot.items():
            summary = diagnose(ontology, skill.name, skill.code, robot, source=skill.source_embodiment).summary()
            got = {_conflict_key(c) for c in summary["conflicts"]}
            want = {_conflict_key(c) for c in expected["conflicts"]}
            true_positive = len(got & want)
            assert true_positive / max(1, len(got)) == 1.0, (name, robot, got - want)  # precision
            assert true_positive / max(1, len(want)) == 1.0, (name, robot, want - got)  # recall
            assert summary["warnings"] == expected["warnings"], (name, robot)


def test_suction_warnings_say_what_to_check_and_where(ontology, put_in_bin):
    result = diagnose(ontology, put_in_bin.name, put_in_bin.code, "Suction")
    flat = next(w for w in result.warnings if w.kind == "surface_flat")
    assert flat.span.text(put_in_bin.code).startswith("pick(") and flat.primitive == "attach_vacuum_handle"
    assert flat.check == "flat_top" and "environment_state" in flat.observation and flat.phase == "before"


def test_a_move_is_guarded_where_it_first_uses_a_read_made_before_the_robot_moved(ontology):
    """The drag's first move beyond the cube uses ``obj_pos``, read before the rake was picked: the cube
    may have moved in between (``target_unmoved``, checked as ``object_unmoved``), and so does the drag
    (the first use of ``region_pos``). The descent and the lift use reads already used since the
    robot moved, where the rake itself moves the cube: not guarded, on any robot, the Panda too."""
    from lerobot_policy_recent.skills.repository import load_skill

    drag = load_skill("drag_with_tool")
    for robot in ("Panda", "UR5e", "Kinova3"):
        guarded = [w for w in diagnose(ontology, drag.name, drag.code, robot).warnings if w.kind == "target_unmoved"]
        assert [w.span.text(drag.code).split("[")[1] for w in guarded] == ["obj_pos", "region_pos"], robot
        assert guarded[0].check == "object_unmoved" and guarded[0].phase == "before"


def test_query_exposes_the_robot_conditioned_interface_and_gaps(ontology, put_in_bin):
    from lerobot_policy_recent.ontology.query import query

    q = query(ontology, put_in_bin.name, put_in_bin.code, "Suction")
    assert {"grasp_object", "place_object", "open_fingers"} <= q.capabilities
    assert [p.name for p in q.interface["place_object"]] == ["detach_vacuum_handle"]
    assert q.gaps == {"grasp_object", "open_fingers", "parallel_jaw_grasp", "release_object"}
    assert not query(ontology, put_in_bin.name, put_in_bin.code, "Panda").gaps


def test_instance_graph_image_is_written(tmp_path, capsys):
    from lerobot_policy_recent.scripts.cli import main

    out = tmp_path / "graph.png"
    assert main(["ontology", "graph", "--skill", "put_in_bin", "--robot", "Suction", "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_build_writes_turtle(tmp_path, capsys):
    from lerobot_policy_recent.scripts.cli import main

    out = tmp_path / "onto.ttl"
    assert main(["ontology", "build", "--out", str(out)]) == 0
    assert "rc:substitutableBy" in out.read_text()


def test_malformed_spec_names_file_and_field(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "embodiment: X\nmodule: m\nprimitives:\n  - name: grab\n    description: d\n    parameters:\n      - {name: p, type: vector, role: motion_target, required: true}\n"
    )
    with pytest.raises(SpecError) as err:
        load_api_spec(bad)
    assert str(bad) in str(err.value) and "primitives[0] (grab).parameters[0].type" in str(err.value)
    bad.write_text("embodiment: X\nmodule: m\nprimitives:\n  - name: grab\n    parameters: []\n")
    with pytest.raises(SpecError, match=r"primitives\[0\] \(grab\)\.description: missing required field"):
        load_api_spec(bad)
    path = "    path:\n      - {role: %s, offset: %s}\n"
    grab = "embodiment: X\nmodule: m\nprimitives:\n  - name: grab\n    description: d\n    parameters:\n      - {name: p, type: position, role: motion_target, required: true}\n    capabilities: []\n    preconditions: []\n    effects: []\n"
    bad.write_text(grab + path % ("elsewhere", "[0, 0, 0.1]"))
    with pytest.raises(
        SpecError, match=r"primitives\[0\] \(grab\)\.path\[0\]\.role: 'elsewhere' is not the role of a position"
    ):
        load_api_spec(bad)
    bad.write_text(grab + path % ("motion_target", "[0, 0.1]"))
    with pytest.raises(SpecError, match=r"primitives\[0\] \(grab\)\.path\[0\]\.offset: must be three numbers"):
        load_api_spec(bad)
    bad.write_text("tool_tip_below_site_m: -0.01\n" + grab)
    with pytest.raises(SpecError, match=r"tool_tip_below_site_m: must be metres from 0 to 0.3, got -0.01"):
        load_api_spec(bad)
    bad.write_text(grab + "    time_limit_s: -1\n")
    with pytest.raises(SpecError, match=r"\(grab\)\.time_limit_s: must be a positive number of seconds, got -1"):
        load_api_spec(bad)
    bad.write_text("embodiment: [unclosed\n")
    with pytest.raises(SpecError, match="not valid YAML"):
        load_api_spec(bad)
    bad.write_text(grab.replace("role: motion_target", "role: grasp_tgt"))  # a typo would match no source role
    with pytest.raises(
        SpecError, match=r"parameters\[0\]\.role: unknown role 'grasp_tgt' of 'p'; known roles: .*grasp_target"
    ):
        load_api_spec(bad)


def test_malformed_turtle_and_mjcf_are_clear_errors(tmp_path):
    bad_ttl = tmp_path / "schema.ttl"
    bad_ttl.write_text("@prefix rc: <x#> .\nrc:A a rc:B")
    with pytest.raises(SpecError, match=r"schema.ttl: turtle: cannot be loaded"):
        build_ontology(schema=bad_ttl)
    bad_xml = tmp_path / "robot.xml"
    bad_xml.write_text("<mujoco><worldbody><body>")
    sources = [
        EmbodimentSource("Panda", default_embodiment_sources()[0].api_spec, str(bad_xml), str(bad_xml), source=True)
    ]
    with pytest.raises(SpecError, match=r"robot.xml: mjcf: not well-formed XML"):
        build_ontology(sources)


def _spec_with(tmp_path, preconditions: str, effects: str):
    path = tmp_path / "x.yaml"
    path.write_text(
        "embodiment: X\nmodule: m\nprimitives:\n  - name: grab\n    description: d\n    parameters: []\n"
        f"    capabilities: [grasp_object]\n    preconditions: {preconditions}\n    effects: {effects}\n"
    )
    return [
        *default_embodiment_sources(),
        EmbodimentSource(
            "X", path, "models/assets/robots/ur5e/robot.xml", "models/assets/grippers/robotiq_gripper_85.xml"
        ),
    ]


def test_unknown_conditions_and_contradictions_name_file_and_field(tmp_path):
    with pytest.raises(
        SpecError, match=r"x.yaml: primitives\[0\] \(grab\).effects: unknown condition\(s\) \['object_teleported'\]"
    ):
        build_ontology(_spec_with(tmp_path, "[]", "[object_teleported]"))
    with pytest.raises(
        SpecError,
        match=r"x.yaml: primitives\[0\] \(grab\).effects: contradiction: 'end_effector_engaged' and 'end_effector_free'",
    ):
        build_ontology(_spec_with(tmp_path, "[]", "[end_effector_free, end_effector_engaged]"))


def test_a_robot_registered_twice_is_rejected():
    sources = default_embodiment_sources()
    with pytest.raises(SpecError, match="registered twice"):
        build_ontology([*sources, sources[1]])


def test_unknown_robot_lists_known_ones(ontology):
    with pytest.raises(KeyError, match="known robots: Panda, UR5e, Sawyer, Robotiq85, Suction"):
        ontology.api("Baxter")


KUKA_SPEC = """
embodiment: Kuka
module: not.needed.for.diagnosis
primitives:
  - name: kuka_take
    description: take an object
    parameters:
      - {{name: where, type: position, unit: m, role: grasp_target, required: true}}
    capabilities: [grasp_object]
    preconditions: [end_effector_free, object_at_target, target_reachable{take_needs}]
    effects: [object_grasped, object_lifted, end_effector_engaged]
  - name: kuka_put
    description: put it down
    parameters:
      - {{name: where, type: position, unit: m, role: release_target, required: true}}
    capabilities: [place_object]
    preconditions: [object_grasped, target_reachable]
    effects: [object_at_target, end_effector_free, object_released]
  - name: kuka_open
    description: open
    parameters: []
    capabilities: [open_fingers]
    preconditions: []
    effects: [end_effector_free, object_released]
  - name: kuka_align
    description: point the gripper down
    parameters: []
    capabilities: [orient_end_effector]
    preconditions: []
    effects: [end_effector_oriented]
"""


def _with_kuka(tmp_path, take_needs: str = ""):
    """The shipped robots plus a Kuka iiwa described only by files in ``tmp_path``."""
    spec = tmp_path / "kuka.yaml"
    spec.write_text(KUKA_SPEC.format(take_needs=take_needs))
    kuka = EmbodimentSource(
        "Kuka", spec, "models/assets/robots/iiwa/robot.xml", "models/assets/grippers/rethink_gripper.xml"
    )
    return build_ontology([*default_embodiment_sources(), kuka])


def test_a_new_robot_is_data_only(tmp_path, put_in_bin):
    """A robot added from files in a temporary directory is diagnosed with no code change."""
    onto = _with_kuka(tmp_path)
    result = diagnose(onto, put_in_bin.name, put_in_bin.code, "Kuka")
    assert [c.substitute.name for c in result.conflicts] == ["kuka_open", "kuka_take", "kuka_put"]
    assert {m.source: m.target for m in result.conflicts[1].mapping} == {"target_pos": "where"}
    assert onto.arms["Kuka"].dof == 7


def test_a_substitute_needing_a_robot_state_gets_a_preparatory_step(tmp_path, put_in_bin):
    """kuka_take needs the gripper oriented first; kuka_align establishes that: D says so, no LM involved."""
    onto = _with_kuka(tmp_path, take_needs=", end_effector_oriented")
    pick = next(c for c in diagnose(onto, put_in_bin.name, put_in_bin.code, "Kuka").conflicts if c.original == "pick")
    assert pick.span_type == "preparatory_step" and pick.preparatory == ("kuka_align",)

    from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
    from lerobot_policy_recent.recent_plugin.infillers.rule import RuleInfiller

    grounded = ground_skill(put_in_bin, onto.target("Kuka"), onto, RuleInfiller())
    assert "    kuka_align(env, task)\n    kuka_take(env, task, where=obj_pos)\n" in grounded.code


KUKA_MODULE = """
def kuka_take(env, task, where):
    yield from ()


def kuka_put(env, task, where, speed=1.0):
    yield from ()


def kuka_open(env, task):
    yield from ()
{rest}"""


def test_a_data_only_robot_is_checked_against_its_module_before_it_runs(tmp_path, monkeypatch):
    """The YAML declares kuka_align, the module lacks it and has kuka_wave: refused, naming both files."""
    from lerobot_policy_recent.ontology.specs import SpecError

    monkeypatch.syspath_prepend(str(tmp_path))
    (tmp_path / "kuka_prims.py").write_text(
        KUKA_MODULE.format(rest="\n\ndef kuka_wave(env, task, speed):\n    yield from ()\n")
    )
    (tmp_path / "spec").mkdir()
    onto = _with_kuka(tmp_path / "spec")
    spec = onto.api("Kuka")
    target = dataclasses.replace(onto.target("Kuka"), api=dataclasses.replace(spec, module="kuka_prims"))
    with pytest.raises(SpecError) as refused:
        bind_primitives(target)
    message = str(refused.value)
    assert "kuka.yaml against" in message and "kuka_prims.py" in message
    assert "kuka_align: declared in the YAML, not a function of the module" in message
    assert "kuka_wave: a function of the module, not declared in the YAML" in message

    (tmp_path / "kuka_good.py").write_text(
        KUKA_MODULE.format(rest="\n\ndef kuka_align(env, task):\n    yield from ()\n")
    )
    good = dataclasses.replace(target, api=dataclasses.replace(spec, module="kuka_good"))
    assert sorted(bind_primitives(good)) == ["kuka_align", "kuka_open", "kuka_put", "kuka_take"]


def test_a_target_is_resolved_once_with_its_api_arm_and_primitives(ontology):
    import dataclasses

    import pytest

    from lerobot_policy_recent.ontology.specs import SpecError

    target = ontology.target("UR5e")
    assert target.api is ontology.api("UR5e") and target.arm.reach == ontology.arms["UR5e"].reach
    assert set(bind_primitives(target)) == {p.name for p in target.api.primitives}
    with pytest.raises(KeyError, match="known robots"):
        ontology.target("Kuka")
    broken = dataclasses.replace(target, api=dataclasses.replace(target.api, module="no.such.module"))
    with pytest.raises(SpecError, match="ur5e.yaml: module: 'no.such.module' cannot be imported"):
        bind_primitives(broken)


def test_bundled_robots_are_robot_files_of_the_format_users_write():
    """One format for one fact: every bundled robot is a robot file (``robot:`` block), listed once,
    and read by the same loader as a ``RECENT_ROBOTS`` file."""
    from lerobot_policy_recent.descriptions.embodiments import BUNDLED, BUNDLED_DIR, EMBODIMENTS, load_robot_file

    with_rows = sorted(p.stem for p in BUNDLED_DIR.glob("*.yaml") if "robot" in yaml.safe_load(p.read_text()))
    assert with_rows == sorted(BUNDLED) and len(set(BUNDLED)) == len(BUNDLED)
    for api in BUNDLED:
        row = load_robot_file(BUNDLED_DIR / f"{api}.yaml")
        assert EMBODIMENTS[row.name] == row
    assert Path(EMBODIMENTS["Suction"].gripper_mjcf).is_file()  # a path beside the robot file


def test_a_condition_checked_as_an_effect_names_its_check_observation_and_message(tmp_path):
    """``as_effect`` is read with the vocabulary: a missing part is named by its path in the file."""
    from lerobot_policy_recent.ontology.specs import CONDITIONS_PATH, SpecError, load_conditions

    assert load_conditions()["object_at_target"].as_effect[0] == "placed_at_target"
    text = CONDITIONS_PATH.read_text().replace(
        "      message: the released object may not rest where it was put (it slid off, or fell beside)\n", ""
    )
    bad = tmp_path / "conditions.yaml"
    bad.write_text(text)
    with pytest.raises(SpecError, match=r"conditions\.object_at_target\.as_effect\.message: missing required field"):
        load_conditions(bad)


TONGS_SPEC = """
embodiment: Tongs
module: not.needed.for.diagnosis
primitives:
  - name: tongs_take
    description: take a named object
    parameters:
      - {name: obj, type: object_name, role: grasp_target, required: true}
    capabilities: [grasp_object]
    preconditions: [end_effector_free, object_at_target, target_reachable]
    effects: [object_grasped, object_lifted, end_effector_engaged]
  - name: tongs_put
    description: put the held object onto a named one
    parameters:
      - {name: onto, type: object_name, role: release_receptacle, required: true}
    capabilities: [place_object]
    preconditions: [object_grasped, target_reachable]
    effects: [object_at_target, end_effector_free, object_released]
  - name: tongs_open
    description: open
    parameters: []
    capabilities: [open_fingers]
    preconditions: []
    effects: [end_effector_free, object_released]
"""


def test_a_tool_put_back_onto_a_robot_that_places_only_by_name_and_cannot_move_to_a_point_is_refused(tmp_path):
    """drag_with_tool puts the rake back at its own earlier point: no object there to name, and
    no move of this robot can trace the place's path, so the call is refused with that reason."""
    from lerobot_policy_recent.skills.repository import load_skill

    spec = tmp_path / "tongs.yaml"
    spec.write_text(TONGS_SPEC)
    tongs = EmbodimentSource(
        "Tongs", spec, "models/assets/robots/iiwa/robot.xml", "models/assets/grippers/rethink_gripper.xml"
    )
    onto = build_ontology([*default_embodiment_sources(), tongs])
    skill = load_skill("drag_with_tool")
    place = diagnose(onto, skill.name, skill.code, "Tongs").conflicts[-1]
    assert place.original == "place" and place.substitute is None and not place.path
    assert place.reason.startswith(
        "place puts tool back at its own earlier point, where no object is to put it on by name"
    )
    assert "Tongs places only onto a named object and has no move to trace the place with" in place.reason


def _rendered(ontology, code: str, robot: str) -> list[str]:
    from lerobot_policy_recent.recent_plugin.refactoring.substitution import render_substitute_call

    result = diagnose(ontology, "moves", code, robot, source="FrankaHand" if "move_to_position" in code else "Panda")
    return [render_substitute_call(c.span.text(code), c) for c in result.conflicts]


def test_a_move_keeps_the_time_its_source_call_gave_it_where_the_target_gives_less(ontology):
    """The Franka Hand's sweep pushed a block 31 cm within its move's 6 s; a UR5e's move gives up
    after 3 s by default, 1 cm short (every sweep_into_pen episode on UR5e). The source's time is
    kept; a timeout the call states is mapped as it is; an arm whose own default is longer keeps it."""
    hand = "def moves(env, task):\n    move_to_position(env, task, pos=[0.1, 0.0, 0.9])\n"
    assert _rendered(ontology, hand, "UR5e") == ["ur5_move_to(env, task, target_pos=[0.1, 0.0, 0.9], timeout_s=6.0)"]
    assert _rendered(ontology, hand, "UR5eScript")[0].endswith("t=6.0)")
    assert "timeout" not in _rendered(ontology, hand, "XArm7")[0]  # its own 10 s default: more than the source's
    panda = "def moves(env, task):\n    move(env, task, target_pos=[0.1, 0.0, 0.9], timeout=4.0)\n"
    assert _rendered(ontology, panda, "UR5e") == ["ur5_move_to(env, task, target_pos=[0.1, 0.0, 0.9], timeout_s=4.0)"]
    [conflict] = diagnose(ontology, "moves", hand, "UR5e", source="FrankaHand").conflicts
    assert (
        conflict.kept == (("timeout_s", "6.0"),)
        and "timeout_s=6.0: the seconds move_to_position gave" in conflict.reason
    )


def test_a_declared_time_limit_is_the_controllers_own():
    """A move with no timeout parameter declares the limit its controller applies: what a target is
    given in its place must be what the source had."""
    import inspect

    from lerobot_policy_recent.robosuite_envs.primitives import control

    default = inspect.signature(control.move_to).parameters["timeout_s"].default
    for robot in ("franka_hand", "robotiq85", "suction"):
        api = load_api_spec(Path(__file__).parents[1] / "descriptions" / "robots" / f"{robot}.yaml")
        limits = {p.name: p.time_limit_s for p in api.primitives if p.time_limit_s is not None}
        assert limits == dict.fromkeys(("move_gripper_to", "move_to_position", "move_parallel"), default), robot
