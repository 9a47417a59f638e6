"""Real simulated episodes: a skill runs unmodified on its source robot, and grounded on the targets."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.episode import run_episode, unmet_subtask
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.robosuite_envs.observation import ObjectState, Observation
from lerobot_policy_recent.robosuite_envs.tasks import PlanStep


def test_panda_runs_the_reference_skill_unmodified(ontology, rule_infiller):
    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), infiller=rule_infiller, ontology=ontology)
    result = run_episode(agent, "cube_in_bin", "Panda", seed=0)
    assert result.success, result.failures
    assert result.grounding.skills[0].diagnosis.compatible and result.generated_tokens == 0


def test_grounded_episode_on_sawyer_with_the_real_lm(ontology, llama_infiller):
    """The README's main job, the product's default method: the ontology renders every span it
    decides (Sawyer's pick takes the object's name, which the point it grasps at gives), the LM is
    loaded but asked nothing, and the grounded skill runs in robosuite."""
    agent = RecentAgent(RecentSettings(), infiller=llama_infiller, ontology=ontology)
    result = run_episode(agent, "cube_in_bin", "Sawyer", seed=0)
    assert result.success, (result.failures, result.grounding.skills[0].diff())
    calls = result.grounding.skills[0].calls
    assert calls and all(c.rendered for c in calls) and result.generated_tokens == 0
    assert "target_object=obj" in result.grounding.skills[0].code

    again = run_episode(agent, "cube_in_bin", "Sawyer", seed=0)
    assert again.grounding.cached and again.grounding.skills[0] is result.grounding.skills[0]
    assert again.success, again.failures
    # the LM samples (the default): another seed is another draw, grounded afresh
    other = run_episode(agent, "cube_in_bin", "Sawyer", seed=1)
    assert not other.grounding.cached and other.success, other.failures


def test_suction_gripper_really_holds_and_releases(ontology):
    """The vacuum cup lifts the cube by contact + adhesion and drops it into the bin when switched off.

    The Panda's place names a point; the cup lets go where it is. The point is placed by the bin's
    position alone, so the ontology names the bin for the move over it: the fast path renders
    everything, and the LM (a script here) is not asked."""
    from doubles import ScriptedInfiller

    from lerobot_policy_recent.recent_plugin.methods import method_named

    lm = ScriptedInfiller(["move_gripper_to(env, task, obj_name=receptacle)\ndetach_vacuum_handle(env, task)"])
    settings = RecentSettings(infiller=RuleConfig(), method=method_named("recent+fast-path"))
    result = run_episode(RecentAgent(settings, infiller=lm, ontology=ontology), "cube_in_bin", "Suction", seed=0)
    assert result.success, result.failures
    code = result.grounding.skills[0].code
    assert "attach_vacuum_handle(env, task, handle_name=obj)" in code and "detach_vacuum_handle(env, task)" in code
    assert "move_gripper_to(env, task, obj_name=receptacle)" in code
    assert lm.units == []  # nothing was left for the LM


@pytest.mark.parametrize("robot", ["Robotiq85", "Suction"])
def test_end_effector_targets_open_and_close_the_drawer_and_box(panda_agent, robot):
    """The Franka Hand's handle grasp by name: the 2F-85's by name too, the cup's traced as moves."""
    result = run_episode(panda_agent, "end_effector/drawer_and_box", robot, seed=0)
    assert result.success, result.failures
    opening = next(s for s in result.grounding.skills if s.skill == "open_drawer")
    grasp = opening.diagnosis.conflicts[0]
    assert opening.valid and grasp.original == "grasp_handle"
    assert grasp.span_type == ("api_substitution" if robot == "Robotiq85" else "path_tracing")


@pytest.mark.slow
@pytest.mark.parametrize(
    ("robot", "task"),
    [
        ("Sawyer", "cube_in_bin"),
        ("Robotiq85", "end_effector/cube_into_drawer"),
        ("Suction", "end_effector/cube_into_drawer"),
    ],
)
def test_grounded_episode_on_end_effector_targets_with_the_real_lm(ontology, llama_infiller, robot, task):
    """The grippers ground the end-effector setting's own skills (the Franka Hand's name-based API).
    The Panda's ``cube_in_bin`` on them is another setting: its place names a point computed from
    the bin's, which the ontology leaves to the LM, and the 1.5B names the cube (since ab8db23)."""
    agent = RecentAgent(RecentSettings(), infiller=llama_infiller, ontology=ontology)
    result = run_episode(agent, task, robot, seed=0)
    assert result.success, (result.failures, result.grounding.skills[0].diff())


