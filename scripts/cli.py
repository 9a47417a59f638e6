"""``recent``: one command for RECENT, with subcommands in the spirit of LeRobot's CLIs.

recent run                 ground a Panda skill onto a robot and execute it (the main job)
recent ground              ground one skill and print the diff and the numbers
recent bench [report]      RECENT vs ablations and baselines on the suites; tables and plots
recent cache info|clear    grounded skills kept on disk across processes
recent model fetch|list|path
recent ontology build|stats|diagnose
recent skills list|show
recent envs list|show        embodiments, subtasks, task suites, variations
recent envs show-embodiment|check   a robot's calibration; the canonical set against the Panda
recent logs verify           check (and --recover) logged runs
recent failures report       failures of logged runs by category, with a bar chart
recent replay                open or rebuild an episode's Rerun recording
recent upload                push a run's datasets to the Hugging Face Hub
"""

from __future__ import annotations

import argparse
import logging
import sys


def commands() -> tuple:
    """The subcommand modules, imported when the parser is built (so that what their imports load, such
    as the robots of ``RECENT_ROBOTS``, fails as a CLI error, not as a traceback)."""
    from lerobot_policy_recent.scripts import (
        bench_cmd,
        cache_cmd,
        envs_cmd,
        episode_cmd,
        ground_cmd,
        logs_cmd,
        model_cmd,
        ontology_cmd,
        skills_cmd,
        transfer_cmd,
    )

    return (
        episode_cmd,
        ground_cmd,
        transfer_cmd,
        bench_cmd,
        cache_cmd,
        envs_cmd,
        model_cmd,
        ontology_cmd,
        skills_cmd,
        logs_cmd,
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="recent",
        description="RECENT for LeRobot: ground robot skill code across embodiments with a small code LM.",
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in commands():
        module.register(sub)
    return parser


def underscored(argv: list[str]) -> list[str]:
    """Options spelled with dashes, as underscores: ``--log_dir=x`` is ``--log_dir=x``.

    The ``recent`` options follow LeRobot's spelling (``--policy.max_skill_steps``, ``--output_dir``);
    the dashed one is accepted as an alias. Values, and everything after ``--``, are left alone.
    """
    out = []
    for i, word in enumerate(argv):
        if word == "--":
            return out + argv[i:]
        if word.startswith("--"):
            flag, eq, value = word.partition("=")
            word = "--" + flag[2:].replace("-", "_") + eq + value
        out.append(word)
    return out


def main(argv: list[str] | None = None) -> int:
    try:
        parser = build_parser()
    except ValueError as exc:  # a robot file on RECENT_ROBOTS that cannot load, named with its field
        print(f"recent: error: {exc}", file=sys.stderr)
        return 2
    args = parser.parse_args(underscored(sys.argv[1:] if argv is None else list(argv)))
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.WARNING, format="%(levelname)s %(name)s: %(message)s"
    )
    try:
        return int(args.handler(args) or 0)
    except (KeyError, ValueError, FileNotFoundError, RuntimeError) as exc:
        message = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"recent {args.command}: error: {message}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
