"""Real-controller interfaces, described by data alone: URScript-style base-frame poses with
axis-angle rotation (``UR5eScript``) and KRL-style millimetres with Euler angles (``IIWAKRL``).

The ontology renders each conversion where the Panda's call determines it (the `rule` backend
grounds it, no LM), and leaves a placeholder where it does not (a position-only call becoming a
pose: which rotation?), which an LM fills from the facts the hint gives. The conversions are
checked numerically, and in simulation: a move reaches the world point the Panda's call named.
KRL has no pick or place: the ontology traces the Panda's as moves and gripper calls (one source
call, five target calls), and the run-time checks still guard them, in millimetres. A bare vacuum
cup added by data (a move, suction on, suction off) gets its picks and places traced the same way.
"""

from __future__ import annotations

import ast
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from doubles import ScriptedInfiller

from lerobot_policy_recent.ontology.conversions import FRAME_QUERIES, HELPERS, conversion
from lerobot_policy_recent.ontology.diagnosis import diagnose
from lerobot_policy_recent.ontology.specs import ParameterSpec, SpecError, load_api_spec
from lerobot_policy_recent.recent_plugin.grounding.gate import SAFE_HELPERS, TASK_QUERIES
from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
from lerobot_policy_recent.recent_plugin.refactoring.units import unit_from_conflict
from lerobot_policy_recent.robosuite_envs.primitives import frames
from lerobot_policy_recent.robosuite_envs.primitives.frames import SKILL_HELPERS, Frame, frame_at

WORLD_M = ParameterSpec("p", "position", "r", unit="m", frame="world")
TOOL_ROTATION = "quat_to_rotvec(task.quat_to_frame(task.get_tool_orientation(), 'base'))"  # the held rotation
BASE = frame_at("base", "arm_base", (0, 0, 180), (-0.56, 0.0, 0.912))  # URScript's base frame on our table


def _param(kind: str, unit: str | None = None, frame: str = "world", sequence: str | None = None) -> ParameterSpec:
    return ParameterSpec("q", kind, "r", unit=unit, frame=frame, sequence=sequence)


def test_the_renders_call_only_what_skill_code_may_call():
    assert set(HELPERS) == set(SKILL_HELPERS) and set(SKILL_HELPERS) <= SAFE_HELPERS
    assert set(FRAME_QUERIES) <= TASK_QUERIES


@pytest.mark.parametrize(
    ("source", "target", "template"),
    [
        (WORLD_M, _param("position", "mm"), "[1000 * v for v in {}]"),
        (WORLD_M, _param("position", "m", "base"), "task.to_frame({}, 'base')"),
        (WORLD_M, _param("position", "mm", "base"), "[1000 * v for v in task.to_frame({}, 'base')]"),
        (_param("position", "cm"), _param("position", "mm"), "[10 * v for v in {}]"),
        (WORLD_M, _param("pose", "m", "base"), "task.to_frame({}, 'base') + " + TOOL_ROTATION),
        (WORLD_M, _param("pose", "m"), "{} + quat_to_rotvec(task.get_tool_orientation())"),
        (_param("quaternion"), _param("rotvec", "rad", "base"), "quat_to_rotvec(task.quat_to_frame({}, 'base'))"),
        (_param("quaternion"), _param("euler", "deg", sequence="ZYX"), "quat_to_euler({}, 'ZYX', degrees=True)"),
        (
            _param("rotvec", "rad"),
            _param("euler", "rad", sequence="xyz"),
            "quat_to_euler(rotvec_to_quat({}), 'xyz', degrees=False)",
        ),
        (WORLD_M, _param("quaternion"), "<quaternion>"),  # nothing in a position determines an orientation
    ],
)
def test_the_ontology_renders_each_conversion_or_leaves_what_it_cannot_decide(source, target, template):
    rendered = conversion(source, target)
    assert rendered is not None and rendered.template == template
    assert rendered.determined == ("<" not in template)


def test_the_same_representation_needs_no_conversion():
    assert conversion(WORLD_M, ParameterSpec("x", "position", "other_role", unit="m", frame="world")) is None


