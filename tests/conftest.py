"""Shared fixtures. Tests marked ``slow`` run only with ``--runslow`` (the benchmark runs them all)."""

from __future__ import annotations

import os

import pytest

# Hermetic tests: no grounded skill is read from or written to the user's grounding cache (the
# subprocesses and Ray workers of the tests inherit this). tests/test_grounding_store.py turns it on.
os.environ["RECENT_GROUNDING_CACHE"] = "off"

import lerobot_policy_recent.evaluation.methods  # noqa: E402, F401  (registers the harness's methods: baselines, ablations)


def pytest_addoption(parser):
    parser.addoption("--runslow", action="store_true", default=False, help="also run tests marked slow")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--runslow"):
        return
    skip = pytest.mark.skip(reason="slow: run with --runslow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def ontology():
    from lerobot_policy_recent.ontology.builder import build_ontology

    return build_ontology()


@pytest.fixture(scope="session")
def put_in_bin():
    from lerobot_policy_recent.skills.repository import load_skill

    return load_skill("put_in_bin")


@pytest.fixture(scope="session")
def llama_infiller():
    """The real Qwen2.5-Coder-1.5B GGUF on llama.cpp (provisioned by the README's setup)."""
    from lerobot_policy_recent.recent_plugin.infillers import make_infiller
    from lerobot_policy_recent.recent_plugin.models import model_path

    if not model_path("qwen2.5-coder-1.5b").is_file():
        pytest.fail(
            "the 1.5B GGUF is not in the cache: run `recent model fetch qwen2.5-coder-1.5b` (the README's test command does)"
        )
    return make_infiller("llamacpp", "qwen2.5-coder-1.5b")


@pytest.fixture(scope="session")
def llama_session():
    """The same model in this process, for tests that look inside the decoder (the agent's runs in a worker)."""
    from lerobot_policy_recent.recent_plugin.infillers.llama_session import LlamaSession
    from lerobot_policy_recent.recent_plugin.models import model_path

    path = model_path("qwen2.5-coder-1.5b")
    if not path.is_file():
        pytest.fail("the 1.5B GGUF is not in the cache: run `recent model fetch qwen2.5-coder-1.5b`")
    return LlamaSession(str(path))


@pytest.fixture(scope="session")
def rule_infiller():
    from lerobot_policy_recent.recent_plugin.infillers import make_infiller

    return make_infiller("rule")


@pytest.fixture(scope="session")
def panda_agent(ontology, rule_infiller):
    """Runs skills without an LM: on Panda they run unmodified, elsewhere the rule backend grounds them."""
    from lerobot_policy_recent.recent_plugin.agent import RecentAgent
    from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
    from lerobot_policy_recent.recent_plugin.settings import RecentSettings

    return RecentAgent(RecentSettings(infiller=RuleConfig()), infiller=rule_infiller, ontology=ontology)
