"""The LM runtime starts on any x86-64 host, proves itself, and a native crash is an explained error.

The smoke check here is the one ``scripts/setup.sh`` runs before it says "ready": on a host where
llama.cpp's kernels crash (an AMX Xeon with a natively built wheel did), this file fails with the
check's message instead of the whole suite dying of a segfault.
"""

from __future__ import annotations

import os
import signal
import time

import pytest

from lerobot_policy_recent.recent_plugin.infillers.llama_runtime import (
    AMX_VARIANTS,
    CpuKernelsError,
    choose_variant,
    variant_libraries,
)
from lerobot_policy_recent.recent_plugin.models import model_path

SCORES = {"x64": 1, "haswell": 40, "skylakex": 90, "zen4": 120, "sapphirerapids": 250, "alderlake": 0}


def test_the_best_variant_this_cpu_runs_is_chosen_and_amx_is_left_out():
    assert choose_variant(SCORES) == "zen4"  # sapphirerapids scores higher, but its AMX kernels crashed
    assert choose_variant({"x64": 1, "haswell": 0}) == "x64"
    assert choose_variant(SCORES, "sapphirerapids") == "sapphirerapids"  # AMX only when asked for by name


def test_a_forced_variant_must_exist_and_run_on_this_cpu():
    with pytest.raises(CpuKernelsError, match="no such variant"):
        choose_variant(SCORES, "graviton")
    with pytest.raises(CpuKernelsError, match="lacks instructions"):
        choose_variant(SCORES, "alderlake")
    with pytest.raises(CpuKernelsError, match="none of llama.cpp's CPU-kernel variants"):
        choose_variant({"zen4": 0, "sapphirerapids": 7})


def test_the_installed_llama_cpp_selects_its_cpu_kernels_at_run_time():
    """The wheel setup installs is the portable one: kernels for every x86-64 level, none tied to the build host."""
    variants = variant_libraries()
    assert {"x64", "haswell", "skylakex"} <= set(variants), f"not the portable build: {sorted(variants)}"
    assert AMX_VARIANTS <= set(variants)  # built, but only loaded when forced


@pytest.fixture(scope="module")
def gguf() -> str:
    path = model_path("qwen2.5-coder-1.5b")
    if not path.is_file():
        pytest.fail("the 1.5B GGUF is not in the cache: run `recent model fetch qwen2.5-coder-1.5b` (setup does)")
    return str(path)


def test_setup_smoke_check_passes_on_this_host(gguf):
    """Setup's check: a worker process loads the model and fills ``return a + b``."""
    from lerobot_policy_recent.recent_plugin.infillers.llama_check import check_lm

    result = check_lm(gguf)
    assert result.ok, result.problem
    kernels = result.info["cpu_kernels"]
    assert kernels not in AMX_VARIANTS and result.info["cpu_kernel_scores"][kernels] > 0
    assert "`a + b`" in result.summary() or "`b + a`" in result.summary()


def test_a_dead_worker_is_an_explained_error_and_the_next_call_starts_a_fresh_one(gguf):
    from lerobot_policy_recent.recent_plugin.infillers.llama_worker import LlamaWorker, LMWorkerCrashed

    worker = LlamaWorker(gguf)
    try:
        first = worker.pid
        assert worker.tokenize("open_gripper(env, task)")
        os.kill(first, signal.SIGSEGV)  # what a bad kernel does
        with pytest.raises(LMWorkerCrashed) as crash:
            worker.tokenize("open_gripper(env, task)")
        message = str(crash.value)
        for part in ("killed by SIGSEGV", "CPU:", "Kernels:", "llama-cpp-python", "Fix:", "scripts/setup.sh"):
            assert part in message, message
        assert worker.tokenize("x") and worker.pid != first  # a benchmark loses only the call in flight
    finally:
        worker.close()
    assert not worker.alive


def test_python_errors_in_the_worker_come_back_as_python_errors(gguf):
    from lerobot_policy_recent.recent_plugin.infillers.llama_worker import LlamaWorker

    worker = LlamaWorker(gguf)
    try:
        with pytest.raises(AttributeError, match="in the LM worker"):
            worker.tokenize(None)  # type: ignore[arg-type]
        with pytest.raises(ValueError, match="unknown LM worker call"):
            worker._call("shutdown_everything")
        assert worker.alive and worker.tokenize("still here")
    finally:
        worker.close()