def test_frames_and_rotations_are_numerically_right():
    """URScript's base frame faces the arm's back: world +x is base -x; a point 10 cm in front of the
    base, 5 cm up, is (-0.1, 0, 0.05) there. A quarter turn about z is rotvec (0, 0, pi/2), A=90 deg."""
    point = [-0.46, 0.0, 0.962]
    assert BASE.to_frame(point) == pytest.approx([-0.1, 0.0, 0.05], abs=1e-9)
    assert BASE.from_frame(BASE.to_frame(point)) == pytest.approx(point)
    quarter = [0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)]
    assert frames.quat_to_rotvec(quarter) == pytest.approx([0, 0, math.pi / 2])
    assert frames.quat_to_euler(quarter, "ZYX", degrees=True) == pytest.approx([90, 0, 0])
    assert frames.euler_to_quat([90, 0, 0], "ZYX") == pytest.approx(quarter)
    down = [1.0, 0.0, 0.0, 0.0]  # a tool pointing down in the world: half a turn about x
    in_base = frames.quat_to_rotvec(BASE.quat_to_frame(down))  # then turned back by half a turn about z: about y
    assert np.allclose(np.abs(in_base), [0, math.pi, 0])
    assert frames.scale([1, 2, 3], "m", "mm") == [1000, 2000, 3000]
    with pytest.raises(TypeError, match="expected 3 numbers"):  # a wrong argument fails as Python would say it
        BASE.to_frame([1.0, 2.0])


def test_a_rendered_conversion_evaluates_to_the_value_the_controller_expects():
    """The text the ontology writes, run as skill code runs it (the task's queries and the helpers)."""
    from lerobot_policy_recent.robosuite_envs.observation import Observation
    from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession, TaskContext

    obs = Observation(eef_pos=np.zeros(3), eef_quat=np.array([1.0, 0, 0, 0]), gripper_opening=0.0, objects={})
    session = RobotSession("UR5eScript", obs, frames={"world": Frame("world"), "base": BASE})
    namespace = {"task": TaskContext(session), **SKILL_HELPERS}
    pose_conversion = conversion(WORLD_M, _param("pose", "m", "base"))
    assert pose_conversion is not None and pose_conversion.determined
    text = pose_conversion.apply("p")
    pose = eval(text, namespace, {"p": [-0.46, 0.0, 0.962]})  # noqa: S307 -- the test's own text
    assert pose[:3] == pytest.approx([-0.1, 0.0, 0.05], abs=1e-9) and len(pose) == 6
    assert frames.world_point(pose, "pose", "m", BASE) == pytest.approx([-0.46, 0.0, 0.962])
    assert frames.world_rotation(pose, "pose", BASE) == pytest.approx([1.0, 0, 0, 0], abs=1e-9) or (
        frames.world_rotation(pose, "pose", BASE) == pytest.approx([-1.0, 0, 0, 0], abs=1e-9)
    )


def test_a_malformed_unit_frame_or_sequence_names_the_file_and_the_field(tmp_path):
    head = "embodiment: X\nmodule: m\n"
    prim = (
        "primitives:\n  - name: go\n    description: d\n    parameters:\n      - {%s}\n"
        "    capabilities: []\n    preconditions: []\n    effects: []\n"
    )
    cases = {
        "name: p, type: position, unit: furlong, role: motion_target, required: true": r"parameters\[0\]\.unit: a position takes",
        "name: p, type: position, frame: base, role: motion_target, required: true": r"parameters\[0\]\.frame: unknown frame 'base'",
        "name: a, type: euler, unit: deg, role: motion_target, required: true": r"parameters\[0\]\.sequence: Euler angles",
        "name: a, type: euler, unit: deg, sequence: ZZX, role: motion_target, required: true": r"\.sequence: three axes",
    }
    bad = tmp_path / "bad.yaml"
    for param, message in cases.items():
        bad.write_text(head + prim % param)
        with pytest.raises(SpecError, match=message) as err:
            load_api_spec(bad)
        assert str(bad) in str(err.value)
    bad.write_text(
        head
        + "frames:\n  base: {origin: flange}\n"
        + prim % "name: p, type: position, role: motion_target, required: true"
    )
    with pytest.raises(SpecError, match=r"frames\.base\.origin: must be one of world, arm_base"):
        load_api_spec(bad)


