"""A robosuite manipulation environment built from a :class:`~lerobot_policy_recent.robosuite_envs.tasks.TaskSpec`.

Follows robosuite's layering: a ``ManipulationEnv`` whose ``_load_model`` composes a
``TableArena``, the robot (with the embodiment's gripper) and the task's objects
(:mod:`lerobot_policy_recent.robosuite_envs.objects`). Per-subtask success is latched in plan order every step, so
goal-conditioned success (GC) survives later subtasks that change the scene again.
"""

from __future__ import annotations

from lerobot_policy_recent.robosuite_envs import runtime  # noqa: F401  (headless GL before robosuite loads)

# isort: split
from collections import Counter
from dataclasses import replace

import mujoco
import numpy as np
from robosuite.environments.manipulation.manipulation_env import ManipulationEnv
from robosuite.models.arenas import TableArena
from robosuite.models.tasks import ManipulationTask
from robosuite.utils.mjcf_utils import array_to_string
from robosuite.utils.transform_utils import convert_quat, mat2quat

from lerobot_policy_recent.robosuite_envs.grippers import (
    SuctionGripper,  # also registers our gripper models with robosuite
)
from lerobot_policy_recent.robosuite_envs.objects import get_kind
from lerobot_policy_recent.robosuite_envs.observation import GroundTruth, ObjectState, Observation
from lerobot_policy_recent.robosuite_envs.primitives.session import CONTROL_FREQ
from lerobot_policy_recent.robosuite_envs.subtasks import get_subtask
from lerobot_policy_recent.robosuite_envs.table import TABLE_OFFSET, TABLE_SIZE
from lerobot_policy_recent.robosuite_envs.tasks import ObjectSpec, TaskSpec
from lerobot_policy_recent.robosuite_envs.variations import (
    FAR_TARGET_XY,
    OBSTACLE,
    VariationPlan,
    apply_build_variations,
    plan_variations,
)

PARKING = np.array([1.5, 1.5, 0.05])  # off the table, on the floor: where unused objects wait
BUTTON_PRESSED = 0.005  # metres of cap travel that count as a press
SEAL_CONTACTS = 3  # contact points between cup and face that make a vacuum seal (a ball gives one)
LEAK_AFTER_STEPS = 30  # seal_failure: policy steps (1.5 s) a seal holds the object before it leaks
WIPE_GRID = 4  # a wipe area is WIPE_GRID x WIPE_GRID cells
WIPE_HEIGHT = 0.035  # the grip site counts as wiping below this height above the table
SINK_TOLERANCE = 0.001  # metres one object may overlap another where a displaced one is set down
LIFT_STEP = 0.002  # a displaced object that would sink into another is raised in these steps ...
LIFT_MAX = 0.3  # ... up to this far, to fall from there onto what is under it


