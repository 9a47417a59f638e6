"""The ontology decides conflicts without an LM: spans, substitutes and parameter mappings."""

from __future__ import annotations

import json

import pytest

from ontology.builder import EmbodimentSource, build_ontology, default_embodiment_sources
from ontology.diagnosis import diagnose
from ontology.mjcf import read_gripper
from ontology.specs import SpecError, load_api_spec

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


def test_gripper_mechanism_is_inferred_from_mjcf(ontology, tmp_path):
    assert {robot: g.mechanism for robot, g in ontology.grippers.items()} == {
        "Panda": "parallel_jaw",
        "UR5e": "parallel_jaw",
        "Sawyer": "parallel_jaw",
        "Robotiq85": "parallel_jaw",
        "Suction": "suction",
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


def test_stats_cli_prints_counts(capsys):
    from scripts.cli import main

    assert main(["ontology", "stats", "--json"]) == 0
    stats = json.loads(capsys.readouterr().out)
    assert stats["robots"] == 5 and stats["primitives"] == 40 and stats["triples"] > 1200


def test_malformed_spec_names_file_and_field(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "embodiment: X\nmodule: m\nprimitives:\n  - name: grab\n    description: d\n    parameters:\n      - {name: p, type: vector, role: r, required: true}\n"
    )
    with pytest.raises(SpecError) as err:
        load_api_spec(bad)
    assert str(bad) in str(err.value) and "primitives[0] (grab).parameters[0].type" in str(err.value)
    bad.write_text("embodiment: X\nmodule: m\nprimitives:\n  - name: grab\n    parameters: []\n")
    with pytest.raises(SpecError, match=r"primitives\[0\] \(grab\)\.description: missing required field"):
        load_api_spec(bad)
    bad.write_text("embodiment: [unclosed\n")
    with pytest.raises(SpecError, match="not valid YAML"):
        load_api_spec(bad)


def test_unknown_robot_lists_known_ones(ontology):
    with pytest.raises(KeyError, match="known robots: Panda, UR5e, Sawyer, Robotiq85, Suction"):
        ontology.api("Baxter")


def test_a_new_robot_is_data_only(tmp_path, put_in_bin):
    """A robot added from files in a temporary directory is diagnosed with no code change."""
    spec = tmp_path / "kuka.yaml"
    spec.write_text(
        """
embodiment: Kuka
module: not.needed.for.diagnosis
primitives:
  - name: kuka_take
    description: take an object
    parameters:
      - {name: where, type: position, unit: m, role: grasp_target, required: true}
    capabilities: [grasp_object]
    preconditions: [end_effector_free, object_at_target, target_reachable]
    effects: [object_grasped, object_lifted]
  - name: kuka_put
    description: put it down
    parameters:
      - {name: where, type: position, unit: m, role: release_target, required: true}
    capabilities: [place_object]
    preconditions: [object_grasped, target_reachable]
    effects: [object_at_target, end_effector_free]
  - name: kuka_open
    description: open
    parameters: []
    capabilities: [open_fingers]
    preconditions: []
    effects: [end_effector_free]
"""
    )
    sources = [
        *default_embodiment_sources(),
        EmbodimentSource(
            "Kuka", spec, "models/assets/robots/iiwa/robot.xml", "models/assets/grippers/rethink_gripper.xml"
        ),
    ]
    onto = build_ontology(sources)
    result = diagnose(onto, put_in_bin.name, put_in_bin.code, "Kuka")
    assert [c.substitute.name for c in result.conflicts] == ["kuka_open", "kuka_take", "kuka_put"]
    assert {m.source: m.target for m in result.conflicts[1].mapping} == {"target_pos": "where"}
    assert onto.arms["Kuka"].dof == 7
