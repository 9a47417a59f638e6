"""``recent skills``: the offline skill repository — list, show, validate on the source robot."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from lerobot_policy_recent.recent_plugin.authoring.sim_validation import validate
from lerobot_policy_recent.robosuite_envs.suites import SEEDS, validation_task
from lerobot_policy_recent.skills.records import load_record, records_dir, save_record
from lerobot_policy_recent.skills.repository import (
    LIBRARY,
    Skill,
    derived_capabilities,
    list_skills,
    load_skill,
    load_skills,
    skill_home,
    source_call_sites,
)


def register(sub) -> None:
    parser = sub.add_parser("skills", help="list, show and validate the reference skills (each on its source robot)")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    listing = actions.add_parser("list", help="skills in the repository and whether they are validated")
    listing.add_argument("--json", action="store_true")
    _library_argument(listing)
    listing.set_defaults(handler=_list)
    show = actions.add_parser("show", help="code, metadata and last validation of one skill")
    show.add_argument("name")
    _library_argument(show)
    show.set_defaults(handler=_show)
    check = actions.add_parser(
        "validate", help="run skills on their source robot over five seeds and record the outcome"
    )
    check.add_argument(
        "--skill", action="append", help="a skill to validate (repeatable; default: all of the library's own)"
    )
    _library_argument(check)
    check.add_argument(
        "--seeds",
        choices=("paper", "dev"),
        default="paper",
        help="the paper's five seeds (every record of the -v1 suites' skills), or the five dev seeds (the skills "
        "of the paper-length suites' new subtasks: the paper's seeds are the test split's)",
    )
    check.set_defaults(handler=_validate)
    gen = actions.add_parser(
        "generate",
        help="have an LLM write a Panda skill for a subtask; stored only if it passes Validate",
        description="Sends Q(skill, Panda) to an OpenAI-compatible /v1/chat/completions endpoint and stores "
        "the answer in the library only if it passes the AST policy and Validate(skill, Panda) on every seed.",
    )
    gen.add_argument("--subtask", required=True, help="a subtask (recent envs list shows them per task)")
    gen.add_argument("--base_url", required=True, help="e.g. https://api.openai.com or http://localhost:8000")
    gen.add_argument("--model", required=True)
    gen.add_argument("--api_key_env", default="OPENAI_API_KEY", help="environment variable holding the key")
    gen.add_argument(
        "--skill_library",
        type=Path,
        default=LIBRARY,
        metavar="DIR",
        help="where to store the skill, with its record in DIR/validation/ (default: the bundled library)",
    )
    gen.add_argument("--force", action="store_true", help="replace an existing skill of that name")
    gen.set_defaults(handler=_generate)


def _library_argument(parser) -> None:
    parser.add_argument(
        "--skill_library",
        type=_directory,
        default=LIBRARY,
        metavar="DIR",
        help="your skills (NAME.py + NAME.yaml, records in DIR/validation/), served before the bundled skills of "
        "the same name; the run commands take the same option (default: the bundled library)",
    )


def _directory(text: str) -> Path:
    path = Path(text)
    if not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is not a directory")
    return path


def _row(skill: Skill) -> dict:
    record = load_record(skill.name, records_dir(skill.path.parent))
    return {
        "name": skill.name,
        "library": str(skill.path.parent),
        "subtask": skill.subtask,
        "source": skill.source_embodiment,
        "validated": bool(record and record.matches(skill.code_sha256)),
        "code_sha256": skill.code_sha256,
        "seeds_passed": sorted(record.passed) if record and record.code_sha256 == skill.code_sha256 else [],
    }


def _list(args) -> int:
    skills, broken = load_skills(args.skill_library)  # a broken file disables its skill, not the listing
    rows = [_row(s) for s in skills] + [{"name": n, "broken": why} for n, why in broken.items()]
    rows.sort(key=lambda row: row["name"])
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    for row in rows:
        if row.get("broken"):
            print(f"{row['name']:<18} BROKEN: {row['broken']}")
            continue
        state = "validated" if row["validated"] else "NOT validated"
        own = f"  {row['library']}" if Path(row["library"]) != LIBRARY else ""
        print(
            f"{row['name']:<18} {row['subtask']:<18} {row['source']:<11} {row['code_sha256'][:12]}  {state} "
            f"({len(row['seeds_passed'])}/5 seeds){own}"
        )
    return 0


def _show(args) -> int:
    home = skill_home(args.name, args.skill_library)
    skill, record = load_skill(args.name, home), load_record(args.name, records_dir(home))
    print(f"# {skill.name} ({skill.source_embodiment}) — {skill.intent}\n# {skill.path}")
    print(f"# subtask: {skill.subtask}")
    print(f"# preconditions: {', '.join(skill.preconditions) or '-'}")
    print(f"# effects: {', '.join(skill.effects) or '-'}")
    leaves = [f"{e.parameter} state {e.wanted}" for e in skill.state_effects]
    leaves += [f"{p.parameter} over {p.over}" for p in skill.placements]
    if leaves:
        print(f"# leaves: {'; '.join(leaves)}")
    print(f"# capabilities: {', '.join(skill.capabilities or derived_capabilities(skill))}")
    sites = source_call_sites(skill)
    print(f"# call sites: {', '.join(f'{s.name} (line {s.span.line})' for s in sites) or '-'}")
    if record is None:
        print("# validation: never validated")
    else:
        stale = "" if record.code_sha256 == skill.code_sha256 else " — STALE: the code changed since"
        print(
            f"# validation: {record.validated_at} on {record.robot} in {record.task}: seeds passed "
            f"{sorted(record.passed)} of {record.seeds}{stale}"
        )
        for seed, reason in record.failures.items():
            print(f"#   seed {seed}: {reason}")
    print()
    print(skill.code)
    return 0


def _validate(args) -> int:
    from tqdm import tqdm

    from lerobot_policy_recent.robosuite_envs.splits import DEV_SEEDS

    names = args.skill or list_skills(args.skill_library)
    # unknown names fail before anything runs; a user's skill is validated in its own library
    skills = [load_skill(name, skill_home(name, args.skill_library)) for name in names]
    for skill in skills:  # each runs in its subtask's single-subtask task
        try:
            validation_task(skill.subtask)
        except KeyError:
            raise ValueError(
                f"{skill.path.with_suffix('.yaml')}: field 'subtask': {skill.subtask!r} has no single-subtask task "
                "to validate in (`recent envs list` shows the subtasks)"
            ) from None
    seeds = DEV_SEEDS if args.seeds == "dev" else SEEDS
    failed, saved = [], set()
    with tqdm(total=len(seeds) * len(skills), unit="episode", desc="validate") as bar:
        for skill in skills:
            bar.set_postfix_str(skill.name)
            record = validate(skill, seeds, on_episode=lambda seed, reason: bar.update(1))
            saved.add(str(save_record(record, records_dir(skill.path.parent)).parent))
            if not record.validated:
                failed.append(f"{skill.name}: {record.failures}")
    for line in failed:
        print(f"FAILED {line}")
    print(f"{len(skills) - len(failed)}/{len(skills)} skill(s) validated; records in {', '.join(sorted(saved))}")
    return 1 if failed else 0


def _generate(args) -> int:
    from tqdm import tqdm

    from lerobot_policy_recent.recent_plugin.authoring.generation import generate_skill

    with tqdm(total=len(SEEDS), unit="episode", desc=f"validate generated {args.subtask}") as bar:
        result = generate_skill(
            args.subtask,
            base_url=args.base_url,
            model=args.model,
            api_key=os.environ.get(args.api_key_env),
            library=args.skill_library,
            force=args.force,
            on_episode=lambda seed, reason: bar.update(1),
        )
    if not result.stored:
        print(f"not stored: {result.reason}\n--- the completion ---\n{result.code}")
        return 1
    print(f"stored {result.skill}: " + ", ".join(str(p) for p in result.paths))
    return 0