class RecentTabletopEnv(ManipulationEnv):
    """One robot at a table with the objects of one task; success is every plan step achieved."""

    def __init__(self, task: TaskSpec, robots: str, gripper_types: str, variations: tuple[str, ...] = (), **kwargs):
        self.task_spec = apply_build_variations(task, variations, kwargs.get("seed"))
        self.variations = tuple(variations)
        self._specs = {spec.name: spec for spec in self.task_spec.objects}
        self._extents = {name: _frozen(spec.size) for name, spec in self._specs.items()}  # read every step: built once
        self._suction_actuator: int | None = None
        self._cup_geom = -1
        self._geom_owner: dict[int, str] = {}
        self._gripper_geoms: frozenset[int] = frozenset()
        self._robot_root = -1  # the robot's root body: contacts with its own links are not sensed
        self._finger_pads: tuple[frozenset[int], ...] = ()
        self._contact_cache: tuple[tuple[int, float] | None, Counter[tuple[int, int]]] = (None, Counter())
        self._adhesion_gain = 0.0
        self._seal: str | None = None  # the object a vacuum cup is sealed on
        self._sealed_steps = 0  # policy steps the current seal has held (seal_failure counts them)
        self._leaked: set[str] = set()  # objects whose seal failed mid-task: no cup seals on them again
        self._episode = 0
        self._snapshot: tuple[tuple[int, float], Observation] | None = None
        self.table_top_z = float(TABLE_OFFSET[2])
        self._objects: dict = {}
        self._body_ids: dict[str, int] = {}
        self._root_ids: dict[str, int] = {}
        self._joint_addr: dict[str, int] = {}
        self._parked: set[str] = set()
        self._latched_state: dict[str, float] = {}
        self._wiped: dict[str, np.ndarray] = {}
        self.achieved: list[bool] = []
        self.plan = VariationPlan(enabled=())
        self.elapsed_steps = 0
        self._noise_rng = np.random.default_rng(0)
        self._defaults: dict[str, np.ndarray] = {}
        super().__init__(robots=robots, gripper_types=gripper_types, base_types="default", **kwargs)

    # ----------------------------------------------------------------- model
    def _load_model(self):
        super()._load_model()
        robot = self.robots[0]
        robot.robot_model.set_base_xpos(robot.robot_model.base_xpos_offset["table"](TABLE_SIZE[0]))
        exclude_mount_contacts(robot.robot_model)
        arena = TableArena(table_full_size=TABLE_SIZE, table_offset=TABLE_OFFSET)
        arena.set_origin([0, 0, 0])
        self._objects = {}
        for spec in self.task_spec.objects:
            obj = get_kind(spec.kind).build(spec.name, spec.size, spec.rgba)
            if get_kind(spec.kind).fixed:
                obj.get_obj().set("pos", array_to_string(self._nominal_pos(spec)))
            self._objects[spec.name] = obj
        self.model = ManipulationTask(
            mujoco_arena=arena,
            mujoco_robots=[robot.robot_model],
            mujoco_objects=list(self._objects.values()),
        )

    def _nominal_pos(self, spec: ObjectSpec, xy=None) -> np.ndarray:
        """World position of the object's origin resting at ``xy``: MJCF fixtures have theirs at
        the bottom, generated shapes at their centre."""
        xy = spec.xy if xy is None else xy
        kind = get_kind(spec.kind)
        lift = 0.0 if kind.fixed and kind.size is not None else spec.size[2] / 2 + 0.001
        return np.array([xy[0], xy[1], self.table_top_z + lift])

    def _setup_references(self):
        super()._setup_references()
        model = self.sim.model
        for name, obj in self._objects.items():
            kind = get_kind(self._specs[name].kind)
            self._root_ids[name] = model.body_name2id(obj.root_body)
            body = obj.naming_prefix + kind.body if kind.body else obj.root_body
            self._body_ids[name] = model.body_name2id(body)
            if kind.joint:
                self._joint_addr[name] = model.jnt_qposadr[model.joint_name2id(obj.naming_prefix + kind.joint)]
        robot = self.robots[0]
        gripper = robot.gripper[robot.arms[0]]
        self._geom_owner = {
            model.geom_name2id(geom): name for name, obj in self._objects.items() for geom in obj.contact_geoms
        }
        self._gripper_geoms = frozenset(model.geom_name2id(g) for g in gripper.contact_geoms)
        self._robot_root = int(model.body_rootid[model.body_name2id(robot.robot_model.root_body)])
        self._finger_pads = tuple(
            frozenset(model.geom_name2id(g) for g in gripper.important_geoms[side])
            for side in ("left_fingerpad", "right_fingerpad")
        )
        if isinstance(gripper, SuctionGripper):
            self._suction_actuator = int(robot._ref_joint_gripper_actuator_indexes[robot.arms[0]][0])
            self._cup_geom = model.geom_name2id(gripper.important_geoms["cup"][0])
            # read once: later resets find the gain this env itself zeroed while no seal held
            self._adhesion_gain = self._adhesion_gain or float(model.actuator_gainprm[self._suction_actuator, 0])
        if not self._defaults:  # the model as built, before any variation scaled it (captured once)
            self._defaults = {
                "friction": np.array(model.geom_friction),
                "mass": np.array(model.body_mass),
                "inertia": np.array(model.body_inertia),
            }

    # ----------------------------------------------------------------- reset
    def _reset_internal(self):
        super()._reset_internal()
        rng = self.rng
        self.plan = plan_variations(self.task_spec, self.variations, rng)
        self._noise_rng = np.random.default_rng(rng.integers(2**32))
        self._parked = {OBSTACLE} & set(self._specs)
        for spec in self.task_spec.objects:
            jitter = rng.uniform(-spec.xy_jitter, spec.xy_jitter, size=2) if spec.xy_jitter else np.zeros(2)
            xy = np.array(spec.xy) + jitter
            if spec.name == self.plan.far_target:
                xy = np.array(FAR_TARGET_XY)
            pos = PARKING if spec.name in self._parked else self._nominal_pos(spec, xy)
            self._place(spec.name, pos)
            if spec.name in self._joint_addr:
                self.sim.data.qpos[self._joint_addr[spec.name]] = spec.state
        self._apply_material_variations()
        self.sim.forward()
        self._latched_state = {name: 0.0 for name in self._specs}
        self._wiped = {}
        self.achieved = [False] * len(self.task_spec.plan)
        self.elapsed_steps = 0
        self._seal, self._sealed_steps, self._leaked = None, 0, set()
        self._episode += 1  # sim time restarts at 0: a new key for observe()'s snapshot

    def _place(self, name: str, pos: np.ndarray) -> None:
        obj = self._objects[name]
        if get_kind(self._specs[name].kind).fixed:
            self.sim.model.body_pos[self._root_ids[name]] = pos
        else:
            self.sim.data.set_joint_qpos(obj.joints[0], np.concatenate([pos, [1.0, 0.0, 0.0, 0.0]]))
            self.sim.data.set_joint_qvel(obj.joints[0], np.zeros(6))

    def _set_down(self, name: str, pos: np.ndarray) -> None:
        """Place ``name`` at ``pos`` or, where it would sink into another object there (a lid
        displaced onto a button's base), just above that object, to fall onto it: a displaced object
        lies on what is under it, never jammed inside it."""
        own = {geom for geom, owner in self._geom_owner.items() if owner == name}
        model, data = self.sim.model._model, self.sim.data._data
        for lift in np.arange(0.0, LIFT_MAX, LIFT_STEP):
            self._place(name, pos + np.array([0.0, 0.0, lift]))
            # poses and contacts only: a full forward pass would also move the solver's warm start,
            # and every episode whose object lands clear must run on exactly as before
            mujoco.mj_kinematics(model, data)
            mujoco.mj_collision(model, data)
            if not self._sinks_into_another(own, data):
                return

    def _sinks_into_another(self, own: set[int], data: mujoco.MjData) -> bool:
        """Whether one of ``own``'s geoms lies deeper than SINK_TOLERANCE inside another object's."""
        for contact in data.contact[: data.ncon]:
            a, b = int(contact.geom1), int(contact.geom2)
            other = b if a in own else a if b in own else None
            if other is not None and other not in own and other in self._geom_owner:
                if contact.dist < -SINK_TOLERANCE:
                    return True
        return False

    def _apply_material_variations(self) -> None:
        model = self.sim.model
        model.geom_friction[:] = self._defaults["friction"]
        model.body_mass[:] = self._defaults["mass"]
        model.body_inertia[:] = self._defaults["inertia"]
        for name, spec in self._specs.items():
            body = self._root_ids[name]
            if spec.mass_kg is not None:  # a drawn mass (odd_obstacle): the inertia scales with it
                model.body_inertia[body] *= spec.mass_kg / model.body_mass[body]
                model.body_mass[body] = spec.mass_kg
            if not get_kind(spec.kind).graspable:
                continue
            for geom in self._objects[name].contact_geoms:
                model.geom_friction[model.geom_name2id(geom), 0] *= self.plan.friction_scale
            model.body_mass[body] *= self.plan.mass_scale
            model.body_inertia[body] *= self.plan.mass_scale

    # ------------------------------------------------------------- stepping
    def _pre_action(self, action, policy_step=False):
        super()._pre_action(action, policy_step)
        if policy_step and self._suction_actuator is not None:
            self._update_seal()

    def _update_seal(self) -> None:
        """A vacuum cup seals only on a flat, non-porous face pressed under its rim (at least
        SEAL_CONTACTS contact points); the adhesion actuator pulls only while a seal holds."""
        sim, actuator = self.sim, self._suction_actuator
        if sim.data.ctrl[actuator] < 0.5:
            self._seal = None
        else:
            contacts = self._cup_contacts()
            if self._seal is not None and not contacts.get(self._seal):
                self._seal = None  # pulled off: the seal broke
            if self._seal is not None and self._seal == self.plan.leak_object:
                self._sealed_steps += 1
                if self._sealed_steps >= LEAK_AFTER_STEPS:  # seal_failure: the face leaks once it is carried
                    self._leaked.add(self._seal)
                    self._seal = None
            if self._seal is None:
                self._sealed_steps = 0
                flat = [
                    n
                    for n, k in contacts.items()
                    if k >= SEAL_CONTACTS and self._specs[n].surface != "porous" and n not in self._leaked
                ]
                self._seal = flat[0] if flat else None
        sim.model.actuator_gainprm[actuator, 0] = self._adhesion_gain if self._seal else 0.0

    def _cup_contacts(self) -> dict[str, int]:
        """Contact points between the cup and each object (a seal needs several, not just one pair)."""
        counts: dict[str, int] = {}
        for (a, b), points in self._contacts().items():
            if a == self._cup_geom and b in self._geom_owner:
                counts[self._geom_owner[b]] = counts.get(self._geom_owner[b], 0) + points
        return counts

    def _post_action(self, action):
        reward, done, info = super()._post_action(action)
        self.elapsed_steps += 1
        self._run_events()
        self._track_progress()
        return reward, done, info

    def _run_events(self) -> None:
        plan, step = self.plan, self.elapsed_steps
        if plan.perturb_object and step == plan.perturb_step and not self.holds(plan.perturb_object):
            pos = np.array(self.sim.data.body_xpos[self._root_ids[plan.perturb_object]])
            pos[:2] = np.clip(pos[:2] + plan.perturb_offset, -0.35, 0.35)
            self._set_down(plan.perturb_object, pos)
        if plan.obstacle_target and step == plan.obstacle_step:
            target = np.array(self.sim.data.body_xpos[self._body_ids[plan.obstacle_target]])
            self._parked.discard(OBSTACLE)
            drop = max(0.06, self._specs[OBSTACLE].size[2] / 2 + 0.03)  # dropped from a little above the table
            self._place(OBSTACLE, np.array([target[0], target[1], self.table_top_z + drop]))
        if step in (plan.perturb_step, plan.obstacle_step):
            self.sim.forward()

    def _track_progress(self) -> None:
        """Latch button presses and wiped cells, then latch subtasks in plan order."""
        grip = self._grip_site_pos()
        for name, spec in self._specs.items():
            if spec.kind == "button":
                pressed = self.sim.data.qpos[self._joint_addr[name]] < -BUTTON_PRESSED
                self._latched_state[name] = max(self._latched_state[name], float(pressed))
            elif spec.kind == "stain":
                self._latched_state[name] = self._wipe_coverage(name, spec, grip)
        obs = self.observe()
        for i, step in enumerate(self.task_spec.plan):
            if self.achieved[i]:
                continue
            if i > 0 and not self.achieved[i - 1]:
                break
            self.achieved[i] = get_subtask(step.subtask).check(self.task_spec, obs, step.args)

    def _wipe_coverage(self, name: str, spec: ObjectSpec, grip: np.ndarray) -> float:
        cells = self._wiped.setdefault(name, np.zeros((WIPE_GRID, WIPE_GRID), dtype=bool))
        centre, half = self.sim.data.body_xpos[self._body_ids[name]], np.array(spec.size[:2]) / 2
        rel = (grip[:2] - (centre[:2] - half)) / (2 * half)
        if grip[2] < self.table_top_z + WIPE_HEIGHT and np.all((rel >= 0) & (rel < 1)):
            i, j = (rel * WIPE_GRID).astype(int)
            cells[i, j] = True
        return float(cells.mean())

    def _grip_site_pos(self) -> np.ndarray:
        robot = self.robots[0]
        return np.array(self.sim.data.site_xpos[robot.eef_site_id[robot.arms[0]]])

    # ----------------------------------------------------------- observation
    def observe(self) -> Observation:
        """The exact state: end effector, gripper sensors, object poses, and the simulator's own
        answers (:class:`GroundTruth`: what is held and touched) for success predicates and logs.

        Computed once per simulated instant: robosuite's ``step`` asks for the reward, the gym
        wrapper for success and for the observation — all read the same snapshot.
        """
        key = (self._episode, self.sim.data.time)
        if self._snapshot is None or self._snapshot[0] != key:
            self._snapshot = (key, self._observe())
        return self._snapshot[1]

    def sensed(self) -> Observation:
        """What the robot's sensors report: the exact state without the simulator's answers, plus the
        ``sensing_noise`` variation on perceived positions."""
        obs = replace(self.observe(), truth=None)
        if not self.plan.noise_sigma:
            return obs
        noisy = {
            name: replace(state, pos=state.pos + self._noise_rng.normal(0.0, self.plan.noise_sigma, 3))
            for name, state in obs.objects.items()
        }
        return replace(obs, objects=noisy)

    def _observe(self) -> Observation:
        robot = self.robots[0]
        arm = robot.arms[0]
        site = robot.eef_site_id[arm]
        eef_quat = mat2quat(np.array(self.sim.data.site_xmat[site]).reshape(3, 3))
        objects, touching = {}, self._touching()
        held = frozenset(name for name in self._specs if name not in self._parked and self.holds(name))
        for spec in self.task_spec.objects:
            if spec.name in self._parked:
                continue
            body = self._body_ids[spec.name]
            joint = self._joint_addr.get(spec.name)
            latched = joint is None or spec.kind == "button"  # progress the env tracks, not a joint
            state = self._latched_state.get(spec.name, 0.0) if latched else float(self.sim.data.qpos[joint])
            objects[spec.name] = ObjectState(
                pos=np.array(self.sim.data.body_xpos[body]),
                quat=convert_quat(np.array(self.sim.data.body_xquat[body]), to="xyzw"),
                size=self._extents[spec.name],
                state=state,
            )
        return Observation(
            eef_pos=self._grip_site_pos(),
            eef_quat=eef_quat,
            gripper_opening=self.gripper_opening(),
            objects=objects,
            joint_pos=np.array(self.sim.data.qpos[robot._ref_arm_joint_pos_indexes]),
            joint_vel=np.array(self.sim.data.qvel[robot._ref_arm_joint_vel_indexes]),
            finger_contact=tuple(self._pad_contact(pads) for pads in self._finger_pads) or (False, False),
            object_detected=bool(held),
            vacuum=1.0 if self._seal is not None else 0.0,
            eef_contact=bool(touching - held),
            truth=GroundTruth(held=held, touching=frozenset(touching)),
        )

    def gripper_opening(self) -> float:
        """Mean finger joint travel; for a vacuum gripper its suction command, 0 (off) .. 1 (on)."""
        robot = self.robots[0]
        arm = robot.arms[0]
        if isinstance(robot.gripper[arm], SuctionGripper):
            return float(self.sim.data.ctrl[robot._ref_joint_gripper_actuator_indexes[arm]][0])
        qpos = self.sim.data.qpos[robot._ref_gripper_joint_pos_indexes[arm]]
        return float(np.mean(np.abs(qpos))) if len(qpos) else 0.0

    def holds(self, name: str) -> bool:
        """Both finger pads on the object (robosuite's grasp check), or the vacuum cup sealed on it."""
        if not get_kind(self._specs[name].kind).graspable:
            return False
        if self._suction_actuator is not None:
            return self._seal == name
        return all(self._pad_touches(pads, name) for pads in self._finger_pads)

    def _contacts(self) -> Counter[tuple[int, int]]:
        """Contact points per geom pair (both orders), read once per simulated instant and shared
        by the grasp, touch and vacuum-seal checks."""
        key = (self._episode, self.sim.data.time)
        if self._contact_cache[0] != key:
            contacts = self.sim.data.contact  # the ncon active contacts, as arrays (no MjContact per point)
            first, second = contacts.geom1.tolist(), contacts.geom2.tolist()
            pairs: Counter[tuple[int, int]] = Counter(zip(first, second, strict=True))
            pairs.update(zip(second, first, strict=True))
            self._contact_cache = (key, pairs)
        return self._contact_cache[1]

    def _touching(self) -> set[str]:
        """Objects any gripper geom touches."""
        return {self._geom_owner[b] for a, b in self._contacts() if a in self._gripper_geoms and b in self._geom_owner}

    def _pad_contact(self, pads: frozenset[int]) -> bool:
        """A finger pad's tactile reading: it touches anything that is not the robot itself."""
        return any(
            a in pads and self.sim.model.body_rootid[self.sim.model.geom_bodyid[b]] != self._robot_root
            for a, b in self._contacts()
        )

    def _pad_touches(self, pads: frozenset[int], name: str) -> bool:
        return any(a in pads and self._geom_owner.get(b) == name for a, b in self._contacts())

    # --------------------------------------------------------------- success
    @property
    def goal_conditioned_success(self) -> float:
        return float(np.mean(self.achieved)) if self.achieved else 0.0

    def _check_success(self):
        return bool(self.achieved) and all(self.achieved)

    def reward(self, action=None):
        return self.goal_conditioned_success


