"""Calibration from the robot model and a short run in simulation; robots added from files; the arm check."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lerobot_policy_recent.descriptions.embodiments import (
    EMBODIMENTS,
    RobotFileError,
    get_embodiment,
    load_robot_file,
)
from lerobot_policy_recent.robosuite_envs.calibrate import cache_path, calibration, calibration_key, measure
from lerobot_policy_recent.robosuite_envs.calibration import Calibration

ROOT = Path(__file__).parents[1]


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("RECENT_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.mark.parametrize("name", ["Panda", "Jaco"])
def test_calibration_reads_the_arm_the_ontology_reads_and_measures_the_rest(name, ontology):
    """DoF, joint limits and reach agree with the ontology's MJCF facts; gripper and tracking are measured."""
    measured = measure(name)
    arm = ontology.arms[name]
    assert measured.arm_dof == arm.dof
    assert np.allclose(measured.joint_limits, [(j.lower, j.upper) for j in arm.joints], atol=1e-4)
    assert measured.reach_m == pytest.approx(arm.reach, abs=1e-3)
    assert measured.mechanism == "fingers" and abs(np.linalg.norm(measured.closing_axis) - 1) < 1e-2
    assert 0 < measured.close_time_s < 10 and measured.opening_open != measured.opening_closed
    assert measured.zero_holds  # robosuite's grippers step their command: zero leaves it where it is
    assert measured.tracking_error_m < measured.settle_tol_m <= 0.05 and not measured.unreached
    # at the table the arm reaches past the table's centre, and less far than stretched out in the air
    assert np.linalg.norm(measured.base_xyz[:2]) < measured.table_reach_m < measured.reach_m
    # and pointing down it reaches the table's near half, where the tasks put objects (30 cm from the base)
    assert measured.inner_reach_m < 0.3
    # walked out at each height in the air, it first stops short within its stretch, nearer or farther than at
    # the table (a Jaco's hand 2 cm nearer 23 cm up)
    heights = [h for h, _ in measured.reach_by_height]
    assert heights == sorted(heights) and heights[0] > 0.1
    assert all(0.5 < d <= measured.reach_m for _, d in measured.reach_by_height)


def test_the_hand_footprint_is_measured_from_the_grippers_own_geometry():
    """The open parallel jaw reaches out along its closing axis (fingers and palm), a cup only as far
    as its mount: the planner sweeps each as wide as it is."""
    jaw, cup = calibration("FrankaHand"), calibration("Suction")
    along = int(np.argmax(np.abs(jaw.closing_axis[:2])))  # the site axis the fingers close along
    assert jaw.hand_half_xy[along] > 0.08 > jaw.hand_half_xy[1 - along]  # a Franka Hand is ~20 cm long
    assert max(cup.hand_half_xy) < 0.04 < max(jaw.hand_half_xy)
    assert jaw.zero_holds and not cup.zero_holds  # a cup's command is on or off


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in EMBODIMENTS if n not in ("Panda", "Jaco")])
def test_every_embodiment_calibrates_consistently_with_the_ontology(name, ontology):
    measured = measure(name)
    assert (measured.arm_dof, measured.reach_m) == (ontology.arms[name].dof, pytest.approx(ontology.arms[name].reach))
    assert measured.mechanism == ("suction" if name == "Suction" else "fingers")
    # measured from the home posture: after the tracking poses a folded Kinova3 read 0 m
    assert np.linalg.norm(measured.base_xyz[:2]) < measured.table_reach_m < measured.reach_m
    # an iiwa's elbow folds to 120 degrees only: pointing down, its hand stops short 36 cm from its base
    assert (measured.inner_reach_m > 0.3) == (name in ("IIWA", "IIWAKRL"))
    assert all(0.5 < d <= measured.reach_m for _, d in measured.reach_by_height)


