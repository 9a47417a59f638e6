"""The simulated world: subtask library, suites, variations, and the suction gripper's limits."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.robosuite_envs import splits
from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
from lerobot_policy_recent.robosuite_envs.observation import MAX_OBJECTS, SLOT_DIM
from lerobot_policy_recent.robosuite_envs.splits import DEV_SEEDS, RETIRED_TEST_TASKS, TEST_SEEDS, split_of
from lerobot_policy_recent.robosuite_envs.subtasks import SUBTASKS
from lerobot_policy_recent.robosuite_envs.suites import (
    STEPS_PER_SUBTASK,
    SUBTASK_STEPS,
    SUITES,
    all_tasks,
    get_suite,
    get_task,
    validation_task,
)
from lerobot_policy_recent.robosuite_envs.variations import FAR_TARGET_XY, VARIATIONS, parse_variations
from lerobot_policy_recent.skills.repository import list_skills

PANDA_REACH = 0.855  # metres, Franka's published reach (UR5e: 0.85)
FAST = {"press_button", "open_drawer", "insert_peg", "sweep_into_pen"}  # a representative subset for CI


def test_the_suites_have_the_papers_shape():
    sizes = {"kinematic": 20, "end_effector": 12, "kinematic-v1": 26, "end_effector-v1": 16}
    assert {name: len(tasks) for name, tasks in SUITES.items()} == sizes
    assert len(SUBTASKS) >= 16
    assert {s.family for s in SUBTASKS.values()} == {"kinematic", "end_effector"}
    ids = [task.task_id for task in all_tasks()]
    assert len(ids) == len(set(ids))  # one id, one task, whichever suite lists it
    for suite, tasks in SUITES.items():
        setting = suite.removesuffix("-v1")
        for task in tasks:
            assert 1 <= len(task.plan) <= 5 and task.instruction and task.suite == setting
            assert len(task.objects) <= MAX_OBJECTS
            for step in task.plan:
                subtask = SUBTASKS[step.subtask]
                assert subtask.family == setting, (task.task_id, step.subtask)
                assert set(step.args) == set(subtask.roles), (task.task_id, step.subtask)
                assert set(step.args.values()) <= set(task.object_names())


def test_the_headline_suites_are_as_long_as_the_papers_and_cover_its_categories():
    """The paper: kinematic 20 tasks of 24.6 calls on average, the longest 54; end-effector 12 tasks of 29;
    up to 5 subtasks from four categories each. Calls are counted as the paper counts them."""
    from lerobot_policy_recent.scripts.envs_cmd import call_stats

    kinematic, end_effector = call_stats(get_suite("kinematic")), call_stats(get_suite("end_effector"))
    assert kinematic["mean"] >= 24.6 and kinematic["max"] >= 50 and end_effector["mean"] >= 29
    categories = {
        "kinematic": {"single-object manipulation", "inter-object manipulation", "precision interaction", "tool use"},
        "end_effector": {"object placement", "articulated objects", "scene rearrangement", "tool use"},
    }
    for suite, wanted in categories.items():
        tasks = get_suite(suite)
        assert {SUBTASKS[step.subtask].category for task in tasks for step in task.plan} == wanted
        assert sum(3 <= len(task.plan) <= 5 for task in tasks) > len(tasks) / 2  # most tasks chain 3-5 subtasks


def test_the_test_split_is_a_draw_nobody_has_run_on_the_papers_seeds(monkeypatch):
    """No test episode exists until a test draw's seed is fixed (when a snapshot's code is frozen); the
    suites' tasks, the retired test tasks among them, are dev on every seed."""
    assert TEST_SEEDS == (0, 1, 42, 123, 2024) and not set(DEV_SEEDS) & set(TEST_SEEDS)
    assert splits.TEST_DRAW == {"kinematic": None, "end_effector": None}  # fixed only at a snapshot
    assert splits.no_test_split() is not None
    for task in all_tasks():
        assert split_of(task.task_id, 42) == "dev"
    assert len(RETIRED_TEST_TASKS["kinematic"]) == 6 and len(RETIRED_TEST_TASKS["end_effector"]) == 4
    monkeypatch.setitem(splits.TEST_DRAW, "kinematic", 90210)  # once fixed: that draw's tasks on test seeds
    assert splits.no_test_split() is None
    assert split_of("kinematic/draw90210_03", 42) == "test" and split_of("kinematic/draw90210_03", 3) == "dev"
    assert split_of("kinematic/draw101_03", 42) == "dev" and split_of("end_effector/draw90210_00", 42) == "dev"
    assert split_of("kinematic/panel_then_clear", 0) == "dev"


