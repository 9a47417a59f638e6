"""The baselines (cap, repair, agentless): prompts, how each answers an error, and their accounting.

Scripted completions drive the control flow deterministically in real robosuite episodes; the
real 1.5B writes a cap program in the slow test at the end.
"""

from __future__ import annotations

from dataclasses import replace

import pytest
from doubles import ScriptedInfiller, library_with

from lerobot_policy_recent.evaluation.baselines.program_prompt import PROGRAM, STATEMENT
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.recent_plugin.grounding.budget import CallBudget
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.methods import method_named
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import build_prompt
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.robosuite_envs.suites import get_task
from lerobot_policy_recent.skills.repository import load_skill

UR5E_BODY = """obj_pos = task.get_object_position(obj)
    bin_pos = task.get_object_position(receptacle)
    open_ur5_ee(env, task)
    ur5_grasp_at(env, task, grasp_pos=obj_pos)
    drop_pos = [bin_pos[0], bin_pos[1], bin_pos[2] + 0.1]
    ur5_release_at(env, task, place_pos=drop_pos)"""
PANDA_LINE = "open_gripper(env, task)"  # what a small model copies from the example


def _agent(ontology, method: str, texts: list[str], library: str | None = None) -> tuple[RecentAgent, ScriptedInfiller]:
    """``method`` with ``texts`` for its LM; ``library``: a skill library of the test's (never validated)."""
    infiller = ScriptedInfiller(texts)
    chosen = method_named(method)
    if library is not None:
        chosen.offline_validation = False  # RECENT's own: a library of the test's was never validated
    settings = RecentSettings(infiller=RuleConfig(), method=chosen, skill_library=library)
    return RecentAgent(settings, ontology=ontology, infiller=infiller), infiller


def test_cap_prompt_shows_api_example_and_task_but_not_the_scene(ontology):
    agent, infiller = _agent(ontology, "cap", [UR5E_BODY])
    grounded, _ = agent.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    assert grounded.valid and grounded.calls[0].span_type == PROGRAM
    prefix = infiller.units[0].prefix
    assert "def put_in_bin_panda(env, task" in prefix  # the reference skill as the in-context example
    assert "#   ur5_grasp_at(env, task, grasp_pos: position [m]" in prefix
    assert "# Task: Pick the cube and place it in the bin." in prefix
    assert prefix.rstrip().endswith('"""')  # the span is the body, right after the signature and docstring
    assert "Scene objects" not in prefix and "Workspace" not in prefix


def test_agentless_prompt_adds_descriptions_objects_and_workspace(ontology):
    agent, infiller = _agent(ontology, "agentless", [UR5E_BODY])
    agent.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    prefix = infiller.units[0].prefix
    assert "# Scene objects: cube (box), bin (bin)" in prefix
    assert "# Workspace: x in [-0.40, 0.40] m" in prefix
    assert "  -- " in prefix  # each primitive's description


def test_progprompt_imports_the_targets_actions_lists_the_objects_and_asks_for_a_translation(ontology):
    agent, infiller = _agent(ontology, "progprompt", [UR5E_BODY])
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    assert result.success
    prefix = infiller.units[0].prefix
    assert "from ur5e_actions import ur5_grasp_at  # ur5_grasp_at(env, task, grasp_pos: position [m]" in prefix
    assert "objects = ['cube', 'bin']" in prefix and "def put_in_bin_panda(env, task" in prefix
    assert "# Translate the reference program from Panda actions to the UR5e actions imported above" in prefix
    assert prefix.rstrip().endswith('"""')  # then the body: the whole program is the span


def test_cap_runs_a_wrong_program_until_it_fails_then_regenerates_it_with_pythons_error(ontology):
    """The paper's protocol: no interface validation; the Panda call fails when reached (NameError),
    and cap regenerates the whole program with that error appended, from the current state."""
    wrong = UR5E_BODY.replace("open_ur5_ee(env, task)", PANDA_LINE)
    agent, infiller = _agent(ontology, "cap", [wrong, UR5E_BODY])
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    assert result.success
    grounded = result.grounding.skills[0]
    assert [c.kind for c in grounded.calls] == ["ground"] and grounded.valid  # it ran as written
    assert [(c.kind, c.span_type) for c in result.runtime_calls] == [("repair", PROGRAM)]
    assert result.failures == [] and result.adaptations[0].checks == ("hallucinated_api",)  # the taxonomy
    feedback = infiller.units[1].hints.feedback
    assert "NameError: name 'open_gripper' is not defined" in feedback  # Python's own error
    # the paper's accounting: the first program is GO-pre, the repair is GO, one interruption
    assert result.generated_tokens == 14 and result.skill_tokens == 100 and result.adaptation_tokens == 7
    assert result.go == pytest.approx(7.0) and result.go_pre == pytest.approx(7.0)
    assert result.ei == 1 and result.it == pytest.approx(0.01)
    assert result.rule_coverage == 0.0  # a whole program is nothing the ontology decided


