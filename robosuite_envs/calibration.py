"""What the shared controllers know about one embodiment: its calibration (data only).

Every quantity is read from the robot's and gripper's models as MuJoCo compiles them, or measured by
driving the embodiment in simulation once (:mod:`~lerobot_policy_recent.robosuite_envs.calibrate`):

- the arm: its joints and limits, its reach (summed link offsets) and where the table mount puts
  its base, from the compiled model (the same MJCF the ontology reads; a test checks they agree);
- the gripper: the grip site's orientation in the hand, the axis the finger pads close along and
  the point between them where a closed grasp holds (both in the grip-site frame), how far the
  open gripper reaches below the grip site, and how long it takes to close and to open;
- tracking: the worst steady-state error of the arm's servo over a few poses above the table, and
  from it the tolerance within which a stopped arm counts as arrived;
- reach at the table: how far from its base (on the table plane) the arm brings its grip site, pointing
  down, to a few centimetres above the table top. Its stretched length says nothing of this: a Panda
  that reaches 1.1 m in the air gets its hand low only about 0.8 m out.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass

CALIBRATION_VERSION = 9
REACHED_M = 0.01  # a probe the stopped grip site is within this of counts as reached (a sweep's margin)
TABLE_REACH_HEIGHT_M = 0.03  # grip site above the table top for the reach at the table: a sweep's or grasp's height


@dataclass(frozen=True)
class Calibration:
    """One embodiment, as the controllers need it. Lengths in metres, times in seconds, frames named."""

    embodiment: str
    robot: str
    gripper: str
    # the arm, from the compiled model
    arm_dof: int
    joint_limits: tuple[tuple[float, float], ...]  # radians (or metres for a slide joint), per arm joint
    reach_m: float  # link offsets summed from the first arm joint to the last (an upper bound)
    base_xyz: tuple[float, float, float]  # world position of the arm's base on our table
    # the gripper
    mechanism: str  # "fingers" or "suction"
    grip_site_in_hand: tuple[float, float, float, float]  # quaternion xyzw of the grip site in the hand body
    closing_axis: tuple[float, float, float] | None  # unit, grip-site frame: from one pad group to the other
    grasp_point: tuple[float, float, float]  # where closed pads (or the cup) hold, grip-site frame
    below_site_m: float  # how far the open gripper reaches below the grip site, pointing down
    # half the open gripper's extent along the grip site's x and y axes, over its parts that a box on the
    # table can meet (pointing down): what the motion planner sweeps past the perceived boxes
    hand_half_xy: tuple[float, float]
    close_time_s: float
    open_time_s: float
    opening_open: float  # the gripper's opening reading fully open (finger joint travel; a cup: 0, off)
    opening_closed: float  # … and fully closed with nothing between the fingers (a cup: 1, on)
    # a zero command leaves the fingers where they are (robosuite's grippers step their command at a fixed
    # rate); a gripper that reads zero as a position (half open, a cup off) does not
    zero_holds: bool
    # tracking (operational-space control at CONTROL_FREQ)
    tracking_error_m: float  # worst steady-state error over the calibration poses it reached
    settle_tol_m: float  # a stopped grip site within this of its goal has arrived
    unreached: tuple[tuple[float, float, float], ...] = ()  # calibration poses (world) it could not reach
    table_reach_m: float = float("inf")  # farthest grip site from the base (table plane) it servos to near the table
    # nearest the base (table plane) a probe walking in from the table's centre first stopped short, pointing
    # down, at every height walked (3 and 20 cm above the table): a long arm's elbow folds only so far (0: it
    # reached the table's near edge)
    inner_reach_m: float = 0.0
    # (height above the table top, distance from the base on the table plane) of the nearest probe a walk
    # out from the table reach first stopped short of, pointing down, at each height walked in the air
    # (inf: none)
    reach_by_height: tuple[tuple[float, float], ...] = ()
    table_top_z: float = float("-inf")  # world height of the table top it was measured at (what objects rest on)
    # how far the closed gripper (a fist) reaches below the grip site, pointing down: linkage fingers
    # swing lower as they close, parallel ones do not
    fist_below_site_m: float = 0.0
    measured_with: str = ""  # simulator versions
    seconds: float = 0.0  # how long the calibration took
    version: int = CALIBRATION_VERSION

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=2)

    @classmethod
    def from_json(cls, text: str) -> Calibration:
        data = json.loads(text)
        for key in ("joint_limits", "unreached", "reach_by_height"):
            data[key] = tuple(tuple(v) for v in data[key])
        for key in ("base_xyz", "grip_site_in_hand", "grasp_point", "hand_half_xy"):
            data[key] = tuple(data[key])
        if data["closing_axis"] is not None:
            data["closing_axis"] = tuple(data["closing_axis"])
        return cls(**data)

    def lines(self) -> list[str]:
        """Human-readable, one fact per line (``recent envs show-embodiment``)."""
        axis = "n/a (suction)" if self.closing_axis is None else _vec(self.closing_axis)
        limits = ", ".join("free" if lo == hi == 0 else f"[{lo:+.2f}, {hi:+.2f}]" for lo, hi in self.joint_limits)
        unreached = ", ".join(_vec(p) for p in self.unreached) or "none"
        return [
            f"embodiment        {self.embodiment}  (robosuite {self.robot} + {self.gripper})",
            f"arm               {self.arm_dof} joints, reach {self.reach_m:.3f} m, base at {_vec(self.base_xyz)}",
            f"joint limits      {limits}",
            f"gripper           {self.mechanism}; grip site in hand (xyzw) {_vec(self.grip_site_in_hand)}",
            f"closing axis      {axis} (grip-site frame)",
            f"grasp point       {_vec(self.grasp_point)} m from the grip site (grip-site frame)",
            f"below grip site   {self.below_site_m * 100:.1f} cm open, {self.fist_below_site_m * 100:.1f} cm closed "
            "(pointing down)",
            f"hand footprint    {2 * self.hand_half_xy[0] * 100:.1f} x {2 * self.hand_half_xy[1] * 100:.1f} cm "
            "(open, along the grip site's x and y)",
            f"close / open      {self.close_time_s:.2f} s / {self.open_time_s:.2f} s "
            f"(opening reads {self.opening_closed:.3f} closed, {self.opening_open:.3f} open{self._hold_line()})",
            f"tracking error    {self.tracking_error_m * 1000:.1f} mm steady-state (worst pose); "
            f"a stopped arm within {self.settle_tol_m * 1000:.1f} mm has arrived",
            f"unreached poses   {unreached}",
            f"reach at table    {self.table_reach_m:.3f} m from the base ({TABLE_REACH_HEIGHT_M * 100:.0f} cm above the "
            f"table top at z = {self.table_top_z:.3f} m, pointing down)",
            f"reach in the air  {self._in_the_air()}",
            f"dead zone         {self._dead_zone()}",
            f"measured with     {self.measured_with} in {self.seconds:.1f} s (calibration v{self.version})",
        ]

    def reach_limits(self) -> tuple[tuple[float, float], ...]:
        """(height above the table, distance from the base) beyond which the grip site, sent there pointing
        down, stops farther short than it settles: the probe it first stopped short of lay at least
        ``REACHED_M`` beyond what it reached, and a move may end within ``settle_tol_m`` of its goal."""
        return tuple((h, d - REACHED_M + self.settle_tol_m) for h, d in self.reach_by_height)

    def _in_the_air(self) -> str:
        if not self.reach_by_height:
            return "not measured"
        stops = ", ".join(
            f"{h * 100:.0f} cm up: {'beyond its stretch' if d == float('inf') else f'{d:.2f} m'}"
            for h, d in self.reach_by_height
        )
        return f"first stops short (pointing down) at {stops}"

    def _dead_zone(self) -> str:
        if not self.inner_reach_m:
            return "none: it reaches the table's near edge"
        return (
            f"within {self.inner_reach_m:.3f} m of the base (the grip site, pointing down, stops short 3 and 20 cm up)"
        )

    def _hold_line(self) -> str:
        """What the close / open line says of a zero command (a cup is not asked)."""
        if self.mechanism == "suction":
            return ""  # a cup's command is on or off: not asked
        return "; a zero command holds it" if self.zero_holds else "; a zero command does not hold it"


@dataclass(frozen=True)
class Nominal:
    """What a session without a measured calibration assumes (unit tests with made-up observations)."""

    settle_tol_m: float = 0.008
    close_time_s: float = 0.5
    open_time_s: float = 0.5
    opening_open: float | None = None  # unknown: an opening gripper is done once its fingers stop
    opening_closed: float | None = None
    zero_holds: bool = False  # unknown: a closing gripper keeps being told to close
    grasp_point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    hand_half_xy: tuple[float, float] | None = None  # unknown: the planner's nominal hand
    closing_axis: tuple[float, float, float] | None = None  # unknown: a grasp is not turned square to its object
    tracking_error_m: float = 0.0
    unreached: tuple = ()
    table_reach_m: float = float("inf")
    inner_reach_m: float = 0.0
    table_top_z: float = float("-inf")  # unknown: no floor under a fist
    fist_below_site_m: float = 0.0
    base_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)  # an API's base frame then sits at the world origin

    def reach_limits(self) -> tuple[tuple[float, float], ...]:
        return ()  # unknown: nothing is refused as out of reach in the air


def _vec(values) -> str:
    return "[" + ", ".join(f"{v:+.3f}" for v in values) + "]"
