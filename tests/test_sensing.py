"""Honest sensing: the policy reads what a real robot's sensors give, never the simulator's ground truth."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import numpy as np

from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
from lerobot_policy_recent.robosuite_envs.observation import (
    AGENT_POS_NAMES,
    SLOT_NAMES,
    ObjectState,
    Observation,
)
from lerobot_policy_recent.robosuite_envs.primitives import control
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession

ROOT = Path(__file__).resolve().parents[1]
TRUTH_WORDS = ("grasp", "held", "hold", "touch")
# What judges a run rather than acts in it: validation of a reference skill reads the env's truth, as
# success predicates do. Everything else under these folders is policy, executor, primitive or check.
POLICY_FOLDERS = ("recent_plugin", "robosuite_envs/primitives", "ontology", "skills")
JUDGES = {"recent_plugin/authoring/sim_validation.py"}


def _box(pos, size=(0.05, 0.05, 0.05)) -> ObjectState:
    return ObjectState(np.array(pos, dtype=float), np.array([0, 0, 0, 1.0]), size=np.array(size, dtype=float))


def test_the_observation_schema_carries_no_ground_truth():
    names = [n for n in AGENT_POS_NAMES + SLOT_NAMES if any(word in n for word in TRUTH_WORDS)]
    assert names == [], f"observation entries named after simulator truth: {names}"
    assert {f.name for f in dataclasses.fields(ObjectState)} == {"pos", "quat", "size", "state"}
    assert {"finger_contact_left", "finger_contact_right", "object_detected", "vacuum", "eef_contact"} <= set(
        AGENT_POS_NAMES
    )


def test_no_policy_module_reads_the_simulators_ground_truth():
    """No module the policy runs names ``GroundTruth`` or reads an observation's ``.truth``."""
    readers = []
    for folder in POLICY_FOLDERS:
        for path in sorted((ROOT / folder).rglob("*.py")):
            relative = path.relative_to(ROOT).as_posix()
            if relative in JUDGES:
                continue
            for node in ast.walk(ast.parse(path.read_text(), filename=relative)):
                attribute = isinstance(node, ast.Attribute) and node.attr == "truth"
                named = (isinstance(node, ast.Name) and node.id == "GroundTruth") or (
                    isinstance(node, ast.alias) and node.name == "GroundTruth"
                )
                if attribute or named:
                    readers.append(f"{relative}:{getattr(node, 'lineno', '?')}")
    assert readers == []


def test_a_grasp_is_inferred_from_the_gripper_sensors_and_geometry():
    cube, block = _box([0.0, 0.0, 0.87]), _box([0.0, 0.0, 0.82])  # the cube stands on the block
    obs = Observation(np.array([0.0, 0.0, 0.872]), np.array([0, 0, 0, 1.0]), 0.02, {"cube": cube, "block": block})
    assert obs.held() is None  # the gripper detects nothing: nothing is held, whatever the geometry
    detected = dataclasses.replace(obs, object_detected=True)
    assert detected.held() == "cube"  # the grip site is inside the cube's box, at the block's top face
    assert dataclasses.replace(detected, eef_pos=np.array([0.0, 0.0, 0.91])).held() == "cube"  # a knob 1.5 cm up
    assert dataclasses.replace(detected, eef_pos=np.array([0.2, 0.0, 0.87])).held() is None  # nothing there
    touching = dataclasses.replace(obs, eef_contact=True, eef_pos=np.array([0.0, 0.0, 0.86]))
    assert touching.in_contact() == ["cube", "block"]  # nearest box first; named only while the sensor fires


def test_the_panda_senses_its_grasp_and_the_policy_never_sees_the_truth():
    """A real grasp in simulation: both pads report contact, the gripper detects the cube, the policy
    infers it holds the cube, as the simulator's truth says; the encoded observation has no truth."""
    env = RecentEnv(task="kinematic/lift_cube", robot="Panda", render_mode="none")
    names = env.spec_task.object_names()
    raw, _ = env.reset(seed=3)
    session = RobotSession("Panda", Observation.decode(raw["agent_pos"], raw["environment_state"], names))
    try:
        assert session.obs.truth is None and not session.obs.object_detected and session.obs.held() is None
        for action in control.grasp_at(session, session.obs.objects["cube"].pos):
            raw, *_ = env.step(action)
            session.update(Observation.decode(raw["agent_pos"], raw["environment_state"], names))
        sensed = session.obs
        assert sensed.truth is None and env._env.sensed().truth is None
        assert sensed.finger_contact == (True, True) and sensed.object_detected and sensed.vacuum == 0.0
        assert sensed.held() == "cube" and env._env.observe().truth.held == {"cube"}
        assert not sensed.eef_contact  # the load in the grip is not a contact event
    finally:
        env.close()