HELD_OUT = ["kinematic/panel_peg_lid_zone", "end_effector/drawer_then_box"]  # one per paper-length suite by default


@pytest.mark.parametrize(
    "task_id",
    [
        pytest.param(t, marks=() if t in HELD_OUT else pytest.mark.slow)
        for ts in RETIRED_TEST_TASKS.values()
        for t in ts
    ],
)
def test_the_panda_reference_can_do_every_held_out_task_on_a_dev_seed(task_id, panda_agent):
    """Feasibility only, and only on a dev seed: no test episode is run to tune anything. The Panda
    runs each setting's skills through that setting's source API (the Franka Hand's, by name, for
    the end-effector tasks)."""
    result = run_episode(panda_agent, task_id, panda_agent.source_robot(task_id), seed=DEV_SEEDS[0])
    assert result.success, result.failures
    assert all(skill.diagnosis.compatible for skill in result.grounding.skills)


def test_every_subtask_has_a_reference_skill_and_a_single_subtask_task():
    assert set(SUBTASKS) <= set(list_skills())
    for name in SUBTASKS:
        assert validation_task(name).subtasks() == [name]


def test_a_subtask_alone_gets_the_steps_the_paper_length_suites_give_it():
    """Three blocks in a row get three blocks' steps there as in a long task, not the -v1 suites' 400."""
    for name in SUBTASKS:
        assert validation_task(name).max_steps == SUBTASK_STEPS.get(name, STEPS_PER_SUBTASK) + 200, name
    assert validation_task("arrange_in_row").max_steps > get_task("end_effector/arrange_row").max_steps


@pytest.mark.parametrize(
    "subtask", [pytest.param(s, marks=() if s in FAST else pytest.mark.slow) for s in sorted(SUBTASKS)]
)
def test_panda_reference_skill_achieves_the_subtask(subtask, panda_agent):
    from lerobot_policy_recent.recent_plugin.episode import run_episode

    task_id = validation_task(subtask).task_id
    result = run_episode(panda_agent, task_id, panda_agent.source_robot(task_id), seed=0)
    assert result.success, result.failures


def test_success_is_latched_per_subtask_in_plan_order():
    env = RecentEnv(task="kinematic/plate_then_button", robot="Panda", render_mode="none")
    obs, info = env.reset(seed=0)
    assert info == {"is_success": False, "gc": 0.0, "subtasks_done": 0, "held": ()}
    inner = env._env
    inner._latched_state["button"] = 1.0  # the button pressed first does not count: the plate comes first
    inner._snapshot = None  # observe the pressed button now
    inner._track_progress()
    assert inner.observe().objects["button"].state == 1.0
    assert inner.achieved == [False, False]
    env.close()


def test_same_seed_same_scene_for_every_suite_task():
    for task_id in ("kinematic/tidy_bench", "end_effector/cabinet_routine"):
        env = RecentEnv(task=task_id, robot="Panda", render_mode="none")
        a, _ = env.reset(seed=42)
        b, _ = env.reset(seed=42)
        c, _ = env.reset(seed=2024)
        np.testing.assert_allclose(a["environment_state"], b["environment_state"])
        assert not np.allclose(a["environment_state"], c["environment_state"])
        env.close()


# ------------------------------------------------------------------------------------ variations
def _run_idle(env, steps):
    hold = np.zeros(7)
    for _ in range(steps):
        obs, *_ = env.step(hold)
    return obs


def _slot(env, name):
    i = env.spec_task.object_names().index(name)
    return slice(i * SLOT_DIM, (i + 1) * SLOT_DIM)


def test_variation_names_parse_and_unknown_ones_list_the_valid_ones():
    assert parse_variations("off") == () and parse_variations("all") == tuple(VARIATIONS)
    assert parse_variations("on") == ("pose_perturbation", "sensing_noise", "obstacle")
    with pytest.raises(ValueError, match="known: pose_perturbation"):
        parse_variations("earthquake")


