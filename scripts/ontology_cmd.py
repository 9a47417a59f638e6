"""``recent ontology``: build the skill ontology, print its scale, diagnose a skill for a robot."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from lerobot_policy_recent.ontology.builder import SkillSource, build_ontology
from lerobot_policy_recent.ontology.diagnosis import diagnose
from lerobot_policy_recent.ontology.instance_graph import draw_instance_graph
from lerobot_policy_recent.ontology.query import query
from lerobot_policy_recent.skills.repository import load_skill, load_skills


def register(sub) -> None:
    parser = sub.add_parser("ontology", help="build, measure and query the skill ontology")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)

    build = actions.add_parser("build", help="build the ontology and write it as Turtle")
    build.add_argument("--out", type=Path, default=Path("ontology.ttl"), help="output file (default: ontology.ttl)")
    build.set_defaults(handler=_build)

    stats = actions.add_parser("stats", help="counts of robots, primitives, relations, triples")
    stats.add_argument("--json", action="store_true")
    stats.set_defaults(handler=_stats)

    diag = actions.add_parser("diagnose", help="determined conflicts of a skill on a robot")
    diag.add_argument("--skill", required=True)
    diag.add_argument("--robot", required=True)
    diag.add_argument("--json", action="store_true")
    diag.set_defaults(handler=_diagnose)

    q = actions.add_parser("query", help="Q(skill, robot): required capabilities, conditions, robot interface")
    q.add_argument("--skill", required=True)
    q.add_argument("--robot", required=True)
    q.set_defaults(handler=_query)

    graph = actions.add_parser("graph", help="draw a skill's partial instance graph for a robot (PNG)")
    graph.add_argument("--skill", required=True)
    graph.add_argument("--robot", required=True)
    graph.add_argument("--out", type=Path, default=None, help="output PNG (default: <skill>_<robot>.png)")
    graph.set_defaults(handler=_graph)


def _with_skills():
    skills, broken = load_skills()
    for name, why in broken.items():
        print(f"recent ontology: skill {name!r} is left out: {why}", file=sys.stderr)
    return build_ontology(skills=[SkillSource(s.name, s.code, str(s.path)) for s in skills])


def _build(args) -> int:
    onto = _with_skills()
    args.out.write_text(onto.to_turtle())
    print(f"wrote {args.out} ({len(onto.store)} triples, {onto.build_seconds * 1000:.1f} ms)")
    return 0


def _stats(args) -> int:
    stats = _with_skills().stats()
    if args.json:
        print(json.dumps(stats))
    else:
        for key, value in stats.items():
            print(f"{key:>24}: {value}")
    return 0


def _skill_and_ontology(args):
    skill = load_skill(args.skill)
    onto = build_ontology()
    onto.api(args.robot)  # unknown robots fail here with the known ones listed
    return skill, onto


def _query(args) -> int:
    skill, onto = _skill_and_ontology(args)
    print(
        json.dumps(query(onto, skill.name, skill.code, args.robot, source=skill.source_embodiment).to_json(), indent=2)
    )
    return 0


def _graph(args) -> int:
    skill, onto = _skill_and_ontology(args)
    out = args.out or Path(f"{skill.name}_{args.robot}.png")
    print(draw_instance_graph(onto, skill.name, skill.code, args.robot, out, source=skill.source_embodiment))
    return 0


def _diagnose(args) -> int:
    skill, onto = _skill_and_ontology(args)
    result = diagnose(onto, skill.name, skill.code, args.robot, skill.source_embodiment, skill.placed_over)
    rows = [
        {
            "line": c.span.line,
            "span": c.span.text(skill.code),
            "span_type": c.span_type,
            "original": c.original,
            "substitute": c.substitute.signature() if c.substitute else None,
            "mapping": {m.source: m.target for m in c.mapping},
            "dropped": list(c.dropped),
            "preparatory": c.preparatory_calls(),
            "path": [step.render() for step in c.path],
            "reason": c.reason,
        }
        for c in result.conflicts
    ]
    warnings = [
        {
            "line": w.span.line,
            "span": w.span.text(skill.code),
            "kind": w.kind,
            "primitive": w.primitive,
            "phase": w.phase,
            "through": w.through,
            "check": w.check,
            "observation": w.observation,
            "message": w.message,
        }
        for w in result.warnings
    ]
    if args.json:
        print(json.dumps({"skill": skill.name, "robot": args.robot, "conflicts": rows, "warnings": warnings}, indent=2))
        return 0
    print(f"{skill.name} on {args.robot}: {len(rows)} determined conflict(s), {len(warnings)} undetermined warning(s)")
    if not rows:
        print(f"  {skill.name} is directly compatible with {args.robot}")
    for row in rows:
        print(f"  line {row['line']}: {row['span']}")
        print(f"      {row['span_type']}: {row['reason']}")
        print(f"      use {row['substitute']}  map {row['mapping']}  drop {row['dropped']}")
        if row["path"]:
            print(f"      path: {' -> '.join(row['path'])}")
    for w in warnings:
        where = f", statements 1-{w['through'] + 1} of its rewrite" if w["through"] is not None else ""
        print(f"  line {w['line']} ({w['phase']} {w['primitive']}{where}): {w['kind']}: {w['message']}")
        print(f"      check {w['check']} on {w['observation']}")
    return 0
