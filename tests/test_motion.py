"""The shared controllers' motion: paths over perceived boxes, descents that end on what they meet,
and positions read from a track of the perception rather than from one noisy frame."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator

import numpy as np
import pytest

from lerobot_policy_recent.robosuite_envs.gym_env import RecentEnv
from lerobot_policy_recent.robosuite_envs.observation import ObjectState, Observation
from lerobot_policy_recent.robosuite_envs.primitives import clearance, control
from lerobot_policy_recent.robosuite_envs.primitives.session import PrimitiveFailure, RobotSession, TaskContext
from lerobot_policy_recent.robosuite_envs.table import TABLE_Z

SLAB = clearance.Box("slab", np.array([0.0, 0.0, 0.83]), np.array([0.05, 0.05, 0.015]))  # top at 0.845


def test_a_straight_line_through_a_box_goes_up_across_and_down():
    path = clearance.path_over([-0.2, 0.0, 0.85], [0.2, 0.0, 0.85], [SLAB], clearance.Sweep())
    assert len(path) == 3 and np.allclose(path[-1], [0.2, 0.0, 0.85])
    rise, across = path[0], path[1]
    assert np.allclose(rise[:2], [-0.2, 0.0]) and np.allclose(across[:2], [0.2, 0.0])
    fingertips = rise[2] - clearance.FINGER_DEPTH
    assert fingertips >= SLAB.top + clearance.CLEAR_MARGIN - 1e-9  # the hand's lowest point clears the top


def test_a_clear_line_the_goals_own_box_and_what_the_hand_drags_are_no_obstacles():
    sweep = clearance.Sweep()
    assert len(clearance.path_over([-0.2, 0.0, 0.95], [0.2, 0.0, 0.95], [SLAB], sweep)) == 1  # high above it
    assert len(clearance.path_over([-0.2, 0.0, 0.95], [0.0, 0.0, 0.84], [SLAB], sweep)) == 1  # a descent into it
    assert len(clearance.path_over([-0.06, 0.0, 0.84], [0.2, 0.0, 0.84], [SLAB], sweep)) == 1  # under the hand already
    cup = clearance.Sweep.of(_carrying(np.array([-0.09, 0.0, 0.84]), 0.0, holding=False), (0.035, 0.035))
    push = clearance.path_over([-0.09, 0.0, 0.84], [0.2, 0.0, 0.84], [SLAB], cup)  # a cup 5 mm behind it: a push
    assert len(push) == 1
    assert len(clearance.path_over([-0.12, 0.0, 0.84], [0.2, 0.0, 0.84], [SLAB], cup)) == 3  # 3.5 cm short: in the way


def test_a_descent_beside_a_box_keeps_its_line_going_over_would_not_avoid_it():
    path = clearance.path_over([-0.2, 0.0, 0.95], [0.07, 0.0, 0.83], [SLAB], clearance.Sweep())
    assert len(path) == 1


def test_a_hand_is_swept_as_wide_as_its_calibrated_footprint_turned_as_the_hand_is():
    """A block 6 cm beside the line is in the nominal 7 cm hand's way, not in a 3.5 cm cup's; a jaw
    10 cm long along its closing axis meets it only while that axis lies across the line."""
    beside = clearance.Box("block", np.array([0.0, 0.06, 0.82]), np.array([0.02, 0.02, 0.02]))
    line = np.array([-0.2, 0.0, 0.83]), np.array([0.2, 0.0, 0.83])
    home, quarter = np.array([0.0, 0.0, 0.0, 1.0]), np.array([0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)])

    def sweep(half_xy, quat) -> clearance.Sweep:
        return clearance.Sweep.of(_carrying(line[0], 0.0, quat=quat, holding=False), half_xy)

    assert sweep(None, home).blocks(beside, *line)  # nominal
    assert not sweep((0.035, 0.035), home).blocks(beside, *line)  # a cup
    assert sweep((0.03, 0.1), home).blocks(beside, *line)  # a jaw closing across the line
    assert not sweep((0.03, 0.1), quarter).blocks(beside, *line)  # turned a quarter: along it
    assert clearance.across_table((0.03, 0.1), quarter) == pytest.approx((0.1, 0.03))


def test_a_held_load_is_swept_with_the_hand():
    """A block hanging 4 cm below the grip site clears the slab only where the block's bottom does."""
    eef = np.array([-0.2, 0.0, 0.9])
    sweep = clearance.Sweep.of(_carrying(eef, hanging=0.04))
    assert len(sweep.parts) == 2
    path = clearance.path_over(eef, [0.2, 0.0, 0.9], [SLAB], sweep)  # the bare hand would clear: 0.88 > 0.845
    bottom = path[0][2] - 0.04 - 0.025
    assert len(path) == 3 and bottom >= SLAB.top + clearance.CLEAR_MARGIN - 1e-9


