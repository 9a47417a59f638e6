"""Measure an embodiment once in simulation, and cache the result (:class:`Calibration`).

:func:`calibration` returns the cached calibration of an embodiment, measuring it on first use (a
few seconds: the arm at an empty table, its gripper closed and opened, its grip site servoed to a
few poses) and storing it under the cache dir, keyed by the robot's and gripper's model files, the
simulator's versions and the procedure's code. ``recent envs show-embodiment NAME`` prints it.
"""

from __future__ import annotations

from lerobot_policy_recent.robosuite_envs import runtime  # noqa: F401  (headless GL before robosuite loads)

# isort: split
import hashlib
import os
import time
from pathlib import Path

import numpy as np

from lerobot_policy_recent.descriptions.embodiments import Embodiment, get_embodiment, resolve_model_file
from lerobot_policy_recent.robosuite_envs.calibration import (
    CALIBRATION_VERSION,
    REACHED_M,
    TABLE_REACH_HEIGHT_M,
    Calibration,
)
from lerobot_policy_recent.robosuite_envs.observation import ACTION_DIM
from lerobot_policy_recent.robosuite_envs.primitives import clearance, control
from lerobot_policy_recent.robosuite_envs.primitives.session import CONTROL_FREQ, RobotSession
from lerobot_policy_recent.robosuite_envs.table import TABLE_SIZE

POSE_SECONDS = 8.0  # longest the arm servos to one calibration pose; it stops earlier once it is still
GRIPPER_SECONDS = 10.0  # longest a gripper may take to close or open before calibration gives up on it
HOLD_SECONDS = 0.5  # how long a zero command is sent to a closed gripper to see whether it stays closed
HELD_SHARE = 0.1  # a closed gripper that moves less than this share of its stroke under a zero command holds
STILL = 1e-3  # opening change per control step below which the fingers have stopped
SETTLE_MARGIN = 1.2  # a stopped arm within this multiple of its steady-state error has arrived
UNREACHED_M = 0.05  # a calibration pose the stopped arm is this far off is out of its reach
# Calibration poses, (x, y, height above the table top) in metres: the table area the tasks use.
POSES = ((0.0, 0.0, 0.12), (-0.15, -0.25, 0.12), (0.15, -0.25, 0.12), (0.15, 0.22, 0.12), (-0.15, 0.22, 0.12))
LOW_POSE = (0.0, -0.1, 0.03)  # near the table: where grasps happen
REACH_STEP_M = 0.02  # how far out each probe of the reach at the table goes beyond the last
# heights above the table the inner reach is walked at (a grasp's, a carry's): the nearer is kept, so a
# target refused there is out of reach at both (an iiwa's hand reaches 3 cm nearer low than 20 cm up)
INNER_REACH_HEIGHTS_M = (TABLE_REACH_HEIGHT_M, 0.20)
INNER_STEP_M = 0.01  # how far in each probe of the inner reach goes beyond the last
# heights above the table the reach out is walked at, in the air (a carry's, an approach's, a lid's top):
# at the table the reach walk above already found its first stop, one step past table_reach_m
REACH_HEIGHTS_M = (0.13, 0.23, 0.33)


def calibration(name: str, *, refresh: bool = False) -> Calibration:
    """The calibration of embodiment ``name``: from the cache, or measured now and cached."""
    embodiment = get_embodiment(name)
    path = cache_path(embodiment)
    if path.exists() and not refresh:
        try:
            return Calibration.from_json(path.read_text())
        except (ValueError, TypeError, KeyError):
            pass  # written by another version: measure again
    measured = measure(name)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")  # workers calibrating at once each write whole, then rename
    tmp.write_text(measured.to_json())
    tmp.replace(path)
    return measured


def cache_path(embodiment: Embodiment) -> Path:
    from lerobot_policy_recent.recent_plugin.cache import cache_dir

    return cache_dir() / "calibration" / f"{embodiment.name}-{calibration_key(embodiment)}.json"


def calibration_key(embodiment: Embodiment) -> str:
    """Changes with the robot's or gripper's model files, the simulator, or the procedure (this module
    and the controllers it measures with)."""
    import mujoco
    import robosuite

    digest = hashlib.sha256()
    for part in (embodiment.robot, embodiment.gripper, robosuite.__version__, mujoco.__version__):
        digest.update(f"{part}\n".encode())
    digest.update(f"v{CALIBRATION_VERSION}\n".encode())
    for model in (embodiment.robot_mjcf, embodiment.gripper_mjcf):
        digest.update(resolve_model_file(model).read_bytes())
    # how it is measured: this module, the servo, and the planner (the hand height a footprint spans)
    for procedure in (Path(__file__), Path(control.__file__), Path(clearance.__file__)):
        digest.update(procedure.read_bytes())
    return digest.hexdigest()[:16]


