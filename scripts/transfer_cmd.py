"""``recent transfer``: the transfer matrix, every skill on every robot (``evaluation/transfer.py``)."""

from __future__ import annotations

import sys
from pathlib import Path

from lerobot_policy_recent.scripts.common import add_settings_arguments, agent_from_args


def register(sub) -> None:
    parser = sub.add_parser(
        "transfer",
        help="ground every skill on every robot: by the ontology, by the LM, or refused with the reason",
        description=(
            "Ground every skill of the library on every embodiment (or those named) and write "
            "OUT/transfer.json, OUT/transfer.md (a table, the refused and invalid cells with their "
            "reasons) and OUT/transfer.png (a heatmap). Exit status 1 if a cell is a defect: refused by "
            "the ontology for a missing capability, yet validated."
        ),
    )
    parser.add_argument("--skills", default="", help="comma list of skills (default: the whole library)")
    parser.add_argument("--robots", default="", help="comma list of embodiments (default: every one)")
    parser.add_argument("--out", default="outputs/transfer", help="output directory (default: outputs/transfer)")
    add_settings_arguments(parser)
    parser.set_defaults(handler=_run)


def _run(args) -> int:
    from lerobot_policy_recent.descriptions.embodiments import EMBODIMENTS
    from lerobot_policy_recent.evaluation.transfer import ground_cells, write_matrix
    from lerobot_policy_recent.skills.repository import list_skills

    agent = agent_from_args(args)
    skills = _names(args.skills, "--skills", list_skills(agent.library))
    robots = _names(args.robots, "--robots", list(EMBODIMENTS))
    total = len(skills) * len(robots)
    done = []

    def progress(cell) -> None:
        done.append(cell)
        print(f"[{len(done)}/{total}] {cell.skill} on {cell.robot}: {cell.grounding}", file=sys.stderr)

    cells = ground_cells(agent, skills, robots, on_cell=progress)
    header = {"backend": agent.infiller.name, "model": agent.infiller.model, "method": agent.settings.method.name}
    paths = write_matrix(cells, Path(args.out), header)
    print(paths["md"].read_text(), end="")
    print(f"wrote {paths['json']}, {paths['md']}, {paths['png']}")
    return 1 if any(c.defect for c in cells) else 0


def _names(text: str, option: str, known: list[str]) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()] or list(known)
    unknown = [n for n in names if n not in known]
    if unknown:
        raise SystemExit(f"{option}: unknown {', '.join(unknown)}; known: {', '.join(known)}")
    return names