def test_a_load_carried_a_hair_above_a_block_goes_over_it_but_slides_over_a_marking():
    """A block carried at its neighbours' height clears one by 3 mm on paper: within perception's
    noise it drags it along, so the path rises; over a 1 mm marking the same line is kept."""
    eef = np.array([-0.2, 0.0, 0.9])
    block_top = eef[2] - 0.025 - 0.025 - 0.003  # the load (5 cm, centred 2.5 cm down) passes 3 mm above it
    sweep = clearance.Sweep.of(_carrying(eef, hanging=0.025))
    block = clearance.Box("block", np.array([0.0, 0.0, block_top - 0.02]), np.array([0.02, 0.02, 0.02]))
    path = clearance.path_over(eef, [0.2, 0.0, 0.9], [block], sweep)
    assert len(path) == 3 and path[0][2] - 0.05 >= block.top + clearance.CLEAR_MARGIN - 1e-9
    marking = clearance.Box("row", np.array([0.0, 0.0, block_top - 0.0005]), np.array([0.1, 0.1, 0.0005]))
    assert len(clearance.path_over(eef, [0.2, 0.0, 0.9], [marking], sweep)) == 1


def _carrying(eef: np.ndarray, hanging: float, *, quat=(0.0, 0.0, 0.0, 1.0), holding: bool = True) -> Observation:
    """The hand at ``eef`` (turned as ``quat``, xyzw) holding a 5 cm block whose centre hangs
    ``hanging`` below the grip site; with ``holding`` False, the hand is empty and the block far off."""
    load = eef - [0.0, 0.0, hanging] if holding else np.array([0.3, 0.3, 0.82])
    return Observation(
        eef_pos=eef,
        eef_quat=np.asarray(quat, dtype=float),
        gripper_opening=0.0,
        objects={"load": ObjectState(load, np.zeros(4), np.array([0.05, 0.05, 0.05]))},
        object_detected=holding,
    )


def test_a_load_dragged_along_the_table_is_pushed_harder_where_it_stalls_but_never_pressed_down():
    """tool_panel s3 on Sawyer: the rake's crossbar dragged the cube towards the zone and the arm
    stopped 1.3 cm short, held by the friction of what it drags (a load resting on the table: no
    breakaway before). Where what is left of the move lies along the table, the setpoint's reach
    grows, and near the goal it scales the error, so the arm pushes harder than the error alone
    commands; a move that would press the load down into what it rests on keeps the 2 cm, and so
    does a straight line's slide (a push, whose fist on the cube rode over it pushed harder)."""
    eef = np.array([-0.09, 0.16, 0.842])
    session = RobotSession("Sawyer", _carrying(eef, hanging=0.01))  # the block's underside on the table top
    assert session.obs.held() == "load" and not control.load_hangs(session)
    along = eef + [-0.012, 0.0, -0.003]
    assert control._slides(session, along) and not control._slides(session, eef + [-0.005, 0.0, -0.02])
    grown = control._breakaway(session, control.MAX_STEP, drag=True)
    assert grown > control.MAX_STEP == control._breakaway(session, control.MAX_STEP, drag=False)
    pushed, plain = control.servo_action(session, along, grown), control.servo_action(session, along)
    assert abs(pushed[0]) > abs(plain[0]) == pytest.approx(0.012 / control.POS_SCALE)


def test_a_push_start_whose_hand_came_down_on_an_edge_moves_back_by_half_the_hands_length_along_the_push():
    """stack_zone_bin_lift s3 on Sawyer: the sweep's start was written for the carried cube's face, and
    the Sawyer's fingers, closed along the push, lead it: the hand came down on the slab's edge,
    held up 1.1 cm short, twice. Blocked there, the push comes down again farther back, by half the
    hand's calibrated footprint along the push as the hand is turned now (10 cm along its closing axis)."""
    from lerobot_policy_recent.robosuite_envs.calibration import Nominal

    start, goal = np.array([-0.046, -0.382, 0.83]), np.array([-0.046, -0.182, 0.83])
    along_y = np.array([0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)])  # the grip site's x along the world's y
    session = RobotSession("Sawyer", _carrying(start, 0.0, quat=along_y), Nominal(hand_half_xy=(0.05, 0.033)))
    assert control._behind(session, start, goal) == pytest.approx([-0.046, -0.407, 0.83])
    across = RobotSession("Sawyer", _carrying(start, 0.0), Nominal(hand_half_xy=(0.05, 0.033)))
    assert control._behind(across, start, goal) == pytest.approx([-0.046, -0.3985, 0.83])


def _observation(positions: dict[str, list[float]]) -> Observation:
    return Observation(
        eef_pos=np.zeros(3),
        eef_quat=np.array([0.0, 0.0, 0.0, 1.0]),
        gripper_opening=0.0,
        objects={
            n: ObjectState(np.asarray(p, dtype=float), np.zeros(4), np.full(3, 0.04)) for n, p in positions.items()
        },
    )