# ------------------------------------------------------------------------------------ measuring
def measure(name: str) -> Calibration:
    """Build the embodiment at an empty table and measure it (a few seconds of simulation)."""
    import mujoco
    import robosuite

    from lerobot_policy_recent.robosuite_envs.tabletop import build_env
    from lerobot_policy_recent.robosuite_envs.tasks import TaskSpec

    started = time.perf_counter()
    embodiment = get_embodiment(name)
    env = build_env(TaskSpec(f"calibration/{name}", "calibrate", (), ()), embodiment, seed=0)
    try:
        probe = _Probe(env, reset=True)
        arm = probe.arm_facts()
        gripper = probe.gripper_facts()
        tracking = probe.tracking()
        # each walk from the arm's home posture: after the tracking poses a 7-joint arm can sit folded where
        # the first probe stops short (Kinova3 read 0 m), and a reset may build a new sim
        table_reach = _Probe(env, reset=True).table_reach(arm["reach_m"])
        inner_reach = min(_Probe(env, reset=True).inner_reach(height) for height in INNER_REACH_HEIGHTS_M)
        reach_by_height = tuple(
            (height, _Probe(env, reset=True).first_stop(height, table_reach, arm["reach_m"]))
            for height in REACH_HEIGHTS_M
        )
    finally:
        env.close()
    return Calibration(
        embodiment=name,
        robot=embodiment.robot,
        gripper=embodiment.gripper,
        **arm,
        **gripper,
        **tracking,
        table_reach_m=table_reach,
        inner_reach_m=inner_reach,
        reach_by_height=reach_by_height,
        table_top_z=round(float(env.table_top_z), 4),
        measured_with=f"robosuite {robosuite.__version__}, mujoco {mujoco.__version__}",
        seconds=round(time.perf_counter() - started, 2),
    )


