"""``recent skills``: the offline skill repository."""

from __future__ import annotations

import json

from skills.repository import list_skills, load_skill


def register(sub) -> None:
    parser = sub.add_parser("skills", help="list and show the Panda reference skills")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    listing = actions.add_parser("list", help="skills in the repository")
    listing.add_argument("--json", action="store_true")
    listing.set_defaults(handler=_list)
    show = actions.add_parser("show", help="code and metadata of one skill")
    show.add_argument("name")
    show.set_defaults(handler=_show)


def _list(args) -> int:
    rows = [
        {"name": s.name, "subtask": s.subtask, "code_sha256": s.code_sha256} for s in map(load_skill, list_skills())
    ]
    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        for row in rows:
            print(f"{row['name']:<24} {row['subtask']:<20} {row['code_sha256'][:12]}")
    return 0


def _show(args) -> int:
    skill = load_skill(args.name)
    print(f"# {skill.name} ({skill.source_embodiment}) — {skill.intent}\n# {skill.path}\n")
    print(skill.code)
    return 0
