"""The openai backend against a completions server we start on loopback (no network)."""

from __future__ import annotations

import pytest
from loopback import json_server

from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill
from lerobot_policy_recent.recent_plugin.infillers import make_infiller
from lerobot_policy_recent.recent_plugin.infillers.fim_formats import fim_format

ANSWERS = {
    "no place;": "ur5_release_at(env, task, place_pos=drop_pos)",
    "no pick;": "ur5_grasp_at(env, task, grasp_pos=obj_pos)",
    "no open_gripper;": "open_ur5_ee(env, task)",
}


REQUESTS: list[dict] = []


def completions(path: str, body: dict) -> dict:
    """Answers like vLLM or llama.cpp's server would, from fixed completions."""
    if path == "/tokenize":
        return {"tokens": list(range(len(body["content"].split())))}
    hint = next((k for k in ANSWERS if k in body["prompt"]), None)
    text = ANSWERS[hint] if hint else ""
    return {"choices": [{"text": text}], "usage": {"completion_tokens": len(text) // 4, "prompt_tokens": 100}}


@pytest.fixture
def server():
    REQUESTS.clear()
    with json_server(completions, REQUESTS) as url:
        yield url


def test_grounds_through_a_completions_server(server, ontology, put_in_bin):
    infiller = make_infiller("openai", "Qwen/Qwen2.5-Coder-7B", base_url=server)
    grounded = ground_skill(put_in_bin, ontology.target("UR5e"), ontology, infiller)
    assert grounded.valid, [c.message for c in grounded.calls]
    completions = [r for r in REQUESTS if r["path"] == "/v1/completions"]
    assert len(completions) == 3
    prompt = completions[0]["prompt"]
    assert (
        prompt.startswith("<|fim_prefix|>def put_in_bin(")
        and "<|fim_suffix|>" in prompt
        and prompt.endswith("<|fim_middle|>")
    )
    assert (
        completions[0]["temperature"] == 0.0
        and "\n" in completions[0]["stop"]
        and "<|endoftext|>" in completions[0]["stop"]
    )
    assert grounded.skill_tokens == len(put_in_bin.code.split())  # counted by the server's /tokenize
    assert grounded.generated_tokens == sum(len(t) // 4 for t in ANSWERS.values())


def test_unreachable_server_is_a_clear_error(ontology, put_in_bin):
    infiller = make_infiller("openai", "Qwen/Qwen2.5-Coder-7B", base_url="http://127.0.0.1:9")
    with pytest.raises(RuntimeError, match="cannot reach the server"):
        ground_skill(put_in_bin, ontology.target("UR5e"), ontology, infiller)


@pytest.mark.parametrize(
    ("model", "marker"),
    [
        ("Qwen/Qwen2.5-Coder-1.5B", "<|fim_middle|>"),
        ("google/codegemma-2b", "<|fim_middle|>"),
        ("bigcode/starcoder2-3b", "<fim_middle>"),
        ("deepseek-ai/deepseek-coder-1.3b-base", "<｜fim▁end｜>"),
    ],
)
def test_fim_formats_per_family(model, marker):
    assert fim_format(model).render("a", "b").endswith(marker)


def test_unknown_family_lists_the_known_ones():
    with pytest.raises(ValueError, match="known families"):
        fim_format("gpt2")


def test_cap_llm_asks_a_served_chat_model_and_runs_its_program(ontology):
    """The paper's CaP-Codex row against a loopback chat server: the unit goes as one user message,
    the reply's code block (the whole function, repeated) is cut back to the body, and it runs."""
    from test_baselines import UR5E_BODY

    from lerobot_policy_recent.evaluation.baselines.cap import CodeAsPoliciesLLM
    from lerobot_policy_recent.recent_plugin.agent import RecentAgent
    from lerobot_policy_recent.recent_plugin.episode import run_episode
    from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
    from lerobot_policy_recent.recent_plugin.settings import RecentSettings

    body = "\n".join("    " + line.strip() for line in UR5E_BODY.splitlines())
    reply = (
        f'Here it is:\n```python\ndef put_in_bin(env, task, obj="cube", receptacle="bin"):\n    """Doc."""\n{body}\n```'
    )
    requests: list[dict] = []

    def chat(path: str, request: dict) -> dict:
        return {"choices": [{"message": {"content": reply}}], "usage": {"completion_tokens": 60, "prompt_tokens": 900}}

    with json_server(chat, requests) as url:
        method = CodeAsPoliciesLLM(base_url=url, model_name="served-coder")
        agent = RecentAgent(RecentSettings(infiller=RuleConfig(), method=method), ontology=ontology)
        result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    assert result.success and agent.infiller.model == "served-coder"
    assert requests[0]["path"] == "/v1/chat/completions" and requests[0]["messages"][1]["role"] == "user"
    assert (
        "<FILL>" in requests[0]["messages"][1]["content"]
        and "ur5_grasp_at(env, task" in requests[0]["messages"][1]["content"]
    )
    assert result.grounding.skills[0].calls[0].generated_tokens == 60
    with pytest.raises(ValueError, match="--method.base_url"):
        RecentAgent(RecentSettings(infiller=RuleConfig(), method=CodeAsPoliciesLLM()), ontology=ontology)


@pytest.mark.parametrize(
    "reply",
    [
        "```python\nopen_ur5_ee(env, task)\nclose_ur5_ee(env, task)\n```",
        "    open_ur5_ee(env, task)\n    close_ur5_ee(env, task)",
        'Sure.\n```\ndef s(env, task):\n    """Two\n    lines."""\n    open_ur5_ee(env, task)\n    close_ur5_ee(env, task)\n```\nDone.',
    ],
)
def test_a_chat_reply_is_cut_to_the_span(reply):
    from lerobot_policy_recent.recent_plugin.refactoring.chat_prompt import span_of_reply

    assert span_of_reply(reply) == "open_ur5_ee(env, task)\nclose_ur5_ee(env, task)"