def test_the_mix_puts_every_variation_in_play_in_its_stated_share_seeded():
    from lerobot_policy_recent.robosuite_envs.variations import MIX_SHARES, episode_variations

    assert set(MIX_SHARES) == set(VARIATIONS) and parse_variations("mix") == ("mix",)
    draws = [episode_variations(("mix",), f"kinematic/t{i % 7}", seed) for i in range(70) for seed in range(20)]
    for name, share in MIX_SHARES.items():
        assert abs(sum(name in d for d in draws) / len(draws) - share) < 0.05, name
    assert episode_variations(("mix",), "kinematic/tidy_bench", 42) == episode_variations(
        ("mix",), "kinematic/tidy_bench", 42
    )
    assert episode_variations(("obstacle",), "kinematic/tidy_bench", 42) == ("obstacle",)  # a fixed set stays fixed


def test_an_env_with_the_mix_applies_each_episodes_draw():
    from lerobot_policy_recent.robosuite_envs.variations import episode_variations

    env = RecentEnv(task="kinematic/cube_on_plate", robot="Panda", render_mode="none", variations="mix")
    seeds = [s for s in range(200) if "non_flat" in episode_variations(("mix",), "kinematic/cube_on_plate", s)][:1]
    seeds += [s for s in range(200) if not episode_variations(("mix",), "kinematic/cube_on_plate", s)][:1]
    built = {"non_flat", "porous", "odd_obstacle"}  # then a set that changes no object: the plan must change still

    def plan_only(seed: int) -> bool:
        drawn = set(episode_variations(("mix",), "kinematic/cube_on_plate", seed))
        return bool(drawn) and not drawn & built

    seeds += [s for s in range(200) if plan_only(s)][:1]
    assert len(seeds) == 3
    for seed in seeds:  # a ball in one episode, nothing changed in the next: the model is rebuilt between
        env.reset(seed=seed)
        assert env.episode_variations == episode_variations(("mix",), "kinematic/cube_on_plate", seed)
        assert (env._env.task_spec.spec("cube").kind == "sphere") is ("non_flat" in env.episode_variations)
    env.close()


def test_pose_perturbation_moves_the_object_after_planning_before_the_grasp():
    env = RecentEnv(task="kinematic/cube_on_plate", robot="Panda", render_mode="none", variations="pose_perturbation")
    env.reset(seed=1)
    step = env._env.plan.perturb_step
    before = env._env.observe().objects["cube"].pos.copy()
    _run_idle(env, step - 1)
    assert np.allclose(env._env.observe().objects["cube"].pos[:2], before[:2], atol=2e-3)
    _run_idle(env, 2)
    shift = np.linalg.norm(env._env.observe().objects["cube"].pos[:2] - before[:2])
    assert 0.035 < shift < 0.065
    env.close()


def test_a_displaced_object_comes_to_rest_on_what_it_lands_over_never_inside_it():
    """assembly_panel, seed 7: the lid is displaced onto the volume button's base. It falls onto the
    base and rests there, tilted, instead of being set inside it, jammed (its grasp kept slipping)."""
    env = RecentEnv(task="kinematic/assembly_panel", robot="Panda", render_mode="none", variations="pose_perturbation")
    env.reset(seed=7)
    inner = env._env
    flat_z = inner.observe().objects["lid"].pos[2]
    _run_idle(env, inner.plan.perturb_step + 40)
    lid = {g for g, owner in inner._geom_owner.items() if owner == "lid"}
    deepest = {}
    for contact in inner.sim.data.contact[: inner.sim.data.ncon]:
        pair = {contact.geom1, contact.geom2}
        if pair & lid and len(pair - lid) == 1:
            other = inner._geom_owner.get((pair - lid).pop(), "table")
            deepest[other] = min(deepest.get(other, 0.0), contact.dist)
    assert "volume" in deepest and deepest["volume"] > -0.002  # on the base, not 5 mm into it
    assert inner.observe().objects["lid"].pos[2] > flat_z + 0.005
    env.close()


def test_sensing_noise_perturbs_what_is_observed_not_the_world():
    env = RecentEnv(task="kinematic/cube_on_plate", robot="Panda", render_mode="none", variations="sensing_noise")
    obs, _ = env.reset(seed=0)
    true = env._env.observe().objects["cube"].pos
    seen = obs["environment_state"][_slot(env, "cube")][:3]
    error = np.abs(seen - true)
    assert error.max() > 1e-4 and error.max() < 0.02
    env.close()


