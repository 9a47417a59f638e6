"""Draw a skill's partial instance graph for one robot (the paper's Fig.: open_gripper → deactivate_vacuum).

Columns, left to right: the skill, the source primitives it calls, the target robot's primitives
that substitute for them, the target robot; below the robot, the capabilities it lacks.
"""

from __future__ import annotations

from pathlib import Path

from lerobot_policy_recent.ontology.builder import Ontology
from lerobot_policy_recent.ontology.diagnosis import diagnose
from lerobot_policy_recent.ontology.query import query
from lerobot_policy_recent.recent_plugin.extras import pyplot

COLORS = {"skill": "#4c72b0", "source": "#8c8c8c", "target": "#55a868", "robot": "#dd8452", "gap": "#c44e52"}
COLUMNS = {"skill": 0.0, "source": 3.0, "target": 7.0, "robot": 10.6, "gap": 10.0}


def draw_instance_graph(
    onto: Ontology, skill_name: str, code: str, robot: str, out: Path, source: str = "Panda"
) -> Path:
    plt = pyplot("recent ontology graph")

    diag = diagnose(onto, skill_name, code, robot, source)
    gaps = sorted(query(onto, skill_name, code, robot, source).gaps)
    rows = max(len(diag.conflicts), 1)
    fig, ax = plt.subplots(figsize=(14, 1.6 + 1.2 * rows + (0.8 if gaps else 0)))

    def box(kind: str, y: float, text: str) -> tuple[float, float]:
        x = COLUMNS[kind]
        ax.text(
            x,
            y,
            text,
            ha="center",
            va="center",
            color="white",
            fontsize=9,
            bbox={"boxstyle": "round,pad=0.5", "fc": COLORS[kind], "ec": "none"},
        )
        return x, y

    def arrow(a: tuple[float, float], b: tuple[float, float], label: str) -> None:
        ax.annotate(
            "", xy=b, xytext=a, arrowprops={"arrowstyle": "-|>", "shrinkA": 70, "shrinkB": 80, "color": "#333333"}
        )
        ax.text((a[0] + b[0]) / 2, (a[1] + b[1]) / 2 + 0.12, label, ha="center", fontsize=8, color="#333333")

    middle = (rows - 1) / 2
    skill = box("skill", middle, f"skill {skill_name}")
    robot_box = box("robot", middle, f"robot {robot}\n({onto.grippers[robot].mechanism.replace('_', ' ')})")
    for i, conflict in enumerate(diag.conflicts):
        y = rows - 1 - i
        src = box("source", y, f"{source}.{conflict.original}")
        arrow(skill, src, "calls")
        if conflict.substitute is not None:
            dst = box("target", y, f"{robot}.{conflict.substitute.name}")
            arrow(src, dst, "substitutableBy")
            arrow(robot_box, dst, "hasPrimitive")
    if gaps:
        box("gap", -1.0, "lacks: " + ", ".join(gaps))
    ax.set_xlim(-1.6, 12.4)
    ax.set_ylim(-1.6 if gaps else -0.8, rows - 0.2)
    ax.set_title(
        f"{skill_name}: {source} → {robot}  ({len(diag.conflicts)} determined conflicts, {len(diag.warnings)} undetermined warnings)"
    )
    ax.axis("off")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return out