def test_the_reach_in_the_air_tells_a_short_arm_from_the_source():
    """close_hinged_box's first move, 26 cm above the table and 0.79 m from the base: the Panda's hand
    gets there, a Kinova3's stops 2.4 cm short (cannot track, every episode); its calibrated limit
    at that height refuses it by name before the arm is sent."""
    from lerobot_policy_recent.recent_plugin.insitu.checks import SceneFacts, reach_in_the_air

    def limit(name: str, height: float) -> float:
        return reach_in_the_air(SceneFacts(frozenset(), {}, reach_limits=calibration(name).reach_limits()), height)

    assert limit("Kinova3", 0.26) < 0.78 < 0.79 < limit("Panda", 0.26)


def test_a_tool_tip_a_robot_file_declares_is_the_one_the_calibration_measures(ontology):
    """The ontology keeps a fist's press point from the tool tips the API files declare; each is the
    depth the calibration measures below the grip site, to half a millimetre."""
    declared = {name: api.tool_tip_m for name, api in ontology.apis.items() if api.tool_tip_m is not None}
    assert {"Panda", "FrankaHand", "Suction"} <= set(declared)
    for name, tip in declared.items():
        assert calibration(name).below_site_m == pytest.approx(tip, abs=5e-4), name


def test_a_calibration_is_measured_once_then_read_from_the_cache(cache):
    first = calibration("Panda")
    path = cache_path(get_embodiment("Panda"))
    assert path.is_file() and Calibration.from_json(path.read_text()) == first
    path.write_text(dataclasses.replace(first, close_time_s=9.99).to_json())  # the cache is what is read
    assert calibration("Panda").close_time_s == 9.99
    refreshed = calibration("Panda", refresh=True)  # measured again: deterministic, so the same facts
    assert refreshed == dataclasses.replace(first, seconds=refreshed.seconds)


def test_the_cache_key_follows_the_models(tmp_path):
    """Another gripper model (a copy with one attribute edited) is another calibration."""
    panda = get_embodiment("Panda")
    source = Path(__import__("robosuite").__file__).parent / panda.gripper_mjcf
    edited = tmp_path / "panda_gripper.xml"
    edited.write_text(source.read_text() + "<!-- edited -->\n")
    assert calibration_key(panda) != calibration_key(dataclasses.replace(panda, gripper_mjcf=str(edited)))


def test_a_slow_three_finger_hand_grasps_with_its_calibrated_stroke(cache):
    """The Jaco's hand takes ~6 s to close: with a fixed 3 s wait it lifted before touching the cube."""
    from lerobot_policy_recent.recent_plugin.agent import RecentAgent
    from lerobot_policy_recent.recent_plugin.episode import run_episode
    from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
    from lerobot_policy_recent.recent_plugin.settings import RecentSettings

    assert calibration("Jaco").close_time_s > 3.0
    result = run_episode(RecentAgent(RecentSettings(infiller=RuleConfig())), "kinematic/lift_cube", "Jaco", seed=0)
    assert result.success, result.failures


def test_a_slow_hand_lets_go_when_told_not_once_its_closing_command_has_unwound(cache):
    """The Jaco's closing command steps 1 % a control step: left on while the fingers held the cube it
    wound on, and the open that followed moved no finger for 70 steps (3.5 s). Held at zero once the
    fingers have squeezed, the hand lets go at once."""
    from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
    from lerobot_policy_recent.robosuite_envs.observation import Observation
    from lerobot_policy_recent.robosuite_envs.primitives import control
    from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession

    env = RecentEnv(task="kinematic/cube_in_bin", robot="Jaco", render_mode="none")
    names = env.spec_task.object_names()
    try:
        raw, _ = env.reset(seed=3)
        session = RobotSession("Jaco", Observation.decode(raw["agent_pos"], raw["environment_state"], names))
        session.calibration = calibration("Jaco")

        def run(steps, until_free: bool = False) -> int:
            taken = 0
            for action in steps:
                raw, *_ = env.step(action)
                session.update(Observation.decode(raw["agent_pos"], raw["environment_state"], names))
                taken += 1
                if until_free and session.obs.held() is None:
                    break
            return taken

        run(control.grasp_at(session, session.obs.objects["cube"].pos, object_name="cube"))
        assert session.obs.held() == "cube" and session.gripper_command == 0.0
        assert run(control.actuate_gripper(session, -1.0), until_free=True) <= 5
    finally:
        env.close()