def test_a_regenerated_program_replaces_everything_the_failed_one_had_left_to_run(ontology):
    """The regenerated program goes on from where the old one failed; no statement of the old one
    runs after it (a regenerated 2F-85 drawer opening, correct, then failed on the old program's
    Franka Hand ``release_handle``)."""
    wrong = UR5E_BODY.replace("open_ur5_ee(env, task)", PANDA_LINE).replace(
        "ur5_release_at(env, task, place_pos=drop_pos)", "close_gripper(env, task)"
    )
    regenerated = "open_ur5_ee(env, task)\n    ur5_grasp_at(env, task, grasp_pos=obj_pos)"  # stops short of the bin
    agent, _ = _agent(ontology, "cap", [wrong, regenerated])
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    assert not result.success  # the new program ran to its end, and the skill with it
    assert [c.kind for c in result.runtime_calls] == ["repair"]  # the old close_gripper never ran to fail


@pytest.mark.parametrize("method", ["repair", "agentless"])
def test_repair_and_agentless_rewrite_only_the_statement_that_failed(ontology, method):
    wrong = UR5E_BODY.replace("open_ur5_ee(env, task)", PANDA_LINE)
    agent, infiller = _agent(ontology, method, [wrong, "open_ur5_ee(env, task)"])
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    assert result.success
    assert [(c.kind, c.span_type, c.span) for c in result.runtime_calls] == [("repair", STATEMENT, PANDA_LINE)]
    assert "NameError" in infiller.units[1].hints.feedback


def test_unsafe_or_empty_output_is_never_accepted(ontology):
    agent, _ = _agent(ontology, "cap", ["import os\n    os.system('true')", "", "__import__('os')"] * 2)
    grounded, _ = agent.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    assert not grounded.valid
    assert [c.category for c in grounded.calls] == ["non_executable", "empty_continuation", "non_executable"]
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0, max_steps=20)  # an invalid program is not cached
    assert result.success is False and result.steps <= 21  # nothing ran: the robot held still


@pytest.mark.parametrize(
    ("method", "repair", "span_type"),
    [
        ("cap", UR5E_BODY, PROGRAM),  # the whole program again, from the current state
        ("repair", "obj_pos = task.get_object_position(obj)", STATEMENT),  # only the failed statement
    ],
)
def test_a_run_time_failure_is_repaired_the_baselines_way(ontology, method, repair, span_type):
    ghost = UR5E_BODY.replace("get_object_position(obj)", 'get_object_position("ghost")')
    agent, infiller = _agent(ontology, method, [ghost, repair])
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    assert result.success
    assert [c.kind for c in result.runtime_calls] == ["repair"]
    assert result.runtime_calls[0].span_type == span_type
    assert "object 'ghost' not found" in infiller.units[1].hints.feedback
    assert [a.kind for a in result.adaptations] == ["repair"] and result.adaptations[0].after
    assert result.ei == 1


@pytest.mark.slow
def test_real_lm_writes_a_cap_program(ontology, llama_infiller):
    agent = RecentAgent(RecentSettings(method=method_named("cap")), ontology=ontology, infiller=llama_infiller)
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    grounded = result.grounding.skills[0]
    assert grounded.calls and grounded.calls[0].kind == "ground" and grounded.calls[0].generated_tokens > 0
    sent = grounded.calls[0].prompt  # exactly what the model was sent: the system line, the instruction, the program
    assert sent.startswith("<|im_start|>system\nYou write Python skill code") and "<|im_start|>user\n" in sent
    assert result.go_pre > 50.0  # a whole program: far above RECENT's localized edits


def _rule_body(ontology, skill: str, task: str) -> str:
    """The UR5e body RECENT's rule backend grounds for ``skill`` (a correct program to script with)."""
    from lerobot_policy_recent.ontology.skill_code import body_span

    grounded, _ = RecentAgent(RecentSettings(infiller=RuleConfig()), ontology=ontology).ground(
        skill, "UR5e", get_task(task)
    )
    start, end = body_span(grounded.code, grounded.entry)
    return grounded.code[start:end]