def test_sawyer_reaches_the_whole_table(ontology):
    """Its base joint turns (no mount contact locks it): the hand reaches both halves of the table."""
    from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
    from lerobot_policy_recent.robosuite_envs.primitives.control import servo_action
    from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession

    env = RecentEnv(task="cube_in_bin", robot="Sawyer")
    try:
        for target in ([0.0, -0.15, 0.9], [0.1, 0.15, 0.9]):
            raw, _ = env.reset(seed=0)
            names = env.spec_task.object_names()
            session = RobotSession("Sawyer", Observation.decode(raw["agent_pos"], raw["environment_state"], names))
            for _ in range(150):
                session.update(Observation.decode(raw["agent_pos"], raw["environment_state"], names))
                raw, *_ = env.step(servo_action(session, np.array(target)))
            assert np.linalg.norm(session.obs.eef_pos - target) < 0.02, (target, session.obs.eef_pos)
    finally:
        env.close()


def test_sawyer_presses_the_button_its_loose_tracking_would_stop_short_of(panda_agent):
    """Sawyer's moves accept 2 cm (its tracking settles that far off), but only once the arm has
    stopped: returning on entering the 2 cm ball ended the press above the cap, never pushing it."""
    result = run_episode(panda_agent, "kinematic/press_button", "Sawyer", seed=0)
    assert result.success and not result.failures
    assert "sawyer_move_to(env, task, target_pos=[cap_pos[0], cap_pos[1], cap_pos[2] + 0.01" in (
        result.grounding.skills[0].code
    )


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 42, 123, 2024])
def test_rule_grounding_succeeds_on_every_paper_seed(ontology, rule_infiller, seed):
    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), infiller=rule_infiller, ontology=ontology)
    assert run_episode(agent, "cube_in_bin", "UR5e", seed=seed).success


def test_a_failed_subtask_names_itself_and_what_was_observed():
    """ "subtask_failed" is never a bare label: the record says which step the env did not count, and
    how its objects ended up (a drawer's state is its opening)."""
    plan = [
        PlanStep("open_drawer", "open_drawer", {"drawer": "drawer"}),
        PlanStep("close_drawer", "close_drawer", {"drawer": "drawer"}),
    ]
    final = Observation(
        eef_pos=np.zeros(3),
        eef_quat=np.array([1.0, 0.0, 0.0, 0.0]),
        gripper_opening=0.0,
        objects={"drawer": ObjectState(np.array([-0.038, -0.165, 0.857]), np.array([0, 0, 0, 1.0]), state=-0.0002)},
    )
    assert unmet_subtask(plan, 0, final, finished=True) == (
        "open_drawer (subtask 1 of 2) not achieved when the plan ended; "
        "observed: drawer=drawer at [-0.038, -0.165, 0.857] state 0.000"
    )
    assert unmet_subtask(plan, 1, final, finished=False).startswith(
        "close_drawer (subtask 2 of 2) not achieved at the step limit"
    )
    assert unmet_subtask(plan, 2, final, finished=True) == ""  # every step achieved: nothing unmet


def test_a_subtask_left_unachieved_says_what_the_last_failed_check_saw():
    """Kinova3's sweep into the pen ran again for a block half out of it and reached the step limit:
    the record says so, not only where the objects ended."""
    from lerobot_policy_recent.recent_plugin.episode import last_failed_check
    from lerobot_policy_recent.recent_plugin.grounding.attempts import AdaptationEvent

    seen = "after sweep_into_pen: blue rests at [0.062, 0.062, 0.823], 0.7 cm of it outside pen's box"
    events = [
        AdaptationEvent("revise", "sweep_into_pen", 8, ("fingers_clear",), "red lies in the way", "", "", 0),
        AdaptationEvent("revise", "sweep_into_pen", 27, ("placement_reached",), seen, "", "", 0),
    ]
    assert last_failed_check(events) == f"; the last check that failed: placement_reached: {seen}"
    assert last_failed_check([]) == ""