def test_krl_is_grounded_by_the_rule_backend_alone_its_picks_traced_as_moves_and_gripper_calls(
    ontology, put_in_bin, rule_infiller
):
    """KRL has no pick: the Panda's pick becomes open, a LIN above the object, down to it, close, back
    up (one source call, five target calls), each point converted to millimetres."""
    grounded = ground_skill(put_in_bin, ontology.target("IIWAKRL"), ontology, rule_infiller)
    assert grounded.valid and grounded.generated_tokens == 0
    pick = [
        "krl_open(env, task)",
        "krl_lin(env, task, xyz_mm=[1000 * v for v in [obj_pos[0], obj_pos[1], obj_pos[2] + 0.1]])",
        "krl_lin(env, task, xyz_mm=[1000 * v for v in obj_pos])",
        "krl_close(env, task)",
        "krl_lin(env, task, xyz_mm=[1000 * v for v in [obj_pos[0], obj_pos[1], obj_pos[2] + 0.1]])",
    ]
    assert "\n".join(f"    {line}" for line in pick) in grounded.code
    place = diagnose(ontology, put_in_bin.name, put_in_bin.code, "IIWAKRL").conflicts[-1]
    assert place.span_type == "path_tracing" and place.preparatory == ()  # the hand opens on the target, not before
    assert [s.render() for s in place.path] == ["target_pos + 0.05z", "target_pos", "krl_open()", "target_pos + 0.05z"]


def test_a_traced_place_is_still_checked_for_a_clear_target_read_as_the_release_target(ontology, put_in_bin):
    warnings = diagnose(ontology, put_in_bin.name, put_in_bin.code, "IIWAKRL").warnings
    clear = next(w for w in warnings if w.kind == "target_clear")
    assert clear.primitive == "krl_lin" and clear.roles == (("xyz_mm", "release_target"),)
    assert clear.through == 1  # before the move above the target and before the descent onto it


def test_a_traced_pick_has_its_hold_read_once_its_lift_has_run(ontology, put_in_bin):
    """A grasp traced as moves and krl_close closed on nothing, and nothing noticed it until the task
    ended (fill_open_drawer, IIWAKRL, dev seed 3, on): the pick's hold is read after the traced lift,
    the last of its five statements, as a pick's is after the call."""
    from lerobot_policy_recent.recent_plugin.insitu.adapter import _guards

    diagnosis = diagnose(ontology, put_in_bin.name, put_in_bin.code, "IIWAKRL")
    (hold,) = [w for w in diagnosis.warnings if w.kind == "object_grasped"]
    assert (hold.phase, hold.check, hold.primitive, hold.through) == ("after", "object_held", "krl_lin", 4)
    lines = [ast.parse("krl_lin(env, task)").body[0] for _ in range(5)]
    for offset, node in enumerate(lines):
        node.lineno = node.end_lineno = hold.span.line + offset
    assert [_guards(hold, node) for node in lines] == [False, False, False, False, True]  # after the lift only


@pytest.mark.slow
def test_a_check_on_a_traced_place_writes_its_sweep_in_the_robots_millimetres(ontology, rule_infiller):
    """cube_on_plate, seed 0, variations on: a slab lies on the plate. The target_clear check reads the
    descent's millimetres as the release target, and sweeps with krl_slide in millimetres."""
    from lerobot_policy_recent.recent_plugin.agent import RecentAgent
    from lerobot_policy_recent.recent_plugin.episode import run_episode
    from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
    from lerobot_policy_recent.recent_plugin.settings import RecentSettings

    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), infiller=rule_infiller, ontology=ontology)
    result = run_episode(agent, "kinematic/cube_on_plate", "IIWAKRL", seed=0, variations="on")
    assert result.success, result.failures
    sweep = next(e for e in result.adaptations if "target_clear" in e.checks)
    assert sweep.after is not None and sweep.after.startswith("krl_slide(env, task, from_mm=[")
    start = [float(v) for v in sweep.after.split("from_mm=[")[1].split("]")[0].split(",")]
    assert 700 < start[2] < 1000  # millimetres: the table top is at about 0.8 m