def test_a_safe_but_wrong_program_runs_up_to_the_failing_call_and_gc_counts_what_ran(ontology):
    """Two subtasks: the first program is right, the second passes a keyword the robot's primitive
    lacks. It runs until that call raises Python's TypeError; the first subtask stays achieved."""
    task = "kinematic/plate_then_button"
    place = _rule_body(ontology, "place_on_plate", task)
    press = _rule_body(ontology, "press_button", task).replace("(env, task", "(env, task, speed=1.0", 1)
    infiller = ScriptedInfiller([place, press])
    agent = RecentAgent(
        # two calls, the two programs: none is left to repair with (a baseline's loop ends with its budget)
        RecentSettings(infiller=RuleConfig(), method=method_named("cap"), max_lm_calls=2),
        ontology=ontology,
        infiller=infiller,
    )
    result = run_episode(agent, task, "UR5e", seed=0)
    assert all(s.valid for s in result.grounding.skills)  # both ran as written: no interface validation
    assert not result.success and result.gc == pytest.approx(0.5)  # the plate subtask counts
    (failure,) = result.failures
    assert failure.skill == "press_button" and failure.category == "hallucinated_kwarg"
    assert failure.message.startswith("TypeError:") and "speed" in failure.message


HOSTILE_OUTPUT = [  # what an LM must never get to run, whichever method asked it
    "open({path!r}, 'w').write('x')",
    "__import__('os').system('touch {path}')",
    "import os\n    os.system('touch {path}')",
    "x = env.__class__.__subclasses__()",
    "x = env.sim.data.qpos",
    "getattr(env, 'sim')",
    "exec(\"open({path!r}, 'w')\")",
]


# the fast path renders every span of the bundled skills: a pick at a point no one object places
# leaves Sawyer's object name to the LM
PICK_BETWEEN_INTO_BIN = '''def put_in_bin(env, task, obj="cube", receptacle="bin"):
    """Pick halfway between the cube and the bin, and drop it into the bin."""
    obj_pos = task.get_object_position(obj)
    bin_pos = task.get_object_position(receptacle)
    open_gripper(env, task)
    pick(env, task, target_pos=[(obj_pos[0] + bin_pos[0]) / 2, (obj_pos[1] + bin_pos[1]) / 2, obj_pos[2]], approach_axis="z")
    place(env, task, target_pos=[bin_pos[0], bin_pos[1], bin_pos[2] + 0.1], approach_axis="z")
'''


@pytest.mark.parametrize(
    ("method", "robot"),
    [
        ("recent", "UR5e"),
        ("recent+fast-path", "Sawyer"),
        ("recent-full-regen", "UR5e"),
        ("cap", "UR5e"),
        ("repair", "UR5e"),
        ("agentless", "UR5e"),
    ],
)
def test_the_security_gate_blocks_hostile_output_for_every_method(ontology, tmp_path, method, robot):
    marker = tmp_path / "pwned"
    texts = [t.format(path=str(marker)) for t in HOSTILE_OUTPUT] * 20
    library = library_with(tmp_path, "put_in_bin", PICK_BETWEEN_INTO_BIN) if method == "recent+fast-path" else None
    agent, infiller = _agent(ontology, method, texts, library)
    result = run_episode(agent, "cube_in_bin", robot, seed=0, max_steps=40)
    assert infiller.units, "the method never asked the LM"
    assert not marker.exists()  # nothing hostile ran
    assert not result.success and all(c.category != "crash" for c in result.failures)


@pytest.mark.parametrize("method", ["recent", "cap"])
def test_calls_before_the_first_action_count_the_same_for_every_method(ontology, method):
    """A retry before anything ran is grounding (GO-pre, IGT) for RECENT and a baseline alike: no EI, IT or GO."""
    recorded = _recorded_completions(ontology, method)
    agent, infiller = _agent(ontology, method, ["", *recorded])  # the first answer is empty: rejected
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    assert result.success
    calls = [c for s in result.grounding.skills for c in s.calls]
    assert [c.kind for c in calls] == ["ground"] * len(calls) and calls[0].category == "empty_continuation"
    assert result.ei == 0 and result.it == 0.0 and result.go == 0.0 and not result.runtime_calls
    assert result.go_pre == pytest.approx(100 * infiller.tokens * len(calls) / result.skill_tokens)


def _recorded_completions(ontology, method: str) -> list[str]:
    """What a correct run of ``method`` is answered with: the rule backend's spans for RECENT, the
    grounded body for a baseline's whole-program span."""
    if method == "cap":
        return [UR5E_BODY]
    rule = RuleConfig().build(0)
    texts: list[str] = []

    class Recording:
        name, model = "recording", "rule"

        def infill(self, unit):
            completion = rule.infill(unit)
            texts.append(completion.text)
            return completion

        def count_tokens(self, text):
            return rule.count_tokens(text)

    RecentAgent(
        RecentSettings(infiller=RuleConfig(), method=method_named("recent")), ontology=ontology, infiller=Recording()
    ).ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    return texts