def test_an_arm_stopped_short_of_its_goal_is_a_calibration_failure_not_a_grounding_one():
    """Beyond reach the arm stalls: ``cannot_track`` (its own category), not a timeout or an LM error."""
    from lerobot_policy_recent.recent_plugin.failures import PRIMITIVE_FAILURE_CATEGORY, FailureCategory
    from lerobot_policy_recent.robosuite_envs.primitives import control
    from lerobot_policy_recent.robosuite_envs.primitives.session import PrimitiveFailure, RobotSession
    from lerobot_policy_recent.robosuite_envs.tabletop import build_env
    from lerobot_policy_recent.robosuite_envs.tasks import TaskSpec

    env = build_env(TaskSpec("t/empty", "nothing", (), ()), get_embodiment("Panda"), seed=0)
    try:
        env.reset()
        session = RobotSession("Panda", env.sensed())
        with pytest.raises(PrimitiveFailure) as failed:
            for action in control.move_to(session, [0.9, 0.0, 1.0], timeout_s=6.0):
                env.step(action)
                session.update(env.sensed())
    finally:
        env.close()
    assert failed.value.kind == "cannot_track" and "short of" in str(failed.value)
    assert PRIMITIVE_FAILURE_CATEGORY[failed.value.kind] == FailureCategory.CANNOT_TRACK


# ------------------------------------------------------------------------------- a robot from files
IIWA_YAML = """\
embodiment: LabIIWA
robot:
  robosuite: IIWA
  gripper: LinkedRobotiq85Gripper
  robot_mjcf: models/assets/robots/iiwa/robot.xml
  gripper_mjcf: models/assets/grippers/robotiq_gripper_85.xml
  description: the lab's KUKA LBR iiwa 14 with a Robotiq 2F-85
module: iiwa_prims
primitives:
  - name: iiwa_grab
    description: Grab what lies at a point and lift it.
    parameters:
      - {name: point, type: position, unit: m, frame: world, role: grasp_target, required: true}
    capabilities: [grasp_object, lift_object, top_down_approach, parallel_jaw_grasp]
    preconditions: [end_effector_free, object_at_target, target_reachable, object_fits_gripper, fingers_clear]
    effects: [object_grasped, object_lifted, end_effector_engaged]
  - name: iiwa_drop
    description: Lower the held object to a point and let go.
    parameters:
      - {name: point, type: position, unit: m, frame: world, role: release_target, required: true}
    capabilities: [place_object, release_object]
    preconditions: [object_grasped, target_reachable, target_clear, support_unmoved]
    effects: [object_at_target, end_effector_free, object_released]
  - name: iiwa_move
    description: Move the tool centre point to a point.
    parameters:
      - {name: point, type: position, unit: m, frame: world, role: motion_target, required: true}
    capabilities: [move_end_effector, cartesian_motion]
    preconditions: [target_reachable, path_clear]
    effects: [end_effector_at_target]
  - name: iiwa_open
    description: Open the gripper.
    parameters: []
    capabilities: [open_fingers]
    preconditions: []
    effects: [end_effector_free, object_released]
"""

IIWA_MODULE = """\
from lerobot_policy_recent.robosuite_envs.primitives import control


def iiwa_grab(env, task, point):
    yield from control.grasp_at(env, point)


def iiwa_drop(env, task, point):
    yield from control.release_at(env, point)


def iiwa_move(env, task, point):
    yield from control.move_to(env, point, settle=True)


def iiwa_open(env, task):
    yield from control.actuate_gripper(env, -1.0)
"""