def _frozen(values) -> np.ndarray:
    array = np.array(values, dtype=float)
    array.flags.writeable = False
    return array


def exclude_mount_contacts(robot_model) -> None:
    """Exclude contacts between each first moving link and the static body it is mounted on.

    MuJoCo filters parent-child contacts except where the parent is welded to the world, so a
    link resting on its mount (robosuite's Sawyer: ``right_l0`` on ``right_arm_base_link``, in
    contact at zero distance) gets friction that locks the joint. Sawyer's base yaw (``right_j0``)
    then never turned, and the hand could not reach the table's -y half.
    """
    import xml.etree.ElementTree as ET

    def moves(body) -> bool:
        return body.find("joint") is not None or body.find("freejoint") is not None

    def visit(body, welded: bool) -> None:
        """``welded``: ``body`` and all its ancestors are fixed to the world."""
        for child in body.findall("body"):
            if welded and moves(child):
                robot_model.contact.append(ET.Element("exclude", body1=body.get("name"), body2=child.get("name")))
            visit(child, welded and not moves(child))

    for top in robot_model.worldbody.findall("body"):
        visit(top, not moves(top))


def check_robosuite_names(embodiment) -> None:
    """The embodiment's robot and gripper classes exist in robosuite (and ours): else one line naming
    the robot file's field, instead of robosuite's bare assertion deep in model loading."""
    from robosuite.models.grippers import GRIPPER_MAPPING
    from robosuite.robots import ROBOT_CLASS_MAPPING

    where = (
        f"{embodiment.spec_dir}/{embodiment.api}.yaml: robot."
        if embodiment.spec_dir
        else f"embodiment {embodiment.name}: "
    )
    for field, value, known in (
        ("robosuite", embodiment.robot, ROBOT_CLASS_MAPPING),
        ("gripper", embodiment.gripper, GRIPPER_MAPPING),
    ):
        if value not in known:
            raise ValueError(
                f"{where}{field}: unknown robosuite {field if field == 'gripper' else 'robot'} class {value!r}; "
                f"known: {', '.join(sorted(k for k in known if k))}"
            )


def build_env(
    task: TaskSpec, embodiment, *, seed: int | None, variations: tuple[str, ...] = (), offscreen: bool = False
) -> RecentTabletopEnv:
    """The tabletop env for ``task`` with ``embodiment`` (an :class:`~lerobot_policy_recent.descriptions.embodiments.Embodiment`),
    under operational-space control at ``CONTROL_FREQ``, never ending on its own."""
    from robosuite.controllers import load_composite_controller_config

    check_robosuite_names(embodiment)
    return RecentTabletopEnv(
        task,
        variations=variations,
        robots=embodiment.robot,
        gripper_types=embodiment.gripper,
        controller_configs=load_composite_controller_config(controller="BASIC", robot=embodiment.robot),
        has_renderer=False,
        has_offscreen_renderer=offscreen,
        use_camera_obs=False,
        ignore_done=True,
        hard_reset=False,
        control_freq=CONTROL_FREQ,
        horizon=10**9,
        seed=seed,
    )
