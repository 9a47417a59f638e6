"""One settings tree: the `recent` CLI's options and `lerobot-eval --policy.*` come from the same dataclasses,
a run's recorded command reproduces its settings, and one record describes an episode everywhere."""

from __future__ import annotations

import dataclasses
import json

import pytest

from lerobot_policy_recent.evaluation.jobs import BenchConfig, Job, episode_record
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.recent_plugin.infillers.configs import InfillerConfig, RuleConfig, TransformersConfig
from lerobot_policy_recent.recent_plugin.methods import Method, method_named
from lerobot_policy_recent.recent_plugin.settings import RecentSettings, parse_settings, settings_flags
from lerobot_policy_recent.scripts.bench_cmd import command_line
from lerobot_policy_recent.scripts.cli import build_parser, main
from lerobot_policy_recent.scripts.common import settings_options


def _option_strings(command: str) -> set[str]:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices[command]
    return {s for a in sub._actions for s in a.option_strings}


def test_the_cli_options_are_the_settings_tree_that_lerobot_eval_reads():
    from lerobot_policy_recent.recent_plugin.configuration_recent import RecentConfig

    tree = {o.path for o in settings_options()}
    assert {f"--{p}" for p in tree} <= _option_strings("run")
    # every top-level field of the tree is a field of the LeRobot config, with the same type
    policy = {f.name: f.type for f in dataclasses.fields(RecentConfig)}
    assert all(policy[f.name] == f.type for f in dataclasses.fields(RecentSettings))
    assert {"infiller.type", "infiller.model", "infiller.n_threads", "method.type", "method.insitu"} <= tree
    # the choices are the registered classes, nothing listed by hand
    options = {o.path: o for o in settings_options()}
    assert set(options["infiller.type"].choices) == set(InfillerConfig.get_known_choices())
    assert set(options["method.type"].choices) == set(Method.get_known_choices())
    assert {"recent", "cap", "repair", "agentless", "recent-no-insitu", "recent-full-regen"} <= set(
        Method.get_known_choices()
    )


def test_bench_takes_methods_by_name_not_the_method_subtree():
    options = _option_strings("bench")
    assert "--infiller.type" in options and not any(o.startswith("--method.") for o in options)


def test_a_dump_of_the_resolved_tree_reproduces_it():
    settings = RecentSettings(
        infiller=TransformersConfig(model="Qwen/Qwen2.5-Coder-7B", device="cpu", dtype="float16"),
        method=method_named("recent-no-insitu"),
        max_retries=4,
        lm_seed=7,
    )
    assert parse_settings(settings_flags(settings.to_dict())) == settings
    config = BenchConfig(out="/tmp/x", methods=("recent", "cap"), agent=settings)
    command = command_line(config)
    assert "--infiller.type=transformers" in command and "--infiller.dtype=float16" in command
    assert "--lm_seed=7" in command and "--max_retries=4" in command


def test_unknown_choices_and_values_are_refused():
    with pytest.raises(SystemExit):
        main(["run", "--infiller.type", "gpt9"])
    with pytest.raises(ValueError, match="unknown method 'nope'"):
        method_named("nope")
    assert main(["run", "--max_retries=-1", "--infiller.type=rule", "--no-log"]) == 2


def test_one_record_per_episode(ontology, rule_infiller, capsys):
    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), infiller=rule_infiller, ontology=ontology)
    result = run_episode(agent, "cube_in_bin", "UR5e", seed=0)
    record = result.to_record()
    event = result.ended_event().payload()
    assert event == {key: record[key] for key in event}  # the event is the record's subset
    bench = episode_record(Job("recent", "kinematic", "cube_in_bin", "UR5e", 0), result)
    assert {key: bench[key] for key in record} == record
    assert main(["run", "--infiller.type", "rule", "--no-log", "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert set(record) <= set(printed) and printed["it"] == record["it"] and printed["success"] is True