def test_a_position_read_is_the_tracks_estimate_not_one_noisy_frame():
    rng = np.random.default_rng(0)
    truth = np.array([0.1, -0.2, 0.82])
    frames = [truth + rng.normal(0.0, 0.004, 3) for _ in range(10)]
    session = RobotSession("Panda", _observation({"cube": frames[0]}))
    for frame in frames[1:]:
        session.update(_observation({"cube": frame}))
    read = np.asarray(TaskContext(session).get_object_position("cube"))
    assert np.linalg.norm(read - truth) < np.linalg.norm(frames[-1] - truth)
    assert np.linalg.norm(read - truth) < 0.004


def test_an_object_that_moved_is_read_where_it_is_now():
    session = RobotSession("Panda", _observation({"cube": [0.0, 0.0, 0.82]}))
    for _ in range(5):
        session.update(_observation({"cube": [0.0, 0.0, 0.82]}))
    session.update(_observation({"cube": [0.1, 0.0, 0.82]}))  # pushed 10 cm
    assert TaskContext(session).get_object_position("cube") == pytest.approx([0.1, 0.0, 0.82])


def _lowered(rates: list[float], landed_rate: float) -> int:
    """Steps :func:`control.lower_until_resting` takes, the grip site coming down by ``rates[i]`` metres
    at step i (a cup lowering a load, its goal far below)."""
    eef = np.array([0.0, 0.0, 1.0])
    session = RobotSession("Suction", _carrying(eef, 0.04))
    taken = 0
    try:
        for _action in control.lower_until_resting(session, eef - [0.0, 0.0, 0.5], landed_rate=landed_rate):
            eef = eef - [0.0, 0.0, rates[min(taken, len(rates) - 1)]]
            session.update(_carrying(eef, 0.04))
            taken += 1
    except PrimitiveFailure as failure:  # pressed on for as long as it may ("nothing held it up")
        assert failure.kind == "timeout"
    return taken


def test_a_cup_lets_go_once_what_it_presses_its_load_onto_only_yields():
    """Lowering at 2.5 mm a step, the load lands on a stack that then gives 0.6 mm a step: pressing
    on until it stopped tipped the middle block (line_up_then_stack, seed 7). The cup's set-down ends
    within a stall window of the landing; without ``landed_rate`` the lowering presses on."""
    landing = [0.0025] * 30 + [0.0006] * 200
    assert _lowered(landing, control.LANDED_RATE) <= 30 + control.STALL_STEPS + 1
    assert _lowered(landing, 0.0) >= 100
    steady = [0.0025] * 230  # a slow arm lowering at its own steady pace is not landing
    assert _lowered(steady, control.LANDED_RATE) >= 100


class _Arm:
    """A Panda in a suite scene, driven by the shared controllers alone."""

    def __init__(self, task: str, robot: str = "Panda"):
        self.env = RecentEnv(task=task, robot=robot, render_mode="none")
        self.names = self.env.spec_task.object_names()
        raw, _ = self.env.reset(seed=0)
        self.session = RobotSession(robot, self._decode(raw))

    def _decode(self, raw) -> Observation:
        return Observation.decode(raw["agent_pos"], raw["environment_state"], self.names)

    def run(self, steps: Iterator[np.ndarray]) -> None:
        for action in steps:
            raw, *_ = self.env.step(action)
            self.session.update(self._decode(raw))

    def position(self, name: str) -> np.ndarray:
        return self.session.obs.objects[name].pos.copy()


@pytest.fixture
def arm():
    arm = _Arm("kinematic/cube_in_bin")
    yield arm
    arm.env.close()


def test_a_move_whose_line_runs_through_a_perceived_block_goes_over_it(arm):
    """The cube (4.5 cm) stands between two points 3.8 cm above the table: planned, the closed hand
    passes over it and arrives; sent along the straight line, it runs into the cube."""
    block = arm.position("cube")
    arm.run(control.actuate_gripper(arm.session, 1.0))
    start, goal = block + [-0.15, 0.0, 0.015], block + [0.15, 0.0, 0.015]
    arm.run(control.move_to(arm.session, start, timeout_s=6.0))
    arm.run(control.move_to(arm.session, goal, timeout_s=6.0))
    assert np.linalg.norm(arm.session.obs.eef_pos - goal) < control.POS_TOL
    assert np.linalg.norm(arm.position("cube") - block) < 0.005  # untouched

    arm.run(control.move_to(arm.session, start, timeout_s=6.0))
    moved_or_blocked = False
    try:
        arm.run(control.move_to(arm.session, goal, timeout_s=6.0, plan=False))
    except PrimitiveFailure:
        moved_or_blocked = True
    assert moved_or_blocked or np.linalg.norm(arm.position("cube") - block) > 0.02


