"""Grounded skills persist across processes, under a key that changes with the code, the robot spec,
the ontology and the model; the store is bounded, survives bad files, and `recent cache clear` empties it."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from lerobot_policy_recent.ontology.builder import build_ontology, default_embodiment_sources
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.grounding.store import ENV, GroundingStore
from lerobot_policy_recent.recent_plugin.infillers.configs import LlamaCppConfig, RuleConfig
from lerobot_policy_recent.recent_plugin.infillers.rule import RuleInfiller
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.scripts.cli import main

GROUND_ONCE = """
import json, time
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
agent = RecentAgent(RecentSettings(infiller=RuleConfig()))
started = time.perf_counter()
grounded, hit = agent.ground("put_in_bin", "UR5e")
print(json.dumps({"hit": hit, "seconds": time.perf_counter() - started, "code": grounded.code}))
"""


def ground_in_new_process(store: Path) -> dict:
    env = {**os.environ, ENV: str(store)}
    out = subprocess.run([sys.executable, "-c", GROUND_ONCE], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_second_process_reads_back_what_the_first_grounded(tmp_path):
    first = ground_in_new_process(tmp_path)
    second = ground_in_new_process(tmp_path)
    assert not first["hit"] and second["hit"]
    assert second["code"] == first["code"]
    assert len(list(tmp_path.glob("*.grounding"))) == 1


def test_the_key_changes_with_the_code_the_robot_spec_the_ontology_and_the_model(ontology, tmp_path):
    store = GroundingStore(tmp_path)
    rule = RuleInfiller()
    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), infiller=rule, ontology=ontology, store=store)
    skill, target = agent.skill("put_in_bin"), ontology.target("UR5e")
    key = agent.grounding_key(skill, target)
    assert agent.grounding_key(skill, target) == key  # stable

    edited = dataclasses.replace(skill, code=skill.code + "\n# edited\n")
    assert agent.grounding_key(edited, target) != key

    # the UR5e spec with one parameter's default changed: another ontology, another key
    sources = default_embodiment_sources()
    ur5e = next(s for s in sources if s.name == "UR5e")
    spec = yaml.safe_load(ur5e.api_spec.read_text())
    spec["primitives"][0]["parameters"][1]["default"] = 7.5  # ur5_grasp_at's timeout_s default
    changed = tmp_path / "ur5e_api.yaml"
    changed.write_text(yaml.safe_dump(spec))
    other = build_ontology([dataclasses.replace(s, api_spec=changed) if s is ur5e else s for s in sources])
    moved = RecentAgent(RecentSettings(infiller=RuleConfig()), infiller=rule, ontology=other, store=store)
    assert moved.grounding_key(skill, other.target("UR5e")) != key

    for model in ("qwen2.5-coder-1.5b", "qwen2.5-coder-0.5b"):  # the weights' pinned sha256 differs
        llm = RecentAgent(RecentSettings(infiller=LlamaCppConfig(model=model)), infiller=rule, ontology=ontology)
        assert llm.grounding_key(skill, target) != key
    small, large = (
        RecentAgent(RecentSettings(infiller=LlamaCppConfig(model=m)), infiller=rule, ontology=ontology).lm_key()
        for m in ("qwen2.5-coder-0.5b", "qwen2.5-coder-1.5b")
    )
    assert small != large and json.loads(large)["model_sha256"]


def test_the_key_changes_with_the_code_that_prompts_the_lm(ontology, tmp_path):
    """A new prompt format (a baseline's program sent as a chat, a hint reworded) is a new key: a
    program grounded by the old prompts is never read back as if the new ones had written it."""
    import shutil

    from lerobot_policy_recent.recent_plugin.grounding.store import GROUNDING_CODE, grounding_code_digest

    package = Path(grounding_code_digest.__wrapped__.__code__.co_filename).parents[2]
    same, edited, reworded, vocabulary = (tmp_path / n for n in ("same", "edited", "reworded", "vocabulary"))
    for copy in (same, edited, reworded, vocabulary):
        for folder in GROUNDING_CODE:
            shutil.copytree(
                package / folder, copy / folder, ignore=shutil.ignore_patterns("__pycache__"), dirs_exist_ok=True
            )
    prompt = edited / "recent_plugin" / "refactoring" / "chat_prompt.py"
    prompt.write_text(prompt.read_text().replace("Answer with code only", "Answer with code"))
    facts = reworded / "ontology" / "conversions.py"  # the ontology writes hints too (a conversion's facts)
    facts.write_text(facts.read_text().replace("keeps the tool's orientation", "holds the tool's orientation"))
    assert grounding_code_digest(same) == grounding_code_digest()  # the same sources, the same digest
    assert grounding_code_digest(edited) != grounding_code_digest()
    assert grounding_code_digest(reworded) != grounding_code_digest()
    conditions = vocabulary / "ontology" / "conditions.yaml"  # a condition now checked for every robot
    conditions.write_text(
        conditions.read_text().replace("  target_reachable:\n", "  target_reachable:\n    always: false\n")
    )
    assert grounding_code_digest(vocabulary) != grounding_code_digest()

    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), infiller=RuleInfiller(), ontology=ontology)
    assert grounding_code_digest() in agent.grounding_key(agent.skill("put_in_bin"), ontology.target("UR5e"))


def test_an_lm_handed_in_is_never_cached_on_disk_unless_asked(ontology, monkeypatch, tmp_path):
    monkeypatch.setenv(ENV, str(tmp_path))
    handed = RecentAgent(RecentSettings(infiller=RuleConfig()), infiller=RuleInfiller(), ontology=ontology)
    assert handed.store is None
    assert RecentAgent(RecentSettings(infiller=RuleConfig()), ontology=ontology).store.root == tmp_path
    monkeypatch.setenv(ENV, "off")
    assert RecentAgent(RecentSettings(infiller=RuleConfig()), ontology=ontology).store is None


def test_a_bad_file_is_a_miss_and_the_store_stays_within_its_bound(ontology, tmp_path):
    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), ontology=ontology, store=GroundingStore(tmp_path))
    grounded, hit = agent.ground("put_in_bin", "UR5e")
    assert not hit and grounded.valid
    key = agent.grounding_key(agent.skill("put_in_bin"), ontology.target("UR5e"))
    path = agent.store.path(key)
    path.write_bytes(b"not a grounding")
    assert agent.store.get(key) is None and not path.exists()  # dropped, grounded again next time

    agent.store.put(key, grounded)
    size = path.stat().st_size
    bounded = GroundingStore(tmp_path / "bounded", max_bytes=int(2.5 * size))
    for i in range(4):
        bounded.put(("k", str(i)), grounded)
    assert len(bounded.files()) == 2 and bounded.get(("k", "3")) is not None and bounded.get(("k", "0")) is None


class _Planted:
    """What a planted pickle would run on load: it touches a file."""

    def __init__(self, marker: str):
        self.marker = marker

    def __reduce__(self):
        return (open, (self.marker, "w"))


def test_a_planted_pickle_in_the_store_runs_nothing(ontology, tmp_path, caplog):
    import pickle

    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), ontology=ontology, store=GroundingStore(tmp_path))
    key = agent.grounding_key(agent.skill("put_in_bin"), ontology.target("UR5e"))
    marker = tmp_path / "ran"
    agent.store.path(key).write_bytes(pickle.dumps(_Planted(str(marker))))
    grounded, hit = agent.ground("put_in_bin", "UR5e")
    assert not hit and grounded.valid and not marker.exists()  # a miss: grounded again, the pickle never loaded
    assert str(agent.store.path(key)) in caplog.text  # the warning names the file
    assert agent.store.get(key) == grounded  # the fresh grounding was stored as JSON and reads back equal


def test_recent_cache_info_and_clear(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv(ENV, str(tmp_path))
    ground_in_new_process(tmp_path)
    assert main(["cache", "info"]) == 0
    assert f"{tmp_path}: 1 grounded skills" in capsys.readouterr().out
    assert main(["cache", "clear"]) == 0
    assert "removed 1 grounded skills" in capsys.readouterr().out
    assert not list(tmp_path.glob("*.grounding"))
    monkeypatch.setenv(ENV, "off")
    assert main(["cache", "clear"]) == 0 and "off" in capsys.readouterr().out


@pytest.fixture(autouse=True)
def _hermetic(monkeypatch):
    monkeypatch.delenv(ENV, raising=False)
    monkeypatch.setenv(ENV, "off")
