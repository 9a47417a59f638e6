"""``recent ground``: ground one skill for one robot and show the diff and the numbers."""

from __future__ import annotations

import json

from lerobot_policy_recent.recent_plugin.failures import FailureCategory
from lerobot_policy_recent.scripts.common import add_settings_arguments, agent_from_args


def register(sub) -> None:
    parser = sub.add_parser("ground", help="ground a Panda skill for a target robot (no execution)")
    parser.add_argument("--skill", required=True, help="skill name (see `recent skills list`)")
    parser.add_argument("--robot", required=True, help="target embodiment, e.g. UR5e")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    add_settings_arguments(parser)
    parser.set_defaults(handler=_run)


def grounding_summary(grounded) -> dict:
    return {
        "skill": grounded.skill,
        "robot": grounded.robot,
        "backend": grounded.backend,
        "model": grounded.model,
        "valid": grounded.valid,
        "diff": grounded.diff(),
        "conflicts": [
            {
                "line": c.span.line,
                "original": c.original,
                "substitute": c.substitute.name if c.substitute else None,
                "span_type": c.span_type,
                **({"omitted": c.reason} if c.omitted else {}),
                **({"refused": c.reason} if c.refused else {}),
            }
            for c in grounded.diagnosis.conflicts
        ],
        "generated_tokens": grounded.generated_tokens,
        "skill_tokens": grounded.skill_tokens,
        "go": round(grounded.go, 2),
        "lm_seconds": round(grounded.lm_seconds, 3),
        "retries": grounded.retries,
        # what the LM wrote where the ontology left a decision open, each answer with its verdict
        "lm_answers": [
            {"line": call.original, "text": call.text.strip(), "accepted": call.accepted, "message": call.message}
            for call in grounded.calls
            if not call.rendered and not call.decided and not call.declined
        ],
        "failure": None
        if grounded.valid
        else {"category": str(grounded.verdict.category), "message": grounded.verdict.message},
    }


def print_grounding(summary: dict) -> None:
    if summary["diff"]:
        print(summary["diff"])
    elif (summary["failure"] or {}).get("category") == FailureCategory.UNSUPPORTED:
        print(f"(no change: {summary['robot']} lacks a primitive the skill needs, so nothing was generated)")
    elif summary["conflicts"]:
        print("(no change: no grounding of its conflicts passed validation)")
    else:
        print("(no change: the skill is directly compatible)")
    for c in summary["conflicts"]:
        if c.get("omitted"):
            substitute = f"nothing: {c['omitted']}"
        elif c.get("refused"):
            substitute = f"refused: {c['refused']}"
        else:
            substitute = c["substitute"] or "?"
        print(f"  line {c['line']}: {c['original']} -> {substitute} ({c['span_type']})")
    for answer in summary["lm_answers"]:
        verdict = "accepted" if answer["accepted"] else f"rejected: {answer['message']}"
        print(f"  LM wrote for {answer['line']}: {answer['text']} -> {verdict}")
    verdict = (
        "valid" if summary["valid"] else f"REJECTED ({summary['failure']['category']}: {summary['failure']['message']})"
    )
    print(
        f"grounding [{summary['backend']}:{summary['model']}]: {verdict}; "
        f"{summary['generated_tokens']} tokens generated vs {summary['skill_tokens']} skill tokens (GO {summary['go']:.1f}% before execution), "
        f"LM {summary['lm_seconds']:.2f} s, {summary['retries']} retries"
    )


def _run(args) -> int:
    grounded, _ = agent_from_args(args).ground(args.skill, args.robot)
    summary = grounding_summary(grounded)
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print_grounding(summary)
    return 0 if grounded.valid else 1