def test_a_planned_move_set_down_behind_a_block_pushes_it_along_its_line():
    """A sweep's fist, set down 6 cm behind a block, is sent past it on a slant (the lane of a pen's
    mouth). The planner passes through what the hand lies against, and the move keeps to the line:
    the block ends on it. Each axis closing its own error, the UR5e's hand reached the lane first,
    sideswiped the block, and it ended 3.6 cm off the line."""
    from lerobot_policy_recent.robosuite_envs.calibrate import calibration

    arm = _Arm("kinematic/drag_cube", "UR5e")
    arm.session = RobotSession("UR5e", arm.session.obs, calibration("UR5e"))
    try:
        cube = arm.position("cube")
        start, goal = cube + [-0.06, -0.01, -0.005], cube + [0.14, 0.03, -0.005]
        seen = clearance.boxes(arm.session.obs)
        arm.run(control.actuate_gripper(arm.session, 1.0))
        arm.run(control.move_to(arm.session, start + [0.0, 0.0, 0.1], timeout_s=6.0, settle=True))
        arm.run(control.move_to(arm.session, start, timeout_s=6.0, settle=True))
        sweep = clearance.Sweep.of(arm.session.obs, arm.session.calibration.hand_half_xy)
        assert [box.name for box in clearance.pushed(arm.session.obs.eef_pos, goal, seen, sweep)] == ["cube"]
        arm.run(control.move_to(arm.session, goal, timeout_s=6.0, settle=True))
        moved = arm.position("cube") - cube
        assert moved[0] > 0.12  # pushed along, not passed over
        assert abs(moved[1] - 0.03) < 0.015, moved  # on the line's lane
    finally:
        arm.env.close()


def test_an_arms_move_that_swings_a_lid_by_its_knob_arrives_where_the_hinge_holds_it():
    """The Franka Hand's open_hinged_box on a UR5e: its 2F-85 holds the knob farther out than the
    source's fingers, so the knob's arc is a wider one and the hinge stops each move 1-1.5 cm off the
    goal, in contact (held up by contact, 0 of 4 episodes). A move that drives a mechanism arrives
    within DRAG_TOL; the lid swings past upright."""
    from lerobot_policy_recent.robosuite_envs.calibrate import calibration

    arm = _Arm("end_effector/open_box", "UR5e")
    arm.session = RobotSession("UR5e", arm.session.obs, calibration("UR5e"))
    try:
        base = arm.position("box")
        hinge = base + [0.07, 0.0, 0.08]
        knob = hinge + [-0.125, 0.0, 0.022]
        arm.run(control.actuate_gripper(arm.session, -1.0))
        arm.run(control.move_to(arm.session, knob + [0.0, 0.0, 0.08], timeout_s=3.0, settle=True))
        arm.run(control.move_to(arm.session, knob, timeout_s=3.0, settle=True))
        arm.run(control.actuate_gripper(arm.session, 1.0))
        for dx, dz in [[-0.110, 0.063], [-0.082, 0.097], [-0.043, 0.119], [0.0, 0.127], [0.044, 0.119]]:
            arm.run(control.move_to(arm.session, hinge + [dx, 0.0, dz], timeout_s=3.0, settle=True))
        assert arm.session.obs.objects["box"].state > np.pi / 2  # past upright: it falls open
    finally:
        arm.env.close()


def test_a_cup_comes_down_square_to_the_face_it_seals_on():
    """The Panda holds its cup's axis 7 degrees off the vertical: coming down so, its edge met the
    5 cm block on two contact points and it never sealed (clear_into_bin, the cup, every episode).
    It descends along the face's normal and seals; its tilt is given back afterwards."""
    from lerobot_policy_recent.robosuite_envs.calibrate import calibration

    arm = _Arm("kinematic/clear_counter", "Suction")
    arm.session = RobotSession("Suction", arm.session.obs, calibration("Suction"))
    try:
        started = arm.session.hold_quat.copy()
        arm.run(control.suction_grasp_at(arm.session, arm.position("block")))
        assert arm.session.obs.held() == "block"
        assert np.allclose(arm.session.hold_quat, started)
    finally:
        arm.env.close()


def test_a_stall_in_contact_is_a_drag_only_where_a_mechanism_moved():
    """Pressed on a cube that does not give, a stop short is a blocked waypoint, not an arrival."""
    still = _observation({"box": [0.05, 0.16, 0.8]})
    still.objects["box"] = dataclasses.replace(still.objects["box"], state=0.40)
    session = RobotSession("UR5e", dataclasses.replace(still, eef_contact=True))
    assert control.drives_mechanism(session, {"box": 0.30})  # the lid swung 0.1 rad under the hand
    assert not control.drives_mechanism(session, {"box": 0.395})  # it did not
    session.update(still)  # nothing touched: whatever moved, the hand did not drive it
    assert not control.drives_mechanism(session, {"box": 0.30})