class _Probe:
    """Drives one calibration env; each method measures one group of facts."""

    def __init__(self, env, *, reset: bool = False):
        if reset:
            env.reset()
        self.env = env
        self.robot = env.robots[0]
        self.arm = self.robot.arms[0]
        self.gripper = self.robot.gripper[self.arm]
        self.model, self.data = env.sim.model, env.sim.data
        self.site = self.robot.eef_site_id[self.arm]
        self._session = RobotSession("calibration", env.sensed())  # the reach walks': holds the pose it starts in

    # ---------------------------------------------------------------- the arm
    def arm_facts(self) -> dict:
        joints = [self.model.joint_name2id(j) for j in self.robot.robot_joints]
        limits = tuple((round(float(lo), 4), round(float(hi), 4)) for lo, hi in self.model.jnt_range[joints])
        bodies = [int(self.model.jnt_bodyid[j]) for j in joints]
        # stretched length: the link offsets from the first joint's body down to the last joint's
        reach = float(sum(np.linalg.norm(self.model.body_pos[b]) for b in self._chain_to(bodies[0], bodies[-1])))
        base = self.model.body_name2id(self.robot.robot_model.root_body)
        return {
            "arm_dof": len(joints),
            "joint_limits": limits,
            "reach_m": round(reach, 3),
            "base_xyz": tuple(round(float(v), 4) for v in self.data.xpos[base]),
        }

    def _chain_to(self, ancestor: int, body: int) -> list[int]:
        """Bodies from below ``ancestor`` down to ``body`` (inclusive), in order."""
        chain = []
        while body not in (ancestor, 0):
            chain.append(body)
            body = int(self.model.body_parentid[body])
        return chain[::-1]

    # ---------------------------------------------------------------- the gripper
    def gripper_facts(self) -> dict:
        hand = self.model.body_name2id(self.gripper.root_body)
        site_in_hand = _rel_quat(self.data.xmat[hand], self.data.site_xmat[self.site])
        suction = "cup" in self.gripper.important_geoms
        open_time = self._actuate(-1.0)  # start open
        below = self._extent_below_site()
        hand = self._hand_half_xy()
        opened = self.env.gripper_opening()
        if suction:
            cup = self.model.geom_name2id(self.gripper.important_geoms["cup"][0])
            close_time = self._actuate(1.0)
            closed = self.env.gripper_opening()
            fist = self._extent_below_site()
            return {
                "mechanism": "suction",
                "grip_site_in_hand": site_in_hand,
                "closing_axis": None,
                "grasp_point": self._in_site(self.data.geom_xpos[cup]),
                "below_site_m": below,
                "fist_below_site_m": fist,
                "hand_half_xy": hand,
                "close_time_s": close_time,
                "open_time_s": max(open_time, self._actuate(-1.0)),
                "opening_open": round(opened, 4),
                "opening_closed": round(closed, 4),
                "zero_holds": False,  # a cup's command is on or off, not a finger travel to hold
            }
        left, right = (
            [self.model.geom_name2id(g) for g in self.gripper.important_geoms[side]]
            for side in ("left_fingerpad", "right_fingerpad")
        )
        axis = np.mean(self.data.geom_xpos[left], axis=0) - np.mean(self.data.geom_xpos[right], axis=0)
        axis = self._site_rot().T @ axis
        close_time = self._actuate(1.0)
        closed = self.env.gripper_opening()
        fist = self._extent_below_site()
        grasp_point = self._in_site(np.mean(self.data.geom_xpos[left + right], axis=0))
        zero_holds = self._holds_at_zero(closed, stroke=abs(opened - closed))
        open_time = max(open_time, self._actuate(-1.0))
        return {
            "mechanism": "fingers",
            "grip_site_in_hand": site_in_hand,
            "closing_axis": tuple(round(float(v), 3) for v in axis / max(np.linalg.norm(axis), 1e-9)),
            "grasp_point": grasp_point,
            "below_site_m": below,
            "fist_below_site_m": fist,
            "hand_half_xy": hand,
            "close_time_s": close_time,
            "open_time_s": open_time,
            "opening_open": round(opened, 4),
            "opening_closed": round(closed, 4),
            "zero_holds": zero_holds,
        }

    def _holds_at_zero(self, closed: float, stroke: float) -> bool:
        """Send the closed gripper a zero command for a while: does it stay closed?"""
        for _ in range(int(HOLD_SECONDS * CONTROL_FREQ)):
            self.env.step(np.zeros(ACTION_DIM))
        return bool(abs(self.env.gripper_opening() - closed) < HELD_SHARE * stroke)

    def _actuate(self, command: float) -> float:
        """Command the gripper and hold the arm; seconds until the fingers stop moving."""
        previous, still = self.env.gripper_opening(), 0
        for step in range(int(GRIPPER_SECONDS * CONTROL_FREQ)):
            self.env.step(np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, command]))
            opening = self.env.gripper_opening()
            still = still + 1 if abs(opening - previous) < STILL else 0
            previous = opening
            if still >= 3:
                return round((step + 1 - still) / CONTROL_FREQ, 2)
        return GRIPPER_SECONDS

    def _extent_below_site(self) -> float:
        """How far the gripper's collision geometry reaches below the grip site (world z, as it points now)."""
        lowest = float(self._contact_corners()[:, 2].min())
        return round(max(0.0, float(self.data.site_xpos[self.site][2]) - lowest), 4)

    def _hand_half_xy(self) -> tuple[float, float]:
        """Half the open gripper's extent along the grip site's x and y, over the corners of its collision
        boxes that lie lower than ``clearance.HAND_HEIGHT`` above the grip site (pointing down, as now):
        what can meet a box on the table as the hand passes it."""
        corners = self._contact_corners()
        low = corners[corners[:, 2] < self.data.site_xpos[self.site][2] + clearance.HAND_HEIGHT]
        local = (low - self.data.site_xpos[self.site]) @ self._site_rot()
        return tuple(round(float(v), 4) for v in np.abs(local[:, :2]).max(axis=0))

    def _contact_corners(self) -> np.ndarray:
        """World corners of the gripper's collision geoms' bounding boxes, as the gripper is posed now."""
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        corners = []
        for name in self.gripper.contact_geoms:
            geom = self.model.geom_name2id(name)
            centre, half = self.model.geom_aabb[geom][:3], self.model.geom_aabb[geom][3:]
            corners.append(
                self.data.geom_xpos[geom] + (signs * half + centre) @ self.data.geom_xmat[geom].reshape(3, 3).T
            )
        return np.concatenate(corners)

    def _site_rot(self) -> np.ndarray:
        return self.data.site_xmat[self.site].reshape(3, 3)

    def _in_site(self, point: np.ndarray) -> tuple[float, float, float]:
        local = self._site_rot().T @ (np.asarray(point) - self.data.site_xpos[self.site])
        return tuple(round(float(v), 4) for v in local)

    # ---------------------------------------------------------------- tracking
    def tracking(self) -> dict:
        session = RobotSession("calibration", self.env.sensed())
        table = self.env.table_top_z
        errors, unreached = [], []
        for x, y, height in (*POSES, LOW_POSE):
            goal = np.array([x, y, table + height])
            error = self._servo(session, goal)
            if error > UNREACHED_M:
                unreached.append(tuple(round(float(v), 3) for v in goal))
            else:
                errors.append(error)
        worst = max(errors, default=0.0)
        return {
            "tracking_error_m": round(worst, 4),
            "settle_tol_m": round(max(control.POS_TOL, SETTLE_MARGIN * worst), 4),
            "unreached": tuple(unreached),
        }

    # ---------------------------------------------------------------- reach at the table
    def table_reach(self, stretched: float) -> float:
        """How far from the base, on the table plane, the grip site gets to TABLE_REACH_HEIGHT_M above the
        table: walked out from the table's centre, away from the base, until a probe stops short."""
        base, out = self._table_line()
        reached, distance = 0.0, float(np.linalg.norm(base))
        while distance <= stretched:
            if not self._reaches(base + out * distance, TABLE_REACH_HEIGHT_M):
                break
            reached, distance = distance, distance + REACH_STEP_M
        return round(reached, 3)

    def first_stop(self, height: float, start: float, stretched: float) -> float:
        """How far from the base, on the table plane, the first probe ``height`` above the table that the
        grip site stops short of lies: walked out from ``start`` (the reach at the table) in
        REACH_STEP_M, or in from it where it is not reached there (inf: reached out to the stretch)."""
        base, out = self._table_line()
        distance = start
        if not self._reaches(base + out * distance, height):
            while distance - REACH_STEP_M > 0.0 and not self._reaches(base + out * (distance - REACH_STEP_M), height):
                distance -= REACH_STEP_M
            return round(distance, 3)
        while distance + REACH_STEP_M <= stretched:
            distance += REACH_STEP_M
            if not self._reaches(base + out * distance, height):
                return round(distance, 3)
        return float("inf")

    def inner_reach(self, height: float) -> float:
        """How near the base, on the table plane, the grip site first stops short of a probe ``height``
        above the table: walked in from the table's centre towards the base, down to the table's near
        edge (0.0 where every probe was reached). A target nearer than that is out of reach pointing
        down; one between it and the last probe reached is not known to be."""
        base, out = self._table_line()
        distance, near_edge = float(np.linalg.norm(base)), float(np.linalg.norm(base)) - TABLE_SIZE[0] / 2
        while distance >= near_edge:
            if not self._reaches(base + out * distance, height):
                return round(distance, 3)
            distance -= INNER_STEP_M
        return 0.0

    def _table_line(self) -> tuple[np.ndarray, np.ndarray]:
        """The base on the table plane, and the unit direction from it through the table's centre."""
        base = np.asarray(self.data.xpos[self.model.body_name2id(self.robot.robot_model.root_body)][:2], dtype=float)
        out = -base / np.linalg.norm(base) if np.linalg.norm(base) > 1e-6 else np.array([1.0, 0.0])
        return base, out

    def _reaches(self, xy: np.ndarray, height: float) -> bool:
        """The grip site, servoed pointing down to ``xy`` at ``height`` above the table, stops on it."""
        goal = np.array([*xy, self.env.table_top_z + height])
        return self._servo(self._session, goal) <= REACHED_M

    def _servo(self, session: RobotSession, goal: np.ndarray) -> float:
        """Servo the grip site to ``goal`` until it stops (what is left is the steady-state error); how far off."""
        trail = []
        for _ in range(int(POSE_SECONDS * CONTROL_FREQ)):
            self.env.step(control.servo_action(session, goal))
            session.update(self.env.sensed())
            trail.append(session.obs.eef_pos.copy())
            if (
                len(trail) > control.STALL_STEPS
                and np.linalg.norm(trail[-1] - trail[-1 - control.STALL_STEPS]) < control.SETTLED
            ):
                break
        return float(np.linalg.norm(goal - session.obs.eef_pos))


def _rel_quat(parent_mat: np.ndarray, child_mat: np.ndarray) -> tuple[float, float, float, float]:
    from robosuite.utils.transform_utils import mat2quat

    relative = np.asarray(parent_mat).reshape(3, 3).T @ np.asarray(child_mat).reshape(3, 3)
    return tuple(round(float(v), 4) for v in mat2quat(relative))