@pytest.mark.parametrize(
    ("robot", "task", "succeeds"),
    [("UR5e", "cube_in_bin", True), ("Sawyer", "cube_in_bin", True), ("IIWAKRL", "end_effector/build_tower", False)],
)
def test_oracle_rule_is_the_ontology_alone_and_never_asks_the_lm(ontology, robot, task, succeeds):
    """The sanity row: where the ontology decides every span it succeeds without an LM (Sawyer's
    object name too: the point its pick grasps at names it); where it refuses a call (IIWAKRL has no
    place, and a place onto a receptacle has no path to trace) it is refused before any span is
    rendered or asked for, by name."""
    agent, infiller = _agent(ontology, "oracle-rule", [])  # any LM call would pop from an empty script
    result = run_episode(agent, task, robot, seed=0, max_steps=400)
    assert infiller.units == [] and result.generated_tokens == 0
    assert bool(result.success) is succeeds
    if succeeds:
        assert result.rule_coverage == 100.0 and result.to_record()["rule_coverage"] == 100.0
    else:  # nothing rendered, nothing asked: no coverage to state
        record = result.to_record()
        assert record["rule_coverage"] is None and record["failure_category"] == "unsupported"
        assert record["failure_message"].startswith("stack_tower: refused: line 5: IIWAKRL has no primitive")


def test_whole_programs_are_written_freely_not_cut_by_a_statement_grammar(ontology):
    """Comments, blank lines and a closing bracket on its own line are ordinary Python: no grammar
    and no blank-line stop for a whole body; RECENT's localized spans keep theirs."""
    agent, infiller = _agent(ontology, "cap", [UR5E_BODY])
    agent.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    prompt = build_prompt(infiller.units[0], 100)
    assert prompt.grammar is None and "\n\n" not in prompt.stop
    recorded = _recorded_completions(ontology, "recent")
    rule, rule_infiller = _agent(ontology, "recent", recorded)
    rule.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    assert build_prompt(rule_infiller.units[0], 10).grammar is not None


def test_every_method_gets_the_same_lm_call_budget_per_task_cached_groundings_included(ontology):
    """max_lm_calls=2: cap's program (1 call) fails, its repair (call 2) fails again, and no third
    call is made; the next episode serves the cached program, which still costs its call."""
    wrong = UR5E_BODY.replace("open_ur5_ee(env, task)", PANDA_LINE)
    infiller = ScriptedInfiller([wrong] * 10)
    settings = RecentSettings(infiller=RuleConfig(), method=method_named("cap"), max_lm_calls=2)
    agent = RecentAgent(settings, ontology=ontology, infiller=infiller)
    first = run_episode(agent, "cube_in_bin", "UR5e", seed=0, max_steps=200)
    assert len(infiller.units) == 2 and len(first.runtime_calls) == 1 and not first.success
    second = run_episode(agent, "cube_in_bin", "UR5e", seed=1, max_steps=200)
    assert second.grounding.cached and len(second.runtime_calls) == 1 and len(infiller.units) == 3


@pytest.mark.parametrize("method", ["repair", "agentless", "cap"])
def test_a_baselines_loop_runs_until_the_task_succeeds_or_its_lm_budget_is_spent(ontology, method):
    """Not stopped at ``max_repairs`` (2): a rewrite that fails again is rewritten again, each one an
    LM call, until the task's 6 calls are spent; without a limit, ``max_repairs`` still ends it."""
    wrong = UR5E_BODY.replace("open_ur5_ee(env, task)", PANDA_LINE)
    rewrite = wrong if method == "cap" else PANDA_LINE
    for limit, calls in ((6, 6), (0, 3)):
        infiller = ScriptedInfiller([wrong] + [rewrite] * 10)
        settings = RecentSettings(infiller=RuleConfig(), method=method_named(method), max_lm_calls=limit)
        result = run_episode(RecentAgent(settings, ontology=ontology, infiller=infiller), "cube_in_bin", "UR5e", seed=0)
        assert not result.success and len(infiller.units) == calls, (limit, len(infiller.units))
        assert [c.kind for c in result.runtime_calls] == ["repair"] * (calls - 1)
    # RepairAgent's growing prompt: a rewrite recalls the rewrites that failed before it; CaP's does not
    recalled = "tried before and failed: `open_gripper(env, task)` (NameError: name 'open_gripper' is not defined)"
    assert (recalled in infiller.units[2].hints.feedback) == (method == "repair")
    assert recalled not in infiller.units[1].hints.feedback  # the first repair has no history yet