def _robot_dir(tmp_path: Path) -> Path:
    folder = tmp_path / "robots"
    folder.mkdir()
    (folder / "lab_iiwa.yaml").write_text(IIWA_YAML)
    (folder / "iiwa_prims.py").write_text(IIWA_MODULE)
    return folder


def test_a_robot_added_from_files_calibrates_and_runs_a_canonical_task(tmp_path):
    """The documented path, nothing else: a directory on RECENT_ROBOTS with a YAML and a module."""
    env = {**os.environ, "RECENT_ROBOTS": str(_robot_dir(tmp_path)), "RECENT_CACHE_DIR": str(tmp_path / "cache")}
    cli = [sys.executable, "-m", "lerobot_policy_recent.scripts.cli"]
    shown = subprocess.run(
        [*cli, "envs", "show-embodiment", "LabIIWA", "--json"], env=env, cwd=ROOT, capture_output=True, text=True
    )
    assert shown.returncode == 0, shown.stderr[-2000:]
    measured = Calibration.from_json(shown.stdout)
    assert (measured.robot, measured.arm_dof, measured.mechanism) == ("IIWA", 7, "fingers")
    ran = subprocess.run(
        [
            *cli,
            "run",
            "--task",
            "kinematic/lift_cube",
            "--robot",
            "LabIIWA",
            "--infiller.type",
            "rule",
            "--no-log",
            "--json",
        ],
        env=env,
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert ran.returncode == 0, ran.stderr[-2000:]
    assert json.loads(ran.stdout)["success"] is True


def test_a_robot_file_missing_a_field_names_the_file_and_the_field(tmp_path):
    path = _robot_dir(tmp_path) / "lab_iiwa.yaml"
    path.write_text(IIWA_YAML.replace("  gripper: LinkedRobotiq85Gripper\n", ""))
    with pytest.raises(RobotFileError) as refused:
        load_robot_file(path)
    assert str(path) in str(refused.value) and "robot.gripper" in str(refused.value)


def test_the_arm_check_compares_a_robot_with_the_reference(tmp_path, capsys):
    """`recent envs check` runs the robot and the Panda on the same episodes and prints the verdict."""
    from lerobot_policy_recent.scripts.cli import main

    code = main(
        ["envs", "check", "JacoRobotiq85", "--seeds", "0", "--tasks", "kinematic/lift_cube", "--out", str(tmp_path),
         "--infiller.type", "rule", "--workers", "1"]
    )  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0, out
    assert "| lift_cube | 1/1 | 1/1 |" in out and "JacoRobotiq85: PASS" in out


def test_the_arm_check_defaults_to_the_rule_backend_and_never_mixes_backends(tmp_path, capsys):
    """Plain `recent envs check` tests motion (rule); a resumed directory of another backend is refused."""
    from lerobot_policy_recent.evaluation.jobs import Job
    from lerobot_policy_recent.scripts.cli import build_parser, main

    args = build_parser().parse_args(["envs", "check", "Jaco"])
    assert getattr(args, "settings.infiller.type") == "rule"
    job = Job("recent", "kinematic", "kinematic/lift_cube", "Jaco", 0)
    job.record_path(tmp_path).parent.mkdir(parents=True)
    record = {"method": "recent", "suite": "kinematic", "task_id": job.task_id, "target": "Jaco", "seed": 0}
    job.record_path(tmp_path).write_text(json.dumps({**record, "backend": "llamacpp", "success": True}))
    code = main(["envs", "check", "Jaco", "--seeds", "0", "--tasks", "kinematic/lift_cube", "--out", str(tmp_path)])
    assert code == 2 and "holds a check with the llamacpp backend" in capsys.readouterr().err


def test_a_bad_robot_directory_is_one_line_from_the_cli(tmp_path):
    env = {**os.environ, "RECENT_ROBOTS": str(tmp_path / "missing")}
    done = subprocess.run(
        [sys.executable, "-m", "lerobot_policy_recent.scripts.cli", "envs", "list"],
        env=env,
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert f"{tmp_path / 'missing'}: RECENT_ROBOTS: is not a directory" in done.stderr