def test_an_episode_whose_lm_dies_ends_with_the_reason_in_logs_that_verify(gguf, ontology, tmp_path):
    """Kill the LM mid-run: the CLI's error names the cause, the episode's logs are whole and say 'crash'."""
    import pyarrow.parquet as pq

    from lerobot_policy_recent.logs.layout import LogLayout
    from lerobot_policy_recent.logs.recorder import Recorder
    from lerobot_policy_recent.logs.verify import verify
    from lerobot_policy_recent.recent_plugin.agent import RecentAgent
    from lerobot_policy_recent.recent_plugin.episode import run_episode
    from lerobot_policy_recent.recent_plugin.infillers.llama_worker import LMWorkerCrashed
    from lerobot_policy_recent.recent_plugin.infillers.llamacpp import LlamaCppInfiller
    from lerobot_policy_recent.recent_plugin.settings import RecentSettings

    infiller = LlamaCppInfiller(gguf)
    agent = RecentAgent(RecentSettings(), infiller=infiller, ontology=ontology)
    os.kill(infiller.lm.pid, signal.SIGKILL)
    for _ in range(100):  # bounded: SIGKILL is delivered within milliseconds
        if not infiller.lm.alive:
            break
        time.sleep(0.05)
    with Recorder(tmp_path) as recorder, pytest.raises(LMWorkerCrashed, match="killed by SIGKILL"):
        run_episode(agent, "cube_in_bin", "UR5e", seed=0, recorder=recorder)
    infiller.close()

    report = verify(tmp_path)
    assert report.ok, (report.problems, [e.problems for e in report.episodes])
    row = pq.read_table(LogLayout(tmp_path).results(0)).to_pylist()[0]
    assert row["failure_category"] == "crash" and "LMWorkerCrashed" in row["failure_message"]
    assert row["success"] is False


def test_a_model_that_does_not_load_is_a_python_error_and_leaves_no_worker(tmp_path):
    from lerobot_policy_recent.recent_plugin.infillers.llama_check import check_lm
    from lerobot_policy_recent.recent_plugin.infillers.llama_worker import LlamaWorker

    bad = tmp_path / "truncated.gguf"
    bad.write_bytes(b"GGUF\x03\x00\x00\x00")
    with pytest.raises(ValueError, match="in the LM worker"):
        LlamaWorker(str(bad))
    result = check_lm(str(bad))
    assert not result.ok and "ValueError" in result.problem and "Fix:" in result.problem


def test_inside_lerobot_eval_a_dead_lm_is_the_policys_error_and_its_episode_is_logged_as_crash(gguf, tmp_path):
    import pyarrow.parquet as pq
    import torch
    from lerobot.policies.factory import make_policy, make_pre_post_processors

    import lerobot_policy_recent  # noqa: F401
    from lerobot_policy_recent.logs.layout import LogLayout
    from lerobot_policy_recent.logs.verify import verify
    from lerobot_policy_recent.recent_plugin.configuration_recent import RecentConfig
    from lerobot_policy_recent.recent_plugin.infillers.llama_worker import LMWorkerCrashed
    from lerobot_policy_recent.recent_plugin.methods import method_named
    from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
    from lerobot_policy_recent.robosuite_envs.lerobot_env import RecentEnvConfig

    env_cfg = RecentEnvConfig(task="cube_in_bin", robot="UR5e")
    policy = make_policy(RecentConfig(log_dir=str(tmp_path), method=method_named("recent")), env_cfg=env_cfg)
    pre, _ = make_pre_post_processors(policy.config)
    worker = policy.agent.infiller.lm
    os.kill(worker.pid, signal.SIGKILL)
    for _ in range(100):
        if not worker.alive:
            break
        time.sleep(0.05)
    env = RecentEnv(task="cube_in_bin", robot="UR5e", render_mode="none")
    obs, _ = env.reset(seed=0)
    batch = {
        "observation.state": torch.from_numpy(obs["agent_pos"])[None],
        "observation.environment_state": torch.from_numpy(obs["environment_state"])[None],
        "task": [env.task_description],
    }
    with pytest.raises(LMWorkerCrashed, match="killed by SIGKILL"):
        policy.select_action(pre(batch))
    env.close()
    policy.close_logs()

    assert verify(tmp_path).ok
    row = pq.read_table(LogLayout(tmp_path).results(0)).to_pylist()[0]
    assert row["failure_category"] == "crash" and "LMWorkerCrashed" in row["failure_message"]