def test_obstacle_lands_on_the_target_mid_task_and_cannot_be_grasped():
    env = RecentEnv(task="kinematic/cube_on_plate", robot="Panda", render_mode="none", variations="obstacle")
    obs, _ = env.reset(seed=0)
    assert obs["environment_state"][_slot(env, "obstacle")][7] == 0.0  # not present yet
    obs = _run_idle(env, env._env.plan.obstacle_step + 5)
    row = obs["environment_state"][_slot(env, "obstacle")]
    plate = env._env.observe().objects["plate"].pos
    assert row[7] == 1.0 and np.linalg.norm(row[:2] - plate[:2]) < 0.03
    assert min(env.spec_task.spec("obstacle").size[:2]) > 0.085  # wider than any gripper opens
    env.close()


def test_an_odd_obstacle_is_a_drawn_shape_size_and_mass_that_lands_on_the_target_and_is_observed_as_it_is():
    """Shapes the checks were never written for: the model is built anew when another seed draws another one,
    the obstacle weighs what was drawn, and perception reports its extents, not the slab's."""
    from lerobot_policy_recent.robosuite_envs.variations import ODD_MASS_KG, ODD_OBSTACLES, odd_obstacle

    draws = {seed: odd_obstacle("kinematic/cube_on_plate", seed) for seed in range(30)}
    assert {d.kind for d in draws.values()} == {kind for kind, _, _ in ODD_OBSTACLES}
    assert draws[3] == odd_obstacle("kinematic/cube_on_plate", 3)  # seeded
    env = RecentEnv(task="kinematic/cube_on_plate", robot="Panda", render_mode="none", variations="odd_obstacle")
    for seed in (3, 7):  # a wide slab, then a post
        odd = draws[seed]
        env.reset(seed=seed)
        inner = env._env
        assert inner.task_spec.spec("obstacle").kind == odd.kind
        body = inner.sim.model.body_name2id(inner._objects["obstacle"].root_body)
        assert inner.sim.model.body_mass[body] == pytest.approx(odd.mass_kg) and ODD_MASS_KG[0] <= odd.mass_kg
        obs = _run_idle(env, inner.plan.obstacle_step + 40)
        row = obs["environment_state"][_slot(env, "obstacle")]
        plate = inner.observe().objects["plate"].pos
        assert row[7] == 1.0 and np.linalg.norm(row[:2] - plate[:2]) < 0.04  # landed on the target
        np.testing.assert_allclose(row[8:11], odd.size, atol=1e-6)  # size_x, size_y, height as drawn
    assert draws[7].kind == "post" and draws[3].kind == "slab"
    env.close()


def test_far_perturbation_moves_the_object_twice_as_far_as_the_papers():
    env = RecentEnv(task="kinematic/cube_on_plate", robot="Panda", render_mode="none", variations="far_perturbation")
    env.reset(seed=1)
    before = env._env.observe().objects["cube"].pos.copy()
    _run_idle(env, env._env.plan.perturb_step + 1)
    shift = np.linalg.norm(env._env.observe().objects["cube"].pos[:2] - before[:2])
    assert 0.075 < shift < 0.125
    env.close()


@pytest.mark.parametrize("variation, quantity, factor", [("slippery", "friction", 0.08), ("heavy", "mass", 8.0)])
def test_slippery_and_heavy_objects(variation, quantity, factor):
    plain = RecentEnv(task="kinematic/lift_cube", robot="Panda", render_mode="none")
    varied = RecentEnv(task="kinematic/lift_cube", robot="Panda", render_mode="none", variations=variation)
    values = []
    for env in (plain, varied):
        env.reset(seed=0)
        model, cube = env._env.sim.model, env._env._objects["cube"]
        if quantity == "friction":
            values.append(model.geom_friction[model.geom_name2id(cube.contact_geoms[0]), 0])
        else:
            values.append(model.body_mass[model.body_name2id(cube.root_body)])
        env.close()
    assert values[1] == pytest.approx(values[0] * factor)


def test_far_target_leaves_the_smaller_robots_workspace():
    env = RecentEnv(task="kinematic/cube_on_plate", robot="Panda", render_mode="none", variations="far_target")
    env.reset(seed=0)
    plate = env._env.observe().objects["plate"].pos
    assert np.allclose(plate[:2], FAR_TARGET_XY)
    shoulder = np.array([-0.56, 0.0, 0.912 + 0.333])  # Panda base on the table's edge + shoulder height
    assert np.linalg.norm(plate - shoulder) > PANDA_REACH
    env.close()


