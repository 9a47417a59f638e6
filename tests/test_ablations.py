"""The paper's ablations run end to end and move the numbers the way the paper says they should."""

from __future__ import annotations

import pytest

from lerobot_policy_recent.evaluation.ablations import body_span, name_similarity_conflicts
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.infillers.rule import RuleInfiller
from lerobot_policy_recent.recent_plugin.methods import Grounding, method_named
from lerobot_policy_recent.recent_plugin.settings import RecentSettings


@pytest.mark.parametrize(
    ("method", "grounds"),
    [
        ("recent", True),
        ("recent-full-regen", True),  # the rule renders every substitution into the whole body
        ("recent-name-similarity", False),  # "pick" is nearest to a primitive with other arguments
        ("recent-no-ontology", False),  # without the ontology there is nothing to render without an LM
        ("recent-no-insitu", True),
        ("recent-no-offline-validation", True),
    ],
)
def test_each_method_runs_an_episode(ontology, method, grounds):
    agent = RecentAgent(
        RecentSettings(infiller=RuleConfig(), method=method_named(method)), infiller=RuleInfiller(), ontology=ontology
    )
    result = run_episode(agent, "kinematic/cube_in_bin", "UR5e", seed=0)
    assert all(s.valid for s in result.grounding.skills) == grounds
    assert result.success == grounds  # nothing that failed validation was executed


def test_name_similarity_picks_substitutes_by_name_not_by_effect(ontology, put_in_bin):
    recent = ground_skill(put_in_bin, ontology.target("UR5e"), ontology, RuleInfiller())
    by_name = name_similarity_conflicts(recent.diagnosis, ontology.api("Panda"), ontology.api("UR5e"))
    ontology_choice = {c.original: c.substitute.name for c in recent.diagnosis.conflicts}
    name_choice = {c.original: c.substitute.name for c in by_name.conflicts}
    assert ontology_choice["pick"] == "ur5_grasp_at" and name_choice["pick"] != "ur5_grasp_at"


def test_whole_body_span_excludes_signature_and_docstring(put_in_bin):
    start, end = body_span(put_in_bin.code, put_in_bin.entry)
    body = put_in_bin.code[start:end]
    assert body.startswith("obj_pos = task.get_object_position(obj)") and body.endswith('approach_axis="z")')


@pytest.mark.slow
def test_full_regeneration_costs_more_tokens_than_localized_edits(ontology, put_in_bin, llama_infiller):
    recent = ground_skill(put_in_bin, ontology.target("UR5e"), ontology, llama_infiller)
    regen = method_named("recent-full-regen").ground(
        Grounding(put_in_bin, ontology.target("UR5e"), ontology, llama_infiller, None, 0)
    )
    assert recent.valid and recent.go < regen.go