def test_a_press_aimed_inside_the_button_ends_where_the_fingertips_meet_it_pressed(arm):
    """A goal read low lies inside the button: the descent stops on the cap, bottomed out, instead of
    failing as a blocked waypoint; the button reads pressed."""
    button = arm.position("button")
    arm.run(control.actuate_gripper(arm.session, 1.0))
    arm.run(control.move_to(arm.session, button + [0.0, 0.0, 0.08], timeout_s=6.0, settle=True))
    arm.run(control.move_to(arm.session, button - [0.0, 0.0, 0.01], timeout_s=3.0, settle=True))
    assert arm.session.obs.objects["button"].state == 1.0
    assert arm.session.obs.eef_pos[2] > button[2] - 0.01 + control.POS_TOL  # it stopped on the cap, short of the goal


def test_a_cup_lowered_onto_a_button_presses_it_until_the_cap_bottoms_out():
    """The cup arrives on what it lowers onto once it has stopped there, not on first touch: a
    button's cap gives way under it. Sent to the point the ontology keeps for a press (11.4 mm under
    the Panda's, whose fingertips reach deeper), the cap reads pressed; sent to the Panda's own
    grip-site point, the cup's face stops above the cap's travel and it does not."""
    from lerobot_policy_recent.robosuite_envs.primitives import suction

    for height, pressed in ((0.01 - 0.0114, 1.0), (0.01, 0.0)):
        arm = _Arm("kinematic/press_button", "Suction")
        try:
            task = TaskContext(arm.session)
            cap = np.asarray(task.get_object_position("button"))
            arm.run(suction.move_to_position(arm.session, task, cap + [0.0, 0.0, 0.08]))
            arm.run(suction.move_to_position(arm.session, task, cap + [0.0, 0.0, height]))
            assert arm.session.obs.objects["button"].state == pressed, height
        finally:
            arm.env.close()


def test_a_push_withdraws_up_and_back_along_its_line():
    """Away from what it pushed, and not past where it was sent; a push in place withdraws straight up."""
    begin, end = np.array([-0.1, 0.2, 0.82]), np.array([0.1, 0.2, 0.82])
    withdrawn = control._withdrawal(begin, end)
    assert np.allclose(withdrawn, end + [-control.PUSH_BACK_OFF, 0.0, control.APPROACH_HEIGHT])
    assert np.allclose(control._withdrawal(end, end), end + [0.0, 0.0, control.APPROACH_HEIGHT])


def _jaco(task: str, seed: int = 0) -> _Arm:
    """A Jaco with its calibration, its scene reset with ``seed`` (what it perceives, and where)."""
    from lerobot_policy_recent.robosuite_envs.calibrate import calibration

    arm = _Arm(task, "Jaco")
    raw, _ = arm.env.reset(seed=seed)
    arm.session = RobotSession("Jaco", arm._decode(raw), calibration("Jaco"))
    return arm


@pytest.mark.slow
@pytest.mark.parametrize("back_off", [True, False], ids=["withdrawn back", "straight up"])
def test_a_jaco_wiping_at_its_reach_comes_back_for_the_next_stroke(monkeypatch, back_off):
    """The wipe's first stroke ends 0.72 m from the Jaco's base. Withdrawn straight up there, its
    elbow unbends past straight, its wrist comes to its limit, and it stops 13 cm short of the next
    stroke's start, going back by the table's middle too; withdrawn back along the push as it
    rises, it comes back."""
    if not back_off:
        monkeypatch.setattr(control, "PUSH_BACK_OFF", 0.0)
    arm = _jaco("kinematic/wipe_table")
    try:
        area = arm.position("stain")
        arm.run(control.push_to(arm.session, area + [-0.09, -0.045, 0.02], area + [0.09, -0.045, 0.02]))
        next_start = area + [-0.09, -0.015, 0.02 + control.APPROACH_HEIGHT]
        if back_off:
            arm.run(control.move_to(arm.session, next_start, timeout_s=10.0, settle=True))
            assert np.linalg.norm(arm.session.obs.eef_pos - next_start) < arm.session.calibration.settle_tol_m
        else:
            with pytest.raises(PrimitiveFailure, match="the same after going back by the table's middle"):
                arm.run(control.move_to(arm.session, next_start, timeout_s=10.0, settle=True))
    finally:
        arm.env.close()