# ------------------------------------------------------------------------------------ suction
@pytest.mark.parametrize("variation", ["", "non_flat", "porous"])
def test_suction_holds_a_flat_box_but_not_a_ball_or_a_porous_box(variation, panda_agent):
    from lerobot_policy_recent.recent_plugin.episode import run_episode

    env = RecentEnv(task="kinematic/lift_cube", robot="Suction", render_mode="none", variations=variation)
    result = run_episode(panda_agent, "kinematic/lift_cube", "Suction", seed=0, env=env)
    if variation:
        assert not result.success
        assert result.failures and result.failures[0].category.value == "grasp_lost"
    else:
        assert result.success, result.failures
    env.close()


def test_a_seal_that_fails_mid_carry_drops_the_object_and_never_holds_it_again(panda_agent):
    """seal_failure: the cube the cup carries leaks after 1.5 s; a dev seed's episode that succeeds
    without it then fails (RECENT has no check for it: the release runs empty, as reported)."""
    from lerobot_policy_recent.robosuite_envs.tabletop import LEAK_AFTER_STEPS

    task = "end_effector/cube_into_drawer"  # a Franka Hand skill: the rule path grounds it on the cup
    env = RecentEnv(task=task, robot="Suction", render_mode="none", variations="seal_failure")
    result = run_episode(panda_agent, task, "Suction", seed=DEV_SEEDS[0], env=env)
    assert env._env._leaked == {"cube"} and env._env.plan.leak_object == "cube" and LEAK_AFTER_STEPS == 30
    assert not result.success and "cube" not in env._env.observe().truth.held
    env.close()
    assert run_episode(panda_agent, task, "Suction", seed=DEV_SEEDS[0]).success


def test_suction_stacks_a_tower_the_held_block_going_where_the_skill_places_it(panda_agent):
    """``place(obj_name=base)`` becomes ``move_gripper_to(obj_name=base)`` and ``detach_vacuum_handle()``:
    the move centres the block the cup carries over the base, lifted by as much as it hangs below
    the cup, and the detach lowers it until it rests there before the suction goes off."""
    from lerobot_policy_recent.recent_plugin.episode import run_episode

    result = run_episode(panda_agent, "end_effector/build_tower", "Suction", seed=0)
    assert result.success and not result.failures and not result.adaptations


def test_suction_cup_lowered_onto_a_knob_stops_on_it_and_pulls_the_drawer(panda_agent):
    """``move_to_position`` to a knob's centre stops where the cup rests on the knob (it cannot go
    inside), so the Franka Hand's handle grasp, traced as moves, grounds to move-then-suck."""
    from lerobot_policy_recent.recent_plugin.episode import run_episode

    result = run_episode(panda_agent, "end_effector/open_drawer", "Suction", seed=0)
    assert result.success and not result.failures


@pytest.mark.parametrize("robot", ["Panda", "UR5e", "Sawyer", "Robotiq85", "Suction"])
def test_every_embodiment_builds_a_suite_scene_and_steps(robot):
    env = RecentEnv(task="end_effector/cabinet_routine", robot=robot, render_mode="none")
    obs, _ = env.reset(seed=0)
    obs, *_ = env.step(np.zeros(7))
    assert np.all(np.isfinite(obs["agent_pos"])) and obs["environment_state"][_slot(env, "drawer")][7] == 1.0
    assert env.embodiment.arm_dof == len(env._env.robots[0].robot_arm_joints)  # the joint slots it fills
    env.close()


def _suction_on_arrange_row():
    """The Suction env on ``arrange_row`` (seed 0), a session that follows it, and ``run``, which
    steps a primitive's actions through the env."""
    from lerobot_policy_recent.robosuite_envs.observation import Observation
    from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession

    env = RecentEnv(task="end_effector/arrange_row", robot="Suction", render_mode="none")
    names = env.spec_task.object_names()
    raw, _ = env.reset(seed=0)
    session = RobotSession("Suction", Observation.decode(raw["agent_pos"], raw["environment_state"], names))

    def run(steps, each=lambda: None) -> None:
        for action in steps:
            observed, *_ = env.step(action)
            session.update(Observation.decode(observed["agent_pos"], observed["environment_state"], names))
            each()

    return env, session, run


