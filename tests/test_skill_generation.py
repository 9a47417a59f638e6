"""The offline LLM generation path against a chat-completions server on loopback (no network)."""

from __future__ import annotations

import pytest
from loopback import json_server

from lerobot_policy_recent.recent_plugin.authoring.generation import extract_code, generate_skill, skill_query
from lerobot_policy_recent.skills.records import load_record
from lerobot_policy_recent.skills.repository import list_skills, load_skill, records_dir, serve_skill

PRESS = load_skill("press_button").code
DOES_NOT_PRESS = PRESS.replace("+ 0.010]", "+ 0.08]")  # hovers over the cap: parses, runs, fails Validate
IMPORTS = "import os\n\n" + PRESS


def chat_answer(code: str):
    def answer(path: str, body: dict) -> dict:
        assert path == "/v1/chat/completions"
        return {"choices": [{"message": {"role": "assistant", "content": f"Here it is:\n```python\n{code}```\n"}}]}

    return answer


def test_query_holds_the_subtask_the_panda_api_and_an_example():
    name, messages = skill_query("press_button")
    prompt = messages[-1]["content"]
    assert name == "press_button"
    assert "def press_button(env, task, button='button')" in prompt
    assert "pick(env, task, target_pos: position [m]" in prompt and "task.get_object_position" in prompt
    assert "def put_in_bin(" in prompt  # the style example


def test_extract_code_takes_the_fenced_block():
    assert extract_code("blah\n```python\ndef f():\n    pass\n```\nmore") == "def f():\n    pass\n"


@pytest.mark.slow
def test_a_valid_completion_is_validated_and_stored(tmp_path):
    requests: list[dict] = []
    with json_server(chat_answer(PRESS), requests) as url:
        result = generate_skill("press_button", base_url=url, model="gpt-x", library=tmp_path, seeds=(0, 1))
    assert result.stored, result.reason
    assert requests[0]["model"] == "gpt-x" and requests[0]["messages"][0]["role"] == "system"
    assert list_skills(tmp_path) == ["press_button"]
    stored = serve_skill("press_button", tmp_path)  # validated: the repository serves it
    assert stored.code == PRESS and stored.capabilities == ("cartesian_motion", "close_fingers", "move_end_effector")
    assert load_record("press_button", records_dir(tmp_path)).passed == [0, 1]


@pytest.mark.parametrize(
    ("code", "why"),
    [(IMPORTS, "rejected before running"), (DOES_NOT_PRESS, "failed Validate")],
    ids=["import", "fails-validate"],
)
def test_an_invalid_completion_is_not_stored(tmp_path, code, why):
    with json_server(chat_answer(code), []) as url:
        result = generate_skill("press_button", base_url=url, model="gpt-x", library=tmp_path, seeds=(0,))
    assert not result.stored and why in result.reason
    assert not list(tmp_path.iterdir())  # nothing written


def test_cli_refuses_to_overwrite_a_reference_skill(capsys):
    from lerobot_policy_recent.scripts.cli import main

    with json_server(chat_answer(PRESS), []) as url, pytest.raises(FileExistsError, match="--force"):
        main(["skills", "generate", "--subtask", "press_button", "--base-url", url, "--model", "m"])
