"""Options shared by the subcommands that ground skills."""

from __future__ import annotations

import argparse

from lerobot_policy_recent.recent_plugin.agent import MODES, AgentSettings, RecentAgent
from lerobot_policy_recent.recent_plugin.infillers import BACKENDS
from lerobot_policy_recent.recent_plugin.models.registry import DEFAULT_MODEL


def add_lm_arguments(parser: argparse.ArgumentParser, *, with_method: bool = True) -> None:
    """LM options (and, ``with_method``, the method options: ``recent bench`` takes methods by name)."""
    lm = parser.add_argument_group("code LM")
    lm.add_argument("--backend", choices=BACKENDS, default="llamacpp", help="span generator (default: llamacpp)")
    lm.add_argument(
        "--model",
        default=DEFAULT_MODEL,
        help=f"model name, .gguf path, or (transformers) Hub id / model dir (default: {DEFAULT_MODEL})",
    )
    lm.add_argument("--threads", type=int, default=None, help="CPU threads for llama.cpp (default: up to 2)")
    lm.add_argument("--max-retries", type=int, default=2, help="retries per rejected span (default: 2)")
    lm.add_argument(
        "--base-url", default=None, help="completions server for --backend openai, e.g. http://127.0.0.1:8000"
    )
    lm.add_argument(
        "--fast-path", action="store_true", help="render spans the ontology fully decides without the LM (0 tokens)"
    )
    lm.add_argument("--device", default=None, help="transformers backend: cuda or cpu (default: CUDA when available)")
    lm.add_argument("--dtype", default="auto", help="transformers backend: auto, float32, float16, bfloat16")
    lm.add_argument("--quantization", default=None, choices=("8bit", "4bit"), help="transformers backend, CUDA only")
    if not with_method:
        return
    method = parser.add_argument_group("method (the paper's ablations and baselines)")
    method.add_argument(
        "--mode",
        choices=MODES,
        default="recent",
        help="how skills are grounded: RECENT, an ablation or a baseline (default: recent)",
    )
    method.add_argument("--no-insitu", action="store_true", help="no run-time checks; reactive repair only")
    method.add_argument("--no-offline-validation", action="store_true", help="serve skills that were never validated")


def settings_from_args(args: argparse.Namespace) -> AgentSettings:
    return AgentSettings(
        backend=args.backend,
        model=args.model,
        n_threads=args.threads,
        max_retries=args.max_retries,
        base_url=args.base_url,
        lm_device=args.device,
        lm_dtype=args.dtype,
        lm_quantization=args.quantization,
        fast_path=args.fast_path,
        mode=getattr(args, "mode", AgentSettings.mode),
        insitu=not getattr(args, "no_insitu", False),
        offline_validation=not getattr(args, "no_offline_validation", False),
    )


def agent_from_args(args: argparse.Namespace) -> RecentAgent:
    return RecentAgent(settings_from_args(args))