def test_a_release_aimed_below_where_the_load_comes_to_rest_sets_it_down_instead_of_timing_out():
    """A release height computed from a noisy read (sigma 4 mm) can lie under where the held block
    comes to rest on the table: the cup cannot lower it further. The lowering ends once the hand has
    stalled just above the target with the load in hand, and the block is let go (it timed out 1.1 cm
    short in arrange_row on Suction, seed 123)."""
    from lerobot_policy_recent.robosuite_envs.primitives import control

    env, session, run = _suction_on_arrange_row()
    try:
        block = session.obs.objects["red"].pos.copy()
        run(control.suction_grasp_at(session, block))
        assert session.obs.held() == "red" and session.obs.vacuum == 1.0  # what the cup's sensor and perception say
        hang = control.held_offset(session)[2]  # the block hangs below the cup: aim the grip site above it
        run(control.release_at(session, [block[0] + 0.1, block[1], block[2] - 0.012 - hang]))
        placed = session.obs.objects["red"]
        assert session.obs.held() is None and abs(placed.pos[2] - block[2]) < 0.005  # on the table, 10 cm over
    finally:
        env.close()


def _off_line(session, goal):
    """How far the grip site strays from the line from where it is now to ``goal``: the list each call
    of the returned function appends the current distance to."""
    start = session.obs.eef_pos.copy()
    direction = (goal - start) / np.linalg.norm(goal - start)
    off_line: list[float] = []

    def measure() -> None:
        along = session.obs.eef_pos - start
        off_line.append(float(np.linalg.norm(along - (along @ direction) * direction)))

    return off_line, measure


def test_a_free_cup_moves_along_its_line_so_a_sweep_pushes_what_lies_on_it():
    """The cup's move, sealed on nothing and pressed on nothing, goes straight from where it is to its goal,
    as the other end-effector APIs' moves go: closing each axis on its own, the cup ran 45 degrees until
    one axis was done, sideswiped the block a sweep was to push, and left it behind."""
    from lerobot_policy_recent.robosuite_envs.primitives import suction
    from lerobot_policy_recent.robosuite_envs.primitives.session import TaskContext

    env, session, run = _suction_on_arrange_row()
    try:
        goal = session.obs.eef_pos + np.array([0.2, 0.06, -0.05])
        off_line, measure = _off_line(session, goal)
        run(suction.move_to_position(session, TaskContext(session), goal), measure)
        assert np.linalg.norm(session.obs.eef_pos - goal) < 0.02 and max(off_line) < 0.01
    finally:
        env.close()


def test_a_cup_carrying_a_lifted_load_moves_along_its_line_and_one_on_the_table_still_drags():
    """A load the cup has lifted hangs free: its carry is planned and follows its line, as a free cup's
    moves do, and the load's centre goes over the goal. Closing each axis on its own, the carry of a
    row's middle block bent 4 cm off its line, brushed the block already in its slot and pushed it
    3.5 cm out (line_up_then_sweep, seed 11). A load set down on the table is dragged again, each
    axis pressing on."""
    from lerobot_policy_recent.robosuite_envs.primitives import control, suction
    from lerobot_policy_recent.robosuite_envs.primitives.session import TaskContext

    env, session, run = _suction_on_arrange_row()
    try:
        block = session.obs.objects["red"].pos.copy()
        run(control.suction_grasp_at(session, block + np.array([0.015, 0.0, 0.0])))  # sealed off its centre
        assert session.obs.held() == "red" and control.load_hangs(session)
        assert abs(control.held_offset(session)[0]) > 0.008
        goal = session.obs.eef_pos + np.array([0.2, 0.06, 0.0])
        off_line, measure = _off_line(session, goal)
        run(suction.move_to_position(session, TaskContext(session), goal), measure)
        assert session.obs.held() == "red" and max(off_line) < 0.01
        centred = np.linalg.norm(session.obs.objects["red"].pos[:2] - goal[:2])
        assert centred < 0.011  # the load over the goal (uncentred: 1.8 cm off)
        down = session.obs.eef_pos.copy()
        down[2] = block[2] - 0.012 - control.held_offset(session)[2]  # the grip site where the block would rest
        run(control.move_to(session, down, set_down=True))
        assert session.obs.held() == "red" and not control.load_hangs(session)  # resting on the table
    finally:
        env.close()