def test_recent_is_held_to_the_same_budget(ontology):
    infiller = ScriptedInfiller([""] * 20)  # every answer rejected
    settings = RecentSettings(infiller=RuleConfig(), method=method_named("recent"), max_retries=10, max_lm_calls=3)
    grounded, _ = RecentAgent(settings, ontology=ontology, infiller=infiller).ground(
        "put_in_bin", "UR5e", get_task("cube_in_bin"), budget=CallBudget(3)
    )
    assert not grounded.valid and len(infiller.units) == 3  # 11 attempts allowed per span, 3 calls per task
    assert "after 3 attempt(s): the task's LM call budget is spent" in grounded.verdict.message  # not the LM's doing


def test_a_paper_length_task_budgets_two_lm_calls_per_primitive_call(ontology):
    """The flat budget (24) would not cover one call per span of a 51-call task; the -v1 tasks keep it."""
    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), ontology=ontology, infiller=ScriptedInfiller([]))
    assert agent.budget(get_task("kinematic/serve_then_clear")).limit == 2 * 51
    assert agent.budget(get_task("kinematic/tidy_bench")).limit == 24  # kinematic-v1: 10 calls
    assert agent.budget(get_task("kinematic/lift_panel_bin")).limit == 2 * 20


@pytest.mark.slow
def test_cap_distilled_runs_caps_protocol_on_a_model_of_its_own(ontology, llama_infiller):
    """The run's LM is the 1.5B; cap-distilled answers with its own slot (the 0.5B here), and says so."""
    agent = RecentAgent(
        # 3 calls: the loop would otherwise regenerate until the task's 24 are spent
        RecentSettings(method=method_named("cap-distilled"), max_lm_calls=3),
        ontology=ontology,
        infiller=llama_infiller,
    )
    assert "0.5b" in agent.infiller.model and agent.infiller.model != llama_infiller.model
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0, max_steps=300)
    calls = [c for s in result.grounding.skills for c in s.calls]
    assert calls and calls[0].kind == "ground" and calls[0].generated_tokens > 0
    assert agent.started_event("cube_in_bin", "UR5e", 0).model == agent.infiller.model  # the logs name it


def test_igt_and_it_are_broken_down_into_prompt_generation_and_the_rest(ontology):
    """Every record splits the LM's time as a backend measured it, and says how much of each prompt
    the model's cache saved."""
    from lerobot_policy_recent.recent_plugin.infillers.base import Completion

    class Timed(ScriptedInfiller):
        def infill(self, unit):
            text = super().infill(unit).text
            return Completion(
                text, 7, 0.01, 100, evaluated_prompt_tokens=40, prompt_seconds=0.004, generation_seconds=0.005
            )

    wrong = UR5E_BODY.replace("open_ur5_ee(env, task)", PANDA_LINE)
    infiller = Timed([wrong, UR5E_BODY])
    agent = RecentAgent(
        RecentSettings(infiller=RuleConfig(), method=method_named("cap")), ontology=ontology, infiller=infiller
    )
    record = run_episode(agent, "cube_in_bin", "UR5e", seed=0).to_record()
    assert record["igt_prompt_s"] == pytest.approx(0.004) and record["igt_generation_s"] == pytest.approx(0.005)
    assert record["it_prompt_s"] == pytest.approx(0.004) and record["it_per_call_s"] == pytest.approx(0.01)
    assert record["igt_other_s"] >= 0 and record["prompt_tokens"] == 200 and record["prompt_tokens_evaluated"] == 80


def _program(*lines: str) -> str:
    return 'def put_in_bin(env, task, obj="cube", receptacle="bin"):\n' + "".join(f"    {line}\n" for line in lines)


@pytest.mark.parametrize(
    ("lines", "behaviours"),
    [
        (UR5E_BODY.splitlines(), []),  # the correct UR5e program
        (["open_gripper(env, task)"], ["nonsense"]),
        (["ur5_grasp_at(env, task, grasp_pos=[0, 0, 0.9], speed=1)"], ["nonsense"]),
        (["ur5_release_at(env, task, place_pos=[0, 0, 0.9])"], ["disorder"]),
        (
            ["ur5_grasp_at(env, task, grasp_pos=[0, 0, 0.9])", "ur5_grasp_at(env, task, grasp_pos=[0, 0.1, 0.9])"],
            ["disorder"],
        ),
        (["ur5_move_to(env, task, target_pos=[1.5, 0, 0.9])"], ["infeasible"]),
        (["ur5_align_gripper(env, task, reference_quat=[1, 1, 0, 0])"], ["badpose"]),
        (["ur5_move_to(env, task, target_pos=[0, 0, 0.9], timeout_s=100)"], ["badpose"]),
    ],
)
def test_the_behaviour_detector_sorts_programs_into_roboinspectors_taxonomy(ontology, lines, behaviours):
    from lerobot_policy_recent.evaluation.baselines.inspector import inspect_program

    code = _program(*(line.strip() for line in lines))
    assert [f.behaviour for f in inspect_program(code, "put_in_bin", ontology.api("UR5e"))] == behaviours