@pytest.mark.slow
@pytest.mark.parametrize("rise", [True, False], ids=["risen", "not risen"])
def test_a_jaco_trapped_by_a_far_grasp_rises_and_carries_the_block_to_the_bin(monkeypatch, rise):
    """The block lies 0.72 m from the Jaco's base; taken by a hand that comes from the bin's first
    corner, the elbow bends past straight, and the carry to the next corner stops some 4.5 cm short,
    touching nothing: more than twice the Jaco's calibrated steady-state error, so trapped. Risen
    before it goes back by the table's middle, it carries the block there; without the rise it
    stops again."""
    if not rise:
        monkeypatch.setattr(control, "UNFOLD_RISE", 0.0)
    arm = _jaco("kinematic/clear_counter", seed=3)  # the block perceived at (0.121, -0.207)
    try:
        block, bin_pos = arm.position("block"), arm.position("bin")
        arm.run(control.move_to(arm.session, bin_pos + [-0.045, -0.045, 0.2], timeout_s=6.0))  # the cube's corner
        arm.run(control.move_to(arm.session, block + [0.0, 0.0, 0.12], timeout_s=6.0))
        arm.run(control.grasp_at(arm.session, block))
        arm.run(control.move_to(arm.session, [block[0], block[1], bin_pos[2] + 0.2], timeout_s=6.0))
        assert arm.session.obs.held() == "block"
        corner = bin_pos + [-0.045, 0.045, 0.2]
        if rise:
            arm.run(control.move_to(arm.session, corner, timeout_s=6.0))
            assert np.linalg.norm(arm.session.obs.eef_pos - corner) < control.POS_TOL
            assert arm.session.obs.held() == "block"
        else:
            with pytest.raises(PrimitiveFailure, match="the same after going back by the table's middle"):
                arm.run(control.move_to(arm.session, corner, timeout_s=6.0))
    finally:
        arm.env.close()


@pytest.mark.slow
@pytest.mark.parametrize("load", [False, True], ids=["empty", "carrying"])
def test_an_arm_folded_by_a_stretch_breaks_away_from_its_stall_and_arrives(monkeypatch, load):
    """XArm7, stretched to the table's far corner, is sent 30 cm back towards its base. Under the force
    a 2 cm setpoint commands, its folded joints stall against their friction some 25 cm short (no
    contact); the setpoint's reach grows while it is stopped short, and the same move arrives. So it
    does carrying a cube that hangs free, clear of every box below it: a stop there is no contact (the
    failure says so, not "resting on something")."""
    arm = _Arm("kinematic/cube_in_bin", "XArm7")
    try:
        height = TABLE_Z + (0.15 if load else 0.12)  # the cube hangs above the bin's rim
        far, near = np.array([0.15, 0.22, height]), np.array([-0.15, 0.22, height])
        if load:
            arm.run(control.grasp_at(arm.session, arm.position("cube")))
        arm.run(control.move_to(arm.session, far, timeout_s=6.0, settle=True, tol=0.03))
        assert control.load_hangs(arm.session) is load
        with monkeypatch.context() as patch:
            patch.setattr(control, "BREAKAWAY_GROWTH", 1.0)  # the reach never grows: the stall stays
            with pytest.raises(PrimitiveFailure) as trapped:
                arm.run(control.move_to(arm.session, near, timeout_s=6.0, plan=False))
        assert trapped.value.kind in ("cannot_track", "timeout")
        assert ("cube hanging free in hand" in str(trapped.value)) is (load and trapped.value.kind == "cannot_track")
        assert np.linalg.norm(arm.session.obs.eef_pos - near) > 0.15
        arm.run(control.move_to(arm.session, near, timeout_s=6.0, plan=False))
        assert np.linalg.norm(arm.session.obs.eef_pos - near) < control.POS_TOL
        assert arm.session.obs.held() == ("cube" if load else None)
    finally:
        arm.env.close()


@pytest.mark.slow
def test_a_fist_sent_below_the_table_slides_just_above_it():
    """XArm7's closed fingers reach 2.6 cm below its grip site (a Panda's 1.4 cm). Sent to a sweep's
    height, 1.5 cm above the table, with its calibration the fist stops just above the table and
    slides along it untouched; told its fist is no deeper than the grip site, the same move presses
    its fingertips onto the table."""
    from lerobot_policy_recent.robosuite_envs.calibrate import calibration

    for depth, touches in ((None, False), (0.0, True)):
        arm = _Arm("kinematic/cube_in_bin", "XArm7")
        try:
            measured = calibration("XArm7")
            assert measured.fist_below_site_m > measured.below_site_m + 0.005  # linkage fingers swing lower closed
            known = measured if depth is None else dataclasses.replace(measured, fist_below_site_m=depth)
            arm.session = RobotSession("XArm7", arm.session.obs, known)
            arm.run(control.actuate_gripper(arm.session, 1.0))
            start = np.array([-0.15, -0.2, TABLE_Z + 0.015])
            arm.run(control.move_to(arm.session, start + [0.0, 0.0, 0.1], timeout_s=6.0, settle=True))
            contact = []
            for action in control.move_to(arm.session, start, timeout_s=4.0, settle=True, tol=0.03):
                arm.run(iter([action]))
                contact.append(any(arm.session.obs.finger_contact))
            assert any(contact[-10:]) is touches, depth
            if not touches:
                floor = measured.table_top_z + measured.fist_below_site_m + control.FIST_FLOOR
                assert arm.session.obs.eef_pos[2] > floor - 0.002  # its goal was raised to the floor
                arm.run(
                    control.move_to(arm.session, start + [0.15, 0.0, 0.0], timeout_s=6.0, straight=True, plan=False)
                )
        finally:
            arm.env.close()


