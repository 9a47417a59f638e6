"""What a Rerun step costs the robot, by how often the sink sends and flushes: why the bound is in time.

    .venv/bin/python -m benchmarks.rerun_flush_bench [--steps 600] [--gap-ms 4]

The sink is fed ``--steps`` steps spaced ``--gap-ms`` apart (a simulated step's worth of time) and
timed without the gaps: buffered (a send every 64 steps), with the 0.25 s time bound, and sending
and flushing every step (what "a kill loses at most the current step" would take).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from lerobot_policy_recent.logs import rerun_sink
from lerobot_policy_recent.logs.events import EpisodeStarted, Stamped, Step
from lerobot_policy_recent.robosuite_envs.observation import AGENT_POS_DIM, ENV_STATE_DIM, SLOT_DIM

SETTINGS = {"buffered (64 steps)": 1e9, "time bound 0.25 s (the sink's)": 0.25, "every step": 0.0}


def per_step_ms(flush_s: float, steps: int, gap_s: float) -> float:
    rerun_sink.FLUSH_S = flush_s
    sink = rerun_sink.RerunSink(lambda _i: Path(tempfile.mkdtemp()) / "e.rrd")
    started = EpisodeStarted("kinematic/press_button", "UR5e", 0, object_names=["button", "cube"])
    sink.begin(Stamped(started, 0, 0, time.time_ns()))
    env_state = np.zeros(ENV_STATE_DIM)
    env_state[7] = env_state[SLOT_DIM + 7] = 1.0  # both objects present
    spent = 0.0
    for i in range(steps):
        step = Step(0, i, i / 20, time.time_ns(), np.zeros(AGENT_POS_DIM), env_state, np.zeros(7))
        began = time.perf_counter()
        sink.step(step)
        spent += time.perf_counter() - began
        time.sleep(gap_s)
    sink.close()
    return 1000 * spent / steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=600)
    parser.add_argument("--gap-ms", type=float, default=4.0)
    args = parser.parse_args()
    print("| Rerun sink | ms per step |\n|---|---:|")
    for name, flush_s in SETTINGS.items():
        print(f"| {name} | {per_step_ms(flush_s, args.steps, args.gap_ms / 1000):.3f} |")


if __name__ == "__main__":
    main()
