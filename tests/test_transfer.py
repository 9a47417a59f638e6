"""The transfer matrix: every cell's grounding classified, refusals named, files written and read back."""

from __future__ import annotations

import json
import subprocess
import sys

from lerobot_policy_recent.evaluation.transfer import classify, ground_cells, render_table, write_matrix


def test_cells_say_who_decided_and_why_a_robot_cannot(panda_agent, tmp_path):
    cells = ground_cells(panda_agent, ["put_in_bin", "stack_tower"], ["Panda", "Suction", "IIWAKRL"])
    at = {(c.skill, c.robot): c for c in cells}
    assert at["put_in_bin", "Panda"].grounding == "source"
    assert at["put_in_bin", "Suction"].grounding == "ontology" and at["put_in_bin", "Suction"].lm_calls == 0
    refused = at["stack_tower", "IIWAKRL"]
    assert refused.grounding == "refused" and "no primitive with the effects of place" in refused.reason
    assert not refused.defect  # the rule backend did not get it through validation
    paths = write_matrix(cells, tmp_path, {"backend": "rule"})
    data = json.loads(paths["json"].read_text())
    assert data["counts"]["refused"] == 1 and len(data["cells"]) == 6
    table = paths["md"].read_text()
    assert "| `stack_tower` | IIWAKRL | refused |" in table and paths["png"].stat().st_size > 1000


def test_a_refused_cell_the_lm_got_through_validation_is_a_defect(panda_agent):
    grounded, _ = panda_agent.ground("stack_tower", "IIWAKRL")
    forced = type(grounded)(**{**grounded.__dict__})
    forced.verdict = type(grounded.verdict)(True)
    cell = classify(forced, "FrankaHand")
    assert cell.grounding == "refused" and cell.defect
    assert "(defect)" in render_table([cell]) and "!" in render_table([cell])


def test_the_command_names_an_unknown_robot_in_one_line(tmp_path):
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "lerobot_policy_recent.scripts.cli",
            "transfer",
            "--robots",
            "Kuka",
            "--infiller.type",
            "rule",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
    )
    assert done.returncode != 0 and "--robots: unknown Kuka" in done.stderr.strip().splitlines()[-1]
