"""The executor runs validated code segment by segment and only patches what has not started."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_policy_recent.recent_plugin.executor import SkillExecutor, split_segments
from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
from lerobot_policy_recent.robosuite_envs.observation import ObjectState, Observation
from lerobot_policy_recent.robosuite_envs.primitives import api_functions
from lerobot_policy_recent.robosuite_envs.primitives.session import RobotSession


def _obs(eef=(0.0, 0.0, 1.0), cube=(0.0, -0.1, 0.82)) -> Observation:
    return Observation(
        eef_pos=np.array(eef),
        eef_quat=np.array([1.0, 0.0, 0.0, 0.0]),
        gripper_opening=0.0,
        objects={
            "cube": ObjectState(np.array(cube), np.array([0, 0, 0, 1.0])),
            "bin": ObjectState(np.array([0.0, 0.2, 0.84]), np.array([0, 0, 0, 1.0])),
        },
    )


@pytest.fixture
def grounded(ontology, put_in_bin, rule_infiller):
    return ground_skill(put_in_bin, ontology.target("UR5e"), ontology, rule_infiller)


def test_segments_are_top_level_statements_without_docstring(grounded):
    segments = split_segments(grounded.code, grounded.entry)
    assert [s.source.split("(")[0] for s in segments] == [
        "obj_pos = task.get_object_position",
        "bin_pos = task.get_object_position",
        "open_ur5_ee",
        "ur5_grasp_at",
        "drop_pos = [bin_pos[0], bin_pos[1], bin_pos[2] + 0.1]",
        "ur5_release_at",
    ]


def test_executor_steps_one_action_at_a_time_and_binds_variables(grounded):
    session = RobotSession("UR5e", _obs())
    executor = SkillExecutor(grounded, {"obj": "cube", "receptacle": "bin"}, api_functions("ur5e"), session)
    action = executor.step()
    assert action.shape == (7,) and action[6] == -1.0  # opening the gripper
    assert executor.cursor == 2 and executor.namespace["obj_pos"] == pytest.approx([0.0, -0.1, 0.82])


def test_only_upcoming_segments_can_be_patched(grounded):
    session = RobotSession("UR5e", _obs())
    executor = SkillExecutor(grounded, {}, api_functions("ur5e"), session)
    executor.step()  # now inside open_ur5_ee (segment 2)
    with pytest.raises(ValueError, match="already started"):
        executor.replace_segment(2, "close_ur5_ee(env, task)")
    executor.replace_segment(5, "ur5_release_at(env, task, place_pos=[0.0, 0.2, 0.95])")
    assert executor.segments[5].source.endswith("[0.0, 0.2, 0.95])")
    executor.replace_rest(3, "x = 1\n    y = 2")  # a regenerated program: nothing of the old one after it
    assert [s.source for s in executor.segments[3:]] == ["x = 1", "y = 2"]
    with pytest.raises(ValueError, match="already started"):
        executor.replace_rest(2, "x = 1")


def test_unvalidated_code_is_never_executed(grounded):
    from dataclasses import replace

    from lerobot_policy_recent.recent_plugin.grounding.gate import Verdict

    with pytest.raises(ValueError, match="refusing to execute"):
        SkillExecutor(
            replace(grounded, verdict=Verdict(False)), {}, api_functions("ur5e"), RobotSession("UR5e", _obs())
        )


def test_primitive_failure_is_categorised(grounded):
    session = RobotSession("UR5e", _obs(cube=(0.0, -0.1, 0.5)))  # below the table top
    executor = SkillExecutor(grounded, {}, api_functions("ur5e"), session)
    while executor.step() is not None:
        pass
    assert executor.failed and str(executor.failure.category) == "workspace"
    assert executor.failure.line == 6


SWEEP = '''def sweep(env, task, first="red", second="blue"):
    """Two pushes."""
    for name, dy in [[first, -0.1], [second, 0.1]]:
        obj_pos = task.get_object_position(name)
        if dy > 0:
            obj_pos = [obj_pos[0],
                       obj_pos[1] + dy, obj_pos[2]]
        push(env, task, start_pos=obj_pos, target_pos=[0.2, 0.0, 0.82])
'''


def test_a_loop_over_a_literal_list_is_unrolled_into_one_segment_per_statement_and_iteration():
    segments = split_segments(SWEEP, "sweep")
    assert [s.source.splitlines()[0] for s in segments] == [
        "name, dy = [first, -0.1]",
        "obj_pos = task.get_object_position(name)",
        "if dy > 0:",
        "push(env, task, start_pos=obj_pos, target_pos=[0.2, 0.0, 0.82])",
        "name, dy = [second, 0.1]",
        "obj_pos = task.get_object_position(name)",
        "if dy > 0:",
        "push(env, task, start_pos=obj_pos, target_pos=[0.2, 0.0, 0.82])",
    ]
    # nested lines sit at the function body's indentation, as top-level segments keep them
    assert (
        segments[2].source
        == "if dy > 0:\n        obj_pos = [obj_pos[0],\n                   obj_pos[1] + dy, obj_pos[2]]"
    )
    assert [s.line for s in segments[:4]] == [3, 4, 5, 8]  # the loop's own lines, for guards and logs


@pytest.mark.parametrize(
    "loop",
    [
        "    for name in range(len(first)):\n        open_gripper(env, task)\n",  # values known only when it runs
        "    for name in [first, second]:\n        if name == 'x':\n            break\n        open_gripper(env, task)\n",
        "    for name in [first, second]:\n        second = 'c'\n        open_gripper(env, task)\n",  # item rebound
    ],
)
def test_a_loop_whose_iterations_are_not_fixed_stays_one_segment(loop):
    assert len(split_segments(f"def f(env, task, first='a', second='b'):\n{loop}", "f")) == 1
