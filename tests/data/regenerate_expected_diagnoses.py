"""Recompute D(skill, robot) in ``expected_diagnoses.yaml`` for new skills, new robots and the skills named.

    .venv/bin/python tests/data/regenerate_expected_diagnoses.py [SKILL ...]

Entries of other skills and robots are kept as they are. Review the diff before committing: the table is
the reference the ontology test holds D to.
"""

from __future__ import annotations

import sys
from pathlib import Path

import yaml

from lerobot_policy_recent.ontology.builder import build_ontology
from lerobot_policy_recent.ontology.diagnosis import diagnose
from lerobot_policy_recent.skills.repository import list_skills, load_skill

TABLE = Path(__file__).with_name("expected_diagnoses.yaml")


def main(refresh: list[str]) -> None:
    text = TABLE.read_text()
    header = "".join(line for line in text.splitlines(keepends=True) if line.startswith("#"))
    table = yaml.safe_load(text) or {}
    onto = build_ontology()
    changed = []
    for name in list_skills():
        skill = load_skill(name)
        kept = {} if name in refresh else table.get(name, {})
        robots = [r for r in sorted(set(onto.robot_names()) - {skill.source_embodiment}) if r not in kept]
        table[name] = {
            **kept,
            **{r: diagnose(onto, skill.name, skill.code, r, source=skill.source_embodiment).summary() for r in robots},
        }
        changed += [f"{name}/{r}" for r in robots]
    TABLE.write_text(header + yaml.safe_dump(table, sort_keys=True))
    print(f"recomputed {len(changed)} (skill, robot) pair(s): {', '.join(changed) or '-'}")


if __name__ == "__main__":
    main(sys.argv[1:])