def test_roboinspector_regenerates_before_execution_with_the_categorised_finding(ontology):
    disordered = "ur5_release_at(env, task, place_pos=task.get_object_position(receptacle))\n    " + UR5E_BODY
    agent, infiller = _agent(ontology, "roboinspector", [disordered, UR5E_BODY])
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    assert result.success and not result.runtime_calls
    first, second = result.grounding.skills[0].calls
    assert not first.accepted and first.kind == second.kind == "ground" and second.accepted
    assert "Disorder (line 3): ur5_release_at() needs a held object" in infiller.units[1].hints.feedback


def test_scot_writes_a_structured_plan_then_the_program_under_it(ontology):
    plan = "open_gripper -> open_ur5_ee\n# - pick(target_pos) -> ur5_grasp_at(grasp_pos)"
    agent, infiller = _agent(ontology, "scot", [plan, UR5E_BODY])
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    assert result.success
    first, second = infiller.units
    assert first.span_type == "structured_plan" and first.prefix.endswith("one line each.\n# - ")
    assert build_prompt(first, 0).grammar is None  # free text, as comment lines
    assert "# Structured plan:\n# - open_gripper -> open_ur5_ee\n# - pick(target_pos) -> ur5_grasp_at(grasp_pos)\n" in (
        second.prefix
    )
    calls = result.grounding.skills[0].calls
    assert [(c.kind, c.span_type) for c in calls] == [("ground", "structured_plan"), ("ground", PROGRAM)]
    assert result.go_pre == pytest.approx(100 * 2 * infiller.tokens / result.skill_tokens)  # both are grounding


def test_seeded_sampling_makes_seeds_real_repetitions_and_replays_an_episode_exactly(ontology):
    """temperature > 0 (the default, 0.2): every LM call samples with a seed drawn from lm_seed, the
    episode seed and the call's place; a grounding is cached per episode seed, so another seed grounds
    afresh. A backend that does not sample (the rule renderer, a double that does not say) is asked
    plainly, and then a grounding serves every seed; temperature 0 is greedy."""

    class Recording(ScriptedInfiller):
        samples = True

        def infill(self, unit, **sampling):
            self.sampling = [*getattr(self, "sampling", []), sampling]
            return super().infill(unit)

    assert RecentSettings().temperature == 0.2
    infiller = Recording([UR5E_BODY] * 3)
    settings = RecentSettings(infiller=RuleConfig(), method=method_named("cap"), temperature=0.7)
    agent = RecentAgent(settings, ontology=ontology, infiller=infiller)
    first = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    again = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    other = run_episode(agent, "cube_in_bin", "UR5e", seed=1)
    assert first.success and not first.grounding.cached and again.grounding.cached and not other.grounding.cached
    (sampled_0, sampled_1) = infiller.sampling  # one grounding call per distinct seed
    assert sampled_0["temperature"] == sampled_1["temperature"] == 0.7 and sampled_0["seed"] != sampled_1["seed"]

    def grounding_calls(lm: ScriptedInfiller, **settings) -> list[dict]:
        agent = RecentAgent(
            RecentSettings(infiller=RuleConfig(), method=method_named("cap"), **settings),
            ontology=ontology,
            infiller=lm,
        )
        for seed in (0, 1):
            agent.ground(
                "put_in_bin", "UR5e", get_task("cube_in_bin"), budget=agent.budget(get_task("cube_in_bin")), seed=seed
            )
        return lm.sampling

    assert grounding_calls(Recording([UR5E_BODY] * 2), temperature=0.0) == [{}]  # greedy: one grounding for both seeds
    deterministic = Recording([UR5E_BODY] * 2)
    deterministic.samples = False
    assert grounding_calls(deterministic) == [{}]


