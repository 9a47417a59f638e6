"""A robosuite manipulation environment built from a :class:`~robosuite_envs.tasks.TaskSpec`.

Follows robosuite's layering: a ``ManipulationEnv`` whose ``_load_model`` composes a
``TableArena``, the robot (with the embodiment's gripper) and the task's objects.
"""

from __future__ import annotations

import numpy as np
from robosuite.environments.manipulation.manipulation_env import ManipulationEnv
from robosuite.models.arenas import TableArena
from robosuite.models.objects import BoxObject
from robosuite.models.objects.composite import Bin
from robosuite.models.tasks import ManipulationTask
from robosuite.utils.transform_utils import convert_quat, mat2quat

from robosuite_envs.grippers import SuctionGripper  # also registers our gripper models with robosuite
from robosuite_envs.observation import ObjectState, Observation
from robosuite_envs.tasks import ObjectSpec, TaskSpec

TABLE_SIZE = (0.8, 0.8, 0.05)
TABLE_OFFSET = np.array((0.0, 0.0, 0.8))


class RecentTabletopEnv(ManipulationEnv):
    """One robot at a table with the objects of one task; success is the task's predicate."""

    def __init__(self, task: TaskSpec, robots: str, gripper_types: str, **kwargs):
        self.task_spec = task
        self._specs = {spec.name: spec for spec in task.objects}
        self._episode = 0
        self._snapshot: tuple[tuple[int, float], Observation] | None = None
        self.table_top_z = float(TABLE_OFFSET[2])
        self._objects: dict[str, BoxObject | Bin] = {}
        self._body_ids: dict[str, int] = {}
        super().__init__(robots=robots, gripper_types=gripper_types, base_types="default", **kwargs)

    # ----------------------------------------------------------------- model
    def _load_model(self):
        super()._load_model()
        robot = self.robots[0]
        robot.robot_model.set_base_xpos(robot.robot_model.base_xpos_offset["table"](TABLE_SIZE[0]))
        arena = TableArena(table_full_size=TABLE_SIZE, table_offset=TABLE_OFFSET)
        arena.set_origin([0, 0, 0])
        self._objects = {spec.name: self._make_object(spec) for spec in self.task_spec.objects}
        self.model = ManipulationTask(
            mujoco_arena=arena,
            mujoco_robots=[robot.robot_model],
            mujoco_objects=list(self._objects.values()),
        )

    @staticmethod
    def _make_object(spec: ObjectSpec):
        if spec.kind == "box":
            return BoxObject(
                name=spec.name,
                size=np.array(spec.size) / 2,
                rgba=list(spec.rgba),
                density=400.0,
                friction=(1.5, 0.005, 0.0001),
            )
        if spec.kind == "bin":
            return Bin(
                name=spec.name,
                bin_size=spec.size,
                wall_thickness=0.01,
                transparent_walls=False,
                use_texture=False,
                rgba=spec.rgba,
                density=20000.0,  # heavy enough that a brushing arm does not shove it
            )
        raise ValueError(f"object {spec.name!r}: unknown kind {spec.kind!r} (known: box, bin)")

    def _setup_references(self):
        super()._setup_references()
        self._body_ids = {name: self.sim.model.body_name2id(obj.root_body) for name, obj in self._objects.items()}

    # ----------------------------------------------------------------- reset
    def _reset_internal(self):
        super()._reset_internal()
        rng = self.rng
        for spec in self.task_spec.objects:
            jitter = rng.uniform(-spec.xy_jitter, spec.xy_jitter, size=2) if spec.xy_jitter else np.zeros(2)
            xy = np.array(spec.xy) + jitter
            obj = self._objects[spec.name]
            z = self.table_top_z + spec.size[2] / 2 + 0.001
            pos = np.array([xy[0], xy[1], z])
            self.sim.data.set_joint_qpos(obj.joints[0], np.concatenate([pos, [1.0, 0.0, 0.0, 0.0]]))
        self.sim.forward()
        self._episode += 1  # sim time restarts at 0: a new key for observe()'s snapshot

    # ----------------------------------------------------------- observation
    def observe(self) -> Observation:
        """The state primitives may use: end effector, gripper opening, object poses and grasps.

        Computed once per simulated instant: robosuite's ``step`` asks for the reward, the gym
        wrapper for success and for the observation — all read the same snapshot.
        """
        key = (self._episode, self.sim.data.time)
        if self._snapshot is None or self._snapshot[0] != key:
            self._snapshot = (key, self._observe())
        return self._snapshot[1]

    def _observe(self) -> Observation:
        robot = self.robots[0]
        arm = robot.arms[0]
        site = robot.eef_site_id[arm]
        eef_pos = np.array(self.sim.data.site_xpos[site])
        eef_quat = mat2quat(np.array(self.sim.data.site_xmat[site]).reshape(3, 3))
        objects = {}
        for spec in self.task_spec.objects:
            body = self._body_ids[spec.name]
            objects[spec.name] = ObjectState(
                pos=np.array(self.sim.data.body_xpos[body]),
                quat=convert_quat(np.array(self.sim.data.body_xquat[body]), to="xyzw"),
                grasped=self.holds(spec.name),
                touching=bool(self.check_contact(robot.gripper[arm], self._objects[spec.name])),
                height=float(spec.size[2]),
            )
        return Observation(eef_pos=eef_pos, eef_quat=eef_quat, gripper_opening=self.gripper_opening(), objects=objects)

    def gripper_opening(self) -> float:
        """Mean finger joint travel; for a vacuum gripper its suction command, 0 (off) .. 1 (on)."""
        robot = self.robots[0]
        arm = robot.arms[0]
        if isinstance(robot.gripper[arm], SuctionGripper):
            return float(self.sim.data.ctrl[robot._ref_joint_gripper_actuator_indexes[arm]][0])
        qpos = self.sim.data.qpos[robot._ref_gripper_joint_pos_indexes[arm]]
        return float(np.mean(np.abs(qpos))) if len(qpos) else 0.0

    def holds(self, name: str) -> bool:
        """Fingers on both sides (robosuite's grasp check), or the sucking cup in contact."""
        if self._specs[name].kind != "box":
            return False
        gripper, obj = self.robots[0].gripper[self.robots[0].arms[0]], self._objects[name]
        if isinstance(gripper, SuctionGripper):
            return self.gripper_opening() > 0.5 and bool(self.check_contact(gripper.important_geoms["cup"], obj))
        return bool(self._check_grasp(gripper=gripper, object_geoms=obj))

    # --------------------------------------------------------------- success
    def object_in_receptacle(self, obs: Observation, obj: str, receptacle: str) -> bool:
        spec = self._specs[receptacle]
        centre, state = obs.objects[receptacle].pos, obs.objects[obj]
        inner = np.array(spec.size[:2]) / 2 - 0.01
        inside_xy = bool(np.all(np.abs(state.pos[:2] - centre[:2]) < inner))
        below_rim = bool(state.pos[2] < centre[2] + spec.size[2])
        return inside_xy and below_rim and not state.grasped

    def subtask_success(self, subtask: str, args: dict[str, str], obs: Observation | None = None) -> bool:
        obs = obs or self.observe()
        if subtask == "put_in_bin":
            return self.object_in_receptacle(obs, args["obj"], args["receptacle"])
        raise KeyError(f"no success predicate for subtask {subtask!r}")

    def _check_success(self):
        obs = self.observe()
        return all(self.subtask_success(step.subtask, step.args, obs) for step in self.task_spec.plan)

    def reward(self, action=None):
        return float(self._check_success())