def test_a_malformed_actuation_step_names_the_file_and_the_field(tmp_path):
    from lerobot_policy_recent.ontology.specs import check_against_vocabulary, load_conditions

    spec = (
        "embodiment: X\nmodule: m\nprimitives:\n  - name: grab\n    description: d\n    parameters:\n"
        "      - {name: p, type: position, role: motion_target, required: true}\n"
        "    capabilities: []\n    preconditions: []\n    effects: []\n    path:\n      - %s\n"
    )
    bad = tmp_path / "bad.yaml"
    bad.write_text(spec % "{effect: end_effector_engaged, role: motion_target}")
    with pytest.raises(SpecError, match=r"primitives\[0\] \(grab\)\.path\[0\]: an actuation step has 'effect' alone"):
        load_api_spec(bad)
    bad.write_text(spec % "{effect: hand_waved}")
    with pytest.raises(SpecError, match=r"path\[0\]\.effect: unknown condition 'hand_waved'") as err:
        check_against_vocabulary(load_api_spec(bad), load_conditions())
    assert str(bad) in str(err.value)


def test_urscript_poses_carry_the_rotation_the_panda_call_holds_rendered_by_the_ontology(
    ontology, put_in_bin, rule_infiller
):
    """A Panda pick approaching top-down never turns the hand: the pose's rotation is the tool's own,
    in URScript's base frame. The ontology writes it; no LM is asked."""
    diagnosis = diagnose(ontology, put_in_bin.name, put_in_bin.code, "UR5eScript")
    pick, place = diagnosis.conflicts[1], diagnosis.conflicts[2]
    assert (pick.span_type, pick.unfilled, place.unfilled) == ("parameter_binding", (), ())
    unit = unit_from_conflict(put_in_bin.code, pick, ontology.target("UR5eScript"))
    assert unit.hints.substitute_call == f"ur_pick(env, task, pose=task.to_frame(obj_pos, 'base') + {TOOL_ROTATION})"
    grounded = ground_skill(put_in_bin, ontology.target("UR5eScript"), ontology, rule_infiller)
    assert grounded.valid, grounded.verdict
    assert f"ur_place(env, task, pose=task.to_frame(drop_pos, 'base') + {TOOL_ROTATION})" in grounded.code


PANDA_MOVE = 'def go(env, task):\n    """Move the hand to a point."""\n    p = [0.05, -0.08, 1.02]\n    move(env, task, target_pos=p)\n'


def test_a_whole_program_prompt_names_the_frames_and_conversions_only_for_a_robot_that_needs_them(ontology):
    """A baseline writes the whole program: it gets the same facts (frames, queries, helpers) in its header."""
    from lerobot_policy_recent.recent_plugin.agent import RecentAgent
    from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
    from lerobot_policy_recent.recent_plugin.methods import method_named
    from lerobot_policy_recent.recent_plugin.settings import RecentSettings
    from lerobot_policy_recent.robosuite_envs.suites import get_task

    headers = {}
    for robot in ("UR5eScript", "UR5e"):
        infiller = ScriptedInfiller(["pass"])
        agent = RecentAgent(
            RecentSettings(infiller=RuleConfig(), method=method_named("cap")), ontology=ontology, infiller=infiller
        )
        agent.ground("put_in_bin", robot, get_task("cube_in_bin"))
        headers[robot] = infiller.units[0].prefix
    assert "# Frames: base: at the arm base, turned [0.0, 0.0, 180.0] deg" in headers["UR5eScript"]
    assert "task.to_frame(...)" in headers["UR5eScript"] and "quat_to_rotvec(...)" in headers["UR5eScript"]
    assert "#   ur_pick(env, task, pose: pose [m, frame base]" in headers["UR5eScript"]
    assert "Conversions" not in headers["UR5e"] and "Frames" not in headers["UR5e"]


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["IIWAKRL", "UR5eScript"])  # millimetres; a base-frame pose with a rotation
def test_an_executed_move_reaches_the_world_point_the_panda_call_named(ontology, rule_infiller, robot):
    """The rendered conversion, the robot's driver and the controller together: within its tolerance,
    and with the hand as the Panda's move leaves it (not turned)."""
    from pathlib import Path

    from lerobot_policy_recent.recent_plugin.executor import PlannedSkill, TaskExecutor
    from lerobot_policy_recent.robosuite_envs.calibrate import calibration
    from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
    from lerobot_policy_recent.robosuite_envs.observation import Observation
    from lerobot_policy_recent.skills.repository import Skill

    skill = Skill("go", "go", "move", "Panda", "move the hand to a point", PANDA_MOVE, Path("go.py"))
    grounded = ground_skill(skill, ontology.target(robot), ontology, rule_infiller)
    assert grounded.valid, grounded.verdict
    measured = calibration(robot)
    env = RecentEnv(task="kinematic/lift_cube", robot=robot, render_mode="none")
    try:
        raw, _ = env.reset(seed=0)
        names = env.spec_task.object_names()
        obs = Observation.decode(raw["agent_pos"], raw["environment_state"], names)
        start_quat = obs.eef_quat.copy()
        executor = TaskExecutor([PlannedSkill(grounded)], ontology.target(robot), obs, calibration=measured)
        for _ in range(200):
            obs = Observation.decode(raw["agent_pos"], raw["environment_state"], names)
            raw, *_ = env.step(executor.act(obs))
            if executor.finished:
                break
        assert executor.finished and not executor.failures, executor.failures
        assert np.linalg.norm(obs.eef_pos - [0.05, -0.08, 1.02]) < 1.2 * measured.settle_tol_m, obs.eef_pos
        turned = 2 * np.arccos(min(1.0, abs(float(np.dot(start_quat, obs.eef_quat)))))
        assert turned < 0.1, f"the tool turned by {turned:.3f} rad"
    finally:
        env.close()