class _RecordingLM:
    """Stands in for the llama.cpp worker: records what it is sent, answers with ``reply``."""

    def __init__(self, reply: str):
        self.reply, self.sent = reply, []

    def tokenize(self, text, special=False):
        return text.split()

    def generate(self, text, **options):
        from lerobot_policy_recent.recent_plugin.infillers.lookup_decoding import Decoded

        self.sent.append((text, options))
        return Decoded(self.reply, len(self.reply.split()), len(text.split()), len(text.split()))


def test_an_instruct_model_writes_whole_programs_through_its_chat_template_and_edits_spans_through_fim(ontology):
    """cap's program goes to the 1.5B-Instruct as ChatML (its reply's code block is the body); RECENT's
    localized span stays a FIM string under its statement grammar."""
    from lerobot_policy_recent.recent_plugin.infillers.llamacpp import LlamaCppInfiller

    reply = "Here it is:\n```python\n" + UR5E_BODY.replace("\n    ", "\n") + "\n```"
    llm = LlamaCppInfiller.__new__(LlamaCppInfiller)  # the infiller's own logic, over a recording LM
    llm.model, llm.lm = "qwen2.5-coder-1.5b-instruct-q4_k_m.gguf", _RecordingLM(reply)
    agent, infiller = _agent(ontology, "cap", [UR5E_BODY])
    agent.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    program = infiller.units[0]
    completion = llm.infill(program)
    text, options = llm.lm.sent[-1]
    assert text.startswith("<|im_start|>system\n") and text.endswith("<|im_start|>assistant\n")
    assert "<FILL>" in text and "<|fim_prefix|>" not in text
    assert options["gbnf"] is None and "<|im_end|>" in options["stops"]
    assert completion.text == UR5E_BODY  # the reply's code, its later lines at the body's indentation

    rule, rule_infiller = _agent(ontology, "recent", _recorded_completions(ontology, "recent"))
    rule.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    llm.lm.reply = "open_ur5_ee(env, task)"
    llm.infill(rule_infiller.units[0])
    text, options = llm.lm.sent[-1]
    assert text.startswith("<|fim_prefix|>") and options["gbnf"] is not None


def test_a_regenerated_program_has_room_to_restate_its_header_and_the_error_before_its_body(ontology):
    """An instruct model's reply restates the ``def`` line, the docstring and the error fed back
    before the body; the budget holds them besides the body's own (a regenerated program used to be
    cut mid-statement here). A span edit gets no such room: its reply is the span."""
    from lerobot_policy_recent.recent_plugin.refactoring.chat_prompt import FENCE_TOKENS, build_chat
    from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import approximate_tokens

    wrong = UR5E_BODY.replace("open_ur5_ee(env, task)", PANDA_LINE)
    agent, infiller = _agent(ontology, "cap", [wrong, UR5E_BODY])
    run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    regeneration = infiller.units[1]
    span_tokens = approximate_tokens(regeneration.span)
    prompt, chat = build_prompt(regeneration, span_tokens), build_chat(regeneration, span_tokens)
    header = prompt.prefix[prompt.prefix.rindex("\ndef ") + 1 :]  # def line, docstring, the error as comments
    assert "NameError" in header
    reply = f"```python\n{header}{UR5E_BODY}\n```"
    assert approximate_tokens(reply) > prompt.max_tokens  # the body's budget alone would cut this reply
    assert chat.max_tokens >= approximate_tokens(reply) + span_tokens  # room for it, and for a longer body

    rule, rule_infiller = _agent(ontology, "recent", _recorded_completions(ontology, "recent"))
    rule.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    edit = rule_infiller.units[0]
    edit_tokens = approximate_tokens(edit.span)
    assert build_chat(edit, edit_tokens).max_tokens == build_prompt(edit, edit_tokens).max_tokens + FENCE_TOKENS


def test_a_chat_reply_keeps_its_nested_blocks_nested():
    from lerobot_policy_recent.recent_plugin.refactoring.chat_prompt import span_of_reply

    reply = "```python\nfor p in points:\n    move(env, task, p)\ndone(env, task)\n```"
    assert span_of_reply(reply, "    ") == "for p in points:\n        move(env, task, p)\n    done(env, task)"


def test_cap_with_the_targets_own_program_as_its_example_is_the_upper_bound_row(ontology):
    """cap-target-example shows the skill as the ontology renders it for the target (no Panda call in
    the example), and refuses a target for which the ontology cannot render the program completely."""
    agent, infiller = _agent(ontology, "cap-target-example", [UR5E_BODY])
    grounded, _ = agent.ground("put_in_bin", "UR5e", get_task("cube_in_bin"))
    header = infiller.units[0].prefix
    example = header[header.index("def put_in_bin_ur5e(") : header.index("# The UR5e robot has")]
    assert "# Example: this skill written for the UR5e robot" in header
    assert "ur5_grasp_at(" in example and "pick(" not in example and "open_gripper(" not in example
    assert grounded.valid and len(infiller.units) == 1  # one program call, as cap; the rendering costs none

    other, _ = _agent(ontology, "cap-target-example", [UR5E_BODY])  # IIWAKRL has no place to render
    with pytest.raises(ValueError, match="no reference program of stack_tower for IIWAKRL"):
        other.ground("stack_tower", "IIWAKRL", get_task("end_effector/build_tower"))