@pytest.mark.slow
def test_a_release_point_inside_a_block_puts_the_load_onto_it():
    """The block's own position as the release point (what a Franka Hand place by name gives a
    position API): the cube comes down on the block from above its perceived top and rests on it,
    let go. Before, the lowered cube stopped on the block 5 cm above the point: a blocked move."""
    arm = _Arm("kinematic/stack_cube")
    try:
        cube, block = arm.position("cube"), arm.position("block")
        arm.run(control.actuate_gripper(arm.session, -1.0))
        arm.run(control.grasp_at(arm.session, cube))
        assert arm.session.obs.held() == "cube"
        arm.run(control.release_at(arm.session, block))
        assert arm.session.obs.held() is None
        rest, sizes = arm.position("cube"), {n: arm.session.obs.objects[n].size for n in ("cube", "block")}
        assert np.linalg.norm(rest[:2] - block[:2]) < 0.015
        assert rest[2] == pytest.approx(block[2] + (sizes["block"][2] + sizes["cube"][2]) / 2, abs=0.01)
    finally:
        arm.env.close()


def test_a_move_pushes_what_the_hand_starts_against_and_runs_into_not_what_it_starts_in():
    """A fist 5.5 cm behind a 4 cm cube, sent past it, pushes it; the same fist pressed on the cube's
    side and sent away pushes nothing, nor does one lifted off it, one that starts at the box's centre
    (a hand on a drawer's knob, which the drawer's box is centred on, pulling it), a move whose goal
    lies in the cube, or one that passes beside it."""
    seen = clearance.boxes(_observation({"cube": [0.0, 0.0, 0.82]}))
    fist = clearance.Sweep((clearance.hand((0.02, 0.02)),))
    behind, pressed = np.array([-0.055, 0.0, 0.82]), np.array([-0.03, 0.0, 0.82])
    assert [box.name for box in clearance.pushed(behind, [0.2, 0.0, 0.82], seen, fist)] == ["cube"]
    assert clearance.pushed(pressed, [-0.2, 0.0, 0.82], seen, fist) == []
    assert clearance.pushed(pressed, [0.0, 0.0, 0.95], seen, fist) == []
    assert clearance.pushed([0.004, 0.0, 0.82], [-0.12, 0.0, 0.825], seen, fist) == []
    assert clearance.pushed([-0.004, 0.0, 0.82], [-0.12, 0.0, 0.825], seen, fist) == []
    assert clearance.pushed(behind, [0.0, 0.0, 0.83], seen, fist) == []
    assert clearance.pushed(behind, [-0.055, 0.2, 0.82], seen, fist) == []


def test_a_release_point_stands_for_the_object_whose_own_position_it_is():
    """An object's own perceived position (within perception's noise) stands for the object; a
    point computed inside its box (a corner of a bin's floor) does not, nor does a point above it,
    and the held load is never what it is put onto."""
    obs = _observation({"bin": [0.0, 0.0, 0.85], "cube": [0.0, 0.0, 0.83], "block": [0.2, 0.0, 0.83]})
    seen = clearance.boxes(obs)
    assert clearance.object_at(seen, [0.0, 0.0, 0.846]).name == "bin"  # the nearer of two
    assert clearance.object_at(seen, [0.208, 0.007, 0.824]).name == "block"  # a track against a noisy frame
    assert clearance.object_at(seen, [0.208, 0.007, 0.824], clearance.GOAL_MARGIN) is None  # against a track
    assert clearance.object_at(seen, [0.045, 0.045, 0.835]) is None  # a corner of a bin's floor
    assert clearance.object_at(seen, [0.2, 0.0, 0.95]) is None
    held = _carrying(np.array([0.2, 0.0, 0.86]), 0.03)
    assert clearance.object_at(clearance.boxes(held), held.objects[held.held()].pos) is None


