"""Every bundled arm: its calibration, and the canonical set against the Panda (BENCHMARKS.md "Arms").

    .venv/bin/python -m benchmarks.arms_bench [--out DIR] [--refresh] [--robots A,B] [-- CHECK OPTIONS]

Prints one calibration table (``--refresh`` measures every embodiment again instead of reading the
cache), then runs ``recent envs check`` on every bundled embodiment but the Panda, which is the
reference, and prints its table. Options after ``--`` go to the check as they are
(``-- --infiller.type llamacpp``, ``-- --workers 2``; the check's default backend is ``rule``). The
check is resumable: run the same command again to finish an interrupted one.
"""

from __future__ import annotations

import argparse
import sys

from lerobot_policy_recent.descriptions.embodiments import EMBODIMENTS, SOURCE_EMBODIMENT
from lerobot_policy_recent.robosuite_envs.calibrate import calibration
from lerobot_policy_recent.robosuite_envs.calibration import Calibration

HEADER = (
    "| embodiment | robot + gripper | DoF | reach (m) | close / open (s) | grasp point off site (mm) "
    "| tracking error (mm) | arrived within (mm) | unreached poses | measured in (s) |\n"
    "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
)


def calibration_row(measured: Calibration) -> str:
    offset_mm = 1000 * sum(v * v for v in measured.grasp_point[:2]) ** 0.5  # across the tool axis
    return (
        f"| {measured.embodiment} | {measured.robot} + {measured.gripper} | {measured.arm_dof} "
        f"| {measured.reach_m:.3f} | {measured.close_time_s:.2f} / {measured.open_time_s:.2f} | {offset_mm:.1f} "
        f"| {measured.tracking_error_m * 1000:.1f} | {measured.settle_tol_m * 1000:.1f} "
        f"| {len(measured.unreached)} | {measured.seconds:.1f} |"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=None, help="the check's run directory (default: the check's own; resumable)")
    parser.add_argument("--refresh", action="store_true", help="measure every calibration again")
    parser.add_argument("--robots", default=None, help="comma list (default: every bundled embodiment)")
    parser.add_argument("check_options", nargs=argparse.REMAINDER, help="after --: options of `recent envs check`")
    args = parser.parse_args()
    robots = args.robots.split(",") if args.robots else [n for n in EMBODIMENTS if n != SOURCE_EMBODIMENT]

    print(HEADER)
    for name in (SOURCE_EMBODIMENT, *robots):
        print(calibration_row(calibration(name, refresh=args.refresh)), flush=True)
    print()

    from lerobot_policy_recent.scripts.cli import main as recent

    extra = [a for a in args.check_options if a != "--"]
    out = ["--out", args.out] if args.out else []
    return recent(["envs", "check", ",".join(robots), *out, *extra])


if __name__ == "__main__":
    sys.exit(main())