LAB_YAML = """\
embodiment: LabBaseMM
robot:
  robosuite: IIWA
  gripper: LinkedRobotiq85Gripper
  robot_mjcf: models/assets/robots/iiwa/robot.xml
  gripper_mjcf: models/assets/grippers/robotiq_gripper_85.xml
  description: a lab's iiwa whose controller takes millimetres in its base frame
module: lab_mm_prims
frames:
  base: {origin: arm_base}
primitives:
  - name: grab_mm
    description: Grab what lies at a point and lift it.
    parameters:
      - {name: at_mm, type: position, unit: mm, frame: base, role: grasp_target, required: true}
    capabilities: [grasp_object, lift_object, top_down_approach, parallel_jaw_grasp]
    preconditions: [end_effector_free, object_at_target, target_reachable, object_fits_gripper, fingers_clear]
    effects: [object_grasped, object_lifted, end_effector_engaged]
  - name: move_mm
    description: Move the tool centre point to a point.
    parameters:
      - {name: to_mm, type: position, unit: mm, frame: base, role: motion_target, required: true}
    capabilities: [move_end_effector, cartesian_motion]
    preconditions: [target_reachable, path_clear]
    effects: [end_effector_at_target]
  - name: open_mm
    description: Open the gripper.
    parameters: []
    capabilities: [open_fingers]
    preconditions: []
    effects: [end_effector_free, object_released]
"""

LAB_MODULE = """\
from lerobot_policy_recent.robosuite_envs.primitives import control, frames


def grab_mm(env, task, at_mm):
    yield from control.grasp_at(env, frames.world_point(at_mm, "position", "mm", env.frame("base")))


def move_mm(env, task, to_mm):
    yield from control.move_to(env, frames.world_point(to_mm, "position", "mm", env.frame("base")), settle=True)


def open_mm(env, task):
    yield from control.actuate_gripper(env, -1.0)
"""


@pytest.mark.slow
def test_a_robot_of_ones_own_with_millimetres_in_its_base_frame_is_added_by_data_alone(tmp_path):
    """The README's path (a YAML with a robot block and a module on RECENT_ROBOTS), nothing else:
    the ontology renders the conversion, and the rule backend grounds and runs a canonical task."""
    cli = _cli_with_robot(tmp_path, {"lab_mm.yaml": LAB_YAML, "lab_mm_prims.py": LAB_MODULE})
    ran = cli(
        "run", "--task", "kinematic/lift_cube", "--robot", "LabBaseMM", "--infiller.type", "rule", "--no-log", "--json"
    )
    assert ran.returncode == 0, ran.stderr[-2000:]
    result = json.loads(ran.stdout)
    assert result["success"] is True, result


