"""Options shared by the subcommands that ground skills."""

from __future__ import annotations

import argparse

from recent_plugin.agent import AgentSettings, RecentAgent
from recent_plugin.grounding.ablations import GROUNDING_MODES
from recent_plugin.infillers import BACKENDS
from recent_plugin.models.registry import DEFAULT_MODEL


def add_lm_arguments(parser: argparse.ArgumentParser) -> None:
    lm = parser.add_argument_group("code LM")
    lm.add_argument("--backend", choices=BACKENDS, default="llamacpp", help="span generator (default: llamacpp)")
    lm.add_argument(
        "--model", default=DEFAULT_MODEL, help=f"model name or path to a .gguf file (default: {DEFAULT_MODEL})"
    )
    lm.add_argument("--threads", type=int, default=None, help="CPU threads for llama.cpp (default: up to 2)")
    lm.add_argument("--max-retries", type=int, default=2, help="retries per rejected span (default: 2)")
    lm.add_argument(
        "--base-url", default=None, help="completions server for --backend openai, e.g. http://127.0.0.1:8000"
    )
    method = parser.add_argument_group("method (the paper's ablations)")
    method.add_argument(
        "--mode", choices=GROUNDING_MODES, default="recent", help="how skills are grounded (default: recent)"
    )
    method.add_argument("--no-insitu", action="store_true", help="no run-time checks; reactive repair only")
    method.add_argument("--no-offline-validation", action="store_true", help="serve skills that were never validated")


def agent_from_args(args: argparse.Namespace) -> RecentAgent:
    return RecentAgent(
        AgentSettings(
            backend=args.backend,
            model=args.model,
            n_threads=args.threads,
            max_retries=args.max_retries,
            base_url=args.base_url,
            mode=args.mode,
            insitu=not args.no_insitu,
            offline_validation=not args.no_offline_validation,
        )
    )
