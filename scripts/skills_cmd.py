"""``recent skills``: the offline skill repository — list, show, validate on the source robot."""

from __future__ import annotations

import json

from skills.repository import list_skills, load_skill
from skills.validation import load_record, save_record, validate


def register(sub) -> None:
    parser = sub.add_parser("skills", help="list, show and validate the Panda reference skills")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    listing = actions.add_parser("list", help="skills in the repository and whether they are validated")
    listing.add_argument("--json", action="store_true")
    listing.set_defaults(handler=_list)
    show = actions.add_parser("show", help="code, metadata and last validation of one skill")
    show.add_argument("name")
    show.set_defaults(handler=_show)
    check = actions.add_parser("validate", help="run skills on Panda over the five seeds and record the outcome")
    check.add_argument("--skill", action="append", help="a skill to validate (repeatable; default: all)")
    check.set_defaults(handler=_validate)


def _row(name: str) -> dict:
    skill, record = load_skill(name), load_record(name)
    return {
        "name": skill.name,
        "subtask": skill.subtask,
        "validated": bool(record and record.matches(skill)),
        "code_sha256": skill.code_sha256,
        "seeds_passed": sorted(record.passed) if record and record.code_sha256 == skill.code_sha256 else [],
    }


def _list(args) -> int:
    rows = [_row(name) for name in list_skills()]
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    for row in rows:
        state = "validated" if row["validated"] else "NOT validated"
        print(
            f"{row['name']:<18} {row['subtask']:<18} {row['code_sha256'][:12]}  {state} ({len(row['seeds_passed'])}/5 seeds)"
        )
    return 0


def _show(args) -> int:
    skill, record = load_skill(args.name), load_record(args.name)
    print(f"# {skill.name} ({skill.source_embodiment}) — {skill.intent}\n# {skill.path}")
    print(f"# subtask: {skill.subtask}")
    print(f"# preconditions: {', '.join(skill.preconditions) or '-'}")
    print(f"# effects: {', '.join(skill.effects) or '-'}")
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

    names = args.skill or list_skills()
    skills = [load_skill(name) for name in names]  # unknown names fail before anything runs
    failed = []
    with tqdm(total=5 * len(skills), unit="episode", desc="validate") as bar:
        for skill in skills:
            bar.set_postfix_str(skill.name)
            record = validate(skill, on_episode=lambda seed, reason: bar.update(1))
            save_record(record)
            if not record.validated:
                failed.append(f"{skill.name}: {record.failures}")
    for line in failed:
        print(f"FAILED {line}")
    print(f"{len(skills) - len(failed)}/{len(skills)} skill(s) validated; records in skills/validation/")
    return 1 if failed else 0