def test_cap_shows_examples_in_the_targets_api_from_other_skills_never_the_tasks_own(ontology):
    """cap, as the original CaP prompts are: before the Panda reference, other validated skills as the
    ontology renders them for the target (in-context examples), chosen to show its primitives; none
    of the task's skills is among them, and the cache tells it from cap with none shown."""
    agent, infiller = _agent(ontology, "cap", [UR5E_BODY])
    task = get_task("cube_in_bin")
    grounded, _ = agent.ground("put_in_bin", "UR5e", task)
    header = infiller.units[0].prefix
    examples = header[: header.index("# Example: this skill written for the Panda robot")]
    assert examples.startswith("# Examples of other skills written for the UR5e robot")
    assert examples.count("\ndef ") == 2 and "_ur5e(env, task" in examples
    assert "ur5_grasp_at(" in examples and "pick(" not in examples  # the target's own calls
    assert "def put_in_bin" not in examples  # the task's skill is shown only as the Panda program
    assert "def put_in_bin_panda(env, task" in header and grounded.valid

    bare = RecentAgent(
        RecentSettings(infiller=RuleConfig(), method=replace(method_named("cap"), api_examples=0)), ontology=ontology
    )
    assert agent.grounding_key(agent.skill("put_in_bin"), ontology.target("UR5e"), task) != bare.grounding_key(
        bare.skill("put_in_bin"), ontology.target("UR5e"), task
    )


def test_a_committed_runs_rows_of_a_retired_method_still_show_after_the_registered_ones():
    from lerobot_policy_recent.evaluation.report.tables import ordered_rows

    rows = ordered_rows({"cap-api-examples", "cap", "recent", "cap@qwen2.5-coder-0.5b"})
    assert rows == ["recent", "cap", "cap@qwen2.5-coder-0.5b", "cap-api-examples"]


def _repair_unit(ontology, method: str):
    """The statement rewrite a ``method`` baseline asks for after UR5e's program called the Panda's primitive."""
    from lerobot_policy_recent.evaluation.baselines.program_prompt import ProgramContext, ProgramPrompt
    from lerobot_policy_recent.ontology.skill_code import body_span

    skill = load_skill("put_in_bin")
    code = skill.code.replace(
        skill.code[slice(*body_span(skill.code, skill.entry))], UR5E_BODY.replace("open_ur5_ee(env, task)", PANDA_LINE)
    )
    start = code.index(PANDA_LINE)
    prompt = ProgramPrompt(
        skill, ontology.target("UR5e"), method_named(method).style, ProgramContext("put the cube in the bin")
    )
    return prompt.statement_unit(
        code,
        (start, start + len(PANDA_LINE)),
        feedback="line 5: hallucinated_name: NameError: name 'open_gripper' is not defined",
        observation="cube at [0.000, 0.000, 0.830]; bin at [0.100, 0.200, 0.820]",
    )


@pytest.mark.parametrize("method", ["repair", "agentless"])
def test_a_statement_rewrite_is_held_to_code_lines_not_more_comments(ontology, method):
    """Its prompt ends in comment lines (was, failed, observed, rewrite): the grammar admits code only."""
    from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import CODE_LINES

    prompt = build_prompt(_repair_unit(ontology, method), span_tokens=8)
    assert prompt.prefix.rstrip().splitlines()[-1].lstrip().startswith("# Rewrite it for UR5e")
    assert prompt.grammar == CODE_LINES


@pytest.mark.slow
@pytest.mark.parametrize("method", ["repair", "agentless"])
def test_the_real_lm_rewrites_the_failed_statement_as_code(ontology, llama_infiller, method):
    """The 1.5B, asked for the one-statement repair, writes a statement (it wrote comments before)."""
    from lerobot_policy_recent.recent_plugin.grounding.attempts import clean_completion

    unit = _repair_unit(ontology, method)
    text = clean_completion(llama_infiller.infill(unit).text, unit)
    assert text.strip() and not text.lstrip().startswith("#"), text
    compile(text.strip(), "<repair>", "exec")