def test_a_jaw_is_turned_the_least_way_square_to_a_boxs_faces():
    """A Sawyer's hand at 101 degrees over the rake (0) turns back 11; a quarter turn either way is as
    square; a box without orientation asks for no turn, and a grasp squares only a long object. The object a grasp closes on is the one whose
    box holds the point, the nearest centre where several do (a cube in a bin)."""
    from robosuite.utils.transform_utils import axisangle2quat, quat_multiply

    from lerobot_policy_recent.robosuite_envs.primitives import squaring

    def about_z(degrees: float) -> np.ndarray:
        half = np.radians(degrees) / 2
        return np.array([0.0, 0.0, np.sin(half), np.cos(half)])

    assert np.degrees(squaring.square_turn(about_z(101), about_z(0))) == pytest.approx(-11)
    assert np.degrees(squaring.square_turn(about_z(0), about_z(50))) == pytest.approx(-40)
    assert np.degrees(squaring.square_turn(about_z(10), about_z(-170))) == pytest.approx(0, abs=1e-6)
    assert squaring.square_turn(about_z(30), np.zeros(4)) == 0.0
    block = ObjectState(np.zeros(3), about_z(20), np.array([0.05, 0.05, 0.05]))  # the pads turn it as they close
    rake = ObjectState(np.zeros(3), about_z(20), np.array([0.27, 0.16, 0.07]))  # it resists, and turns later
    assert squaring.grasp_turn(about_z(0), block) == 0.0
    assert np.degrees(squaring.grasp_turn(about_z(0), rake)) == pytest.approx(20)
    # a hand pointing down, tilted 1 degree: its yaw is its x axis's, whichever of x and y lies flatter
    # (read by the flatter axis, the hand and its held orientation differed by a quarter turn)
    down = quat_multiply(about_z(100), quat_multiply(np.array([1.0, 0.0, 0.0, 0.0]), axisangle2quat([0, 0.017, 0])))
    assert np.degrees(squaring.yaw_of(down)) == pytest.approx(100, abs=0.5)
    cube = ObjectState(np.array([0.0, 0.0, 0.84]), about_z(20), np.array([0.04, 0.04, 0.04]))
    bin_ = ObjectState(np.array([0.01, 0.0, 0.86]), about_z(0), np.array([0.2, 0.2, 0.08]))
    obs = dataclasses.replace(_observation({}), objects={"cube": cube, "bin": bin_})
    assert squaring.grasped(obs, [0.0, 0.0, 0.845]) == "cube"
    assert squaring.grasped(obs, [0.08, 0.0, 0.86]) == "bin"
    assert squaring.grasped(obs, [0.3, 0.0, 0.86]) is None


@pytest.mark.parametrize("squared", [True, False], ids=["squared", "as_it_came"])
def test_a_sawyer_takes_the_rake_square_to_its_handle_and_it_does_not_turn_in_the_grip(monkeypatch, squared):
    """panel_then_tools s7 on Sawyer: the hand came down 11 degrees off the rake's handle, the pads
    turned the rake 10 degrees while it was carried, and its crossbar pushed the dragged cube out of
    the zone's side. Turned square first, the rake keeps its yaw through the lift, within the
    controller's deadband; taken as the hand came, it turns (9.5 degrees here)."""
    from lerobot_policy_recent.robosuite_envs.calibrate import calibration
    from lerobot_policy_recent.robosuite_envs.primitives import squaring

    arm = _Arm("kinematic/drag_cube", "Sawyer")
    arm.session = RobotSession("Sawyer", arm.session.obs, calibration("Sawyer"))
    try:
        if not squared:
            monkeypatch.setattr(control, "square_to", lambda session, name: _no_turn())
        rake = arm.position("rake")
        start = arm.session.obs.objects["rake"].quat.copy()
        arm.run(control.move_to(arm.session, rake + [0.0, 0.0, 0.12], timeout_s=6.0, settle=True))
        arm.run(control.rotate_about_z(arm.session, np.radians(12)))
        arm.session.hold_yaw = False
        arm.run(control.grasp_at(arm.session, rake + [0.0, 0.0, 0.025], object_name="rake"))
        arm.run(control.move_to(arm.session, rake + [0.15, 0.1, 0.1], timeout_s=6.0, settle=True))
        assert arm.session.obs.held() == "rake"
        turned = abs(np.degrees(squaring.square_turn(arm.session.obs.objects["rake"].quat, start)))
        deadband = np.degrees(control.ROT_DEADBAND)  # the slant the controller leaves
        assert turned < deadband if squared else turned > 2 * deadband, turned
    finally:
        arm.env.close()


def test_a_grasp_that_turned_for_a_tool_and_then_failed_leaves_the_yaw_free():
    """A grasp turns the jaw square to the rake, then its descent is refused (a point given below the
    table): the moves after it keep the yaw free again, as after a grasp that ended."""
    from lerobot_policy_recent.robosuite_envs.calibrate import calibration

    arm = _Arm("kinematic/drag_cube", "Sawyer")
    arm.session = RobotSession("Sawyer", arm.session.obs, calibration("Sawyer"))
    try:
        below = arm.position("rake") * [1.0, 1.0, 0.0] + [0.0, 0.0, TABLE_Z - 0.02]
        arm.run(control.move_to(arm.session, below + [0.0, 0.0, 0.14], timeout_s=6.0, settle=True))
        arm.run(control.rotate_about_z(arm.session, np.radians(12)))
        arm.session.hold_yaw = False
        with pytest.raises(PrimitiveFailure, match="below the table"):
            arm.run(control.grasp_at(arm.session, below, object_name="rake"))
        assert not arm.session.hold_yaw
    finally:
        arm.env.close()


def _no_turn():
    return False
    yield  # a generator that turns nothing