def _cli_with_robot(tmp_path, files: dict[str, str]):
    """``recent`` in a new process that finds a robot added from ``files`` alone (a folder on RECENT_ROBOTS)."""
    folder = tmp_path / "robots"
    folder.mkdir()
    for name, text in files.items():
        (folder / name).write_text(text)
    env = {**os.environ, "RECENT_ROBOTS": str(folder), "RECENT_CACHE_DIR": str(tmp_path / "cache")}
    command = [sys.executable, "-m", "lerobot_policy_recent.scripts.cli"]
    return lambda *args: subprocess.run([*command, *args], env=env, capture_output=True, text=True)


VACUUM_YAML = """\
embodiment: LabVacuum
robot:
  robosuite: Panda
  gripper: SuctionGripper
  robot_mjcf: models/assets/robots/panda/robot.xml
  gripper_mjcf: {cup}
  description: a lab's Panda with a bare vacuum cup (move, suction on, suction off)
module: lab_vacuum_prims
primitives:
  - name: cup_to
    description: Move the cup to a point; lowered onto a surface, it stops on it and presses its rim down.
    parameters:
      - {{name: point, type: position, unit: m, frame: world, role: motion_target, required: true}}
    capabilities: [move_end_effector, cartesian_motion]
    preconditions: [target_reachable, path_clear]
    effects: [end_effector_at_target]
  - name: suction_on
    description: Switch suction on; it holds what the cup is pressed on.
    parameters: []
    capabilities: [activate_suction]
    preconditions: [end_effector_free]
    effects: [end_effector_engaged]
  - name: suction_off
    description: Switch suction off.
    parameters: []
    capabilities: [deactivate_suction]
    preconditions: []
    effects: [end_effector_free, object_released]
"""

VACUUM_MODULE = """\
from lerobot_policy_recent.robosuite_envs.primitives import control


def cup_to(env, task, point):
    yield from control.move_to(env, point, settle=True, stop_on_contact=True)
    if env.obs.eef_contact:  # a seal needs the rim pressed down, not just touching
        yield from control.descend_until_contact(env, point)


def suction_on(env, task):
    yield from control.actuate_gripper(env, 1.0, duration_s=0.3, max_duration_s=0.5)


def suction_off(env, task):
    yield from control.actuate_gripper(env, -1.0, duration_s=0.3, max_duration_s=0.5)
"""


@pytest.mark.slow
def test_a_bare_vacuum_cup_added_by_data_picks_as_approach_suction_on_and_lift(tmp_path):
    """One-to-many by data alone: a cup with only a move and suction on/off has nothing with the
    effects of a pick or a place, so the ontology traces the Panda's (approach, down until the cup
    rests, suction on, lift; above, down, suction off, up), the rule backend grounds it, and the
    object ends up in the bin in simulation."""
    from lerobot_policy_recent.descriptions.embodiments import get_embodiment

    cup = get_embodiment("Suction").gripper_mjcf  # the bundled cup's MJCF, by its path
    cli = _cli_with_robot(
        tmp_path, {"lab_vacuum.yaml": VACUUM_YAML.format(cup=cup), "lab_vacuum_prims.py": VACUUM_MODULE}
    )
    rule = ["--robot", "LabVacuum", "--infiller.type", "rule"]
    grounded = cli("ground", "--skill", "put_in_bin", *rule)
    assert grounded.returncode == 0, grounded.stderr[-2000:]
    pick = [
        "+    cup_to(env, task, point=[obj_pos[0], obj_pos[1], obj_pos[2] + 0.1])",
        "+    cup_to(env, task, point=obj_pos)",
        "+    suction_on(env, task)",
        "+    cup_to(env, task, point=[obj_pos[0], obj_pos[1], obj_pos[2] + 0.1])",
    ]
    assert "\n".join(pick) in grounded.stdout
    assert "line 6: pick -> cup_to (path_tracing)" in grounded.stdout
    assert "line 8: place -> cup_to (path_tracing)" in grounded.stdout
    ran = cli("run", "--task", "cube_in_bin", *rule, "--no-log", "--json")
    assert ran.returncode == 0, ran.stderr[-2000:]
    assert json.loads(ran.stdout)["success"] is True
