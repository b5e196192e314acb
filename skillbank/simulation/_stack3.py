"""``Stack3``: three cubes on robosuite's table, to be stacked in an order the goal gives.

robosuite's ``Stack`` puts one cube on another; this task, built from
robosuite's own parts (its table arena, box objects, placement sampler and
contact checks), asks for a tower of three. The cubes are the same size, 4.5
cm, so that a cube on a cube stands as high as robosuite's 4 cm cube on its 5
cm one: demonstrations of ``Stack`` show the placement this task needs, onto
any cube. ``order`` names the tower from the top; success, in robosuite's
style, is every cube touching the one it is meant to stand on and above it,
the lowest on the table, the top one let go.

The class is defined when :func:`stack3_class` is first called (robosuite,
the ``sim`` extra, is imported then); defining it registers ``Stack3`` with
robosuite's ``make``.
"""

from __future__ import annotations

import numpy as np

from ._robosuite import import_robosuite

__all__ = ["stack3_class", "CUBES", "HALF_SIZE"]

CUBES = ("cubeA", "cubeB", "cubeC")
HALF_SIZE = 0.0225  # m: 0.02 + 0.025 = 2 x 0.0225, Stack's cube-on-cube height
_CLASS = []


def stack3_class():
    """The ``Stack3`` environment class (registered with robosuite when first made)."""
    if _CLASS:
        return _CLASS[0]
    import_robosuite()
    # robosuite's parts, only when a simulation is made (the sim extra)
    from robosuite.environments.manipulation.manipulation_env import ManipulationEnv
    from robosuite.models.arenas import TableArena
    from robosuite.models.objects import BoxObject
    from robosuite.models.tasks import ManipulationTask
    from robosuite.utils.observables import Observable, sensor
    from robosuite.utils.placement_samplers import UniformRandomSampler
    from robosuite.utils.transform_utils import convert_quat

    class Stack3(ManipulationEnv):
        """Three cubes to stack, ``order`` from the top (default cubeA on cubeB on cubeC)."""

        def __init__(self, robots, *, order=CUBES, table_full_size=(0.8, 0.8, 0.05),
                     table_friction=(1.0, 5e-3, 1e-4), use_object_obs=True, reward_scale=1.0,
                     reward_shaping=False, placement_initializer=None, **kwargs):
            self.order = tuple(order)
            self.table_full_size, self.table_friction = table_full_size, table_friction
            self.table_offset = np.array((0, 0, 0.8))
            self.use_object_obs, self.reward_scale = use_object_obs, reward_scale
            self.reward_shaping = reward_shaping
            self.placement_initializer = placement_initializer
            super().__init__(robots=robots, **kwargs)

        def reward(self, action=None):
            return float(self._check_success()) * (self.reward_scale or 1.0)

        def _load_model(self):
            super()._load_model()
            xpos = self.robots[0].robot_model.base_xpos_offset["table"](self.table_full_size[0])
            self.robots[0].robot_model.set_base_xpos(xpos)
            arena = TableArena(table_full_size=self.table_full_size, table_friction=self.table_friction,
                               table_offset=self.table_offset)
            arena.set_origin([0, 0, 0])
            colours = {"cubeA": [1, 0, 0, 1], "cubeB": [0, 0.8, 0, 1], "cubeC": [0, 0.3, 1, 1]}
            self.cubes = {name: BoxObject(name=name, size_min=[HALF_SIZE] * 3, size_max=[HALF_SIZE] * 3,
                                          rgba=colours[name]) for name in CUBES}
            cubes = list(self.cubes.values())
            if self.placement_initializer is not None:
                self.placement_initializer.reset()
                self.placement_initializer.add_objects(cubes)
            else:
                # a wider square than Stack's (+-8 cm): three cubes with room between them
                self.placement_initializer = UniformRandomSampler(
                    name="ObjectSampler", mujoco_objects=cubes, x_range=[-0.1, 0.1], y_range=[-0.1, 0.1],
                    rotation=None, ensure_object_boundary_in_range=False, ensure_valid_placement=True,
                    reference_pos=self.table_offset, z_offset=0.01, rng=self.rng)
            self.model = ManipulationTask(mujoco_arena=arena,
                                          mujoco_robots=[robot.robot_model for robot in self.robots],
                                          mujoco_objects=cubes)

        def _setup_references(self):
            super()._setup_references()
            self.cube_body_ids = {name: self.sim.model.body_name2id(cube.root_body)
                                  for name, cube in self.cubes.items()}

        def _reset_internal(self):
            super()._reset_internal()
            if not self.deterministic_reset:
                for pos, quat, obj in self.placement_initializer.sample().values():
                    self.sim.data.set_joint_qpos(obj.joints[0], np.r_[pos, quat])

        def _setup_observables(self):
            observables = super()._setup_observables()
            if not self.use_object_obs:
                return observables

            def pose_sensors(name):
                body = self.cube_body_ids[name]

                @sensor(modality="object")
                def pos(obs_cache):
                    return np.array(self.sim.data.body_xpos[body])

                @sensor(modality="object")
                def quat(obs_cache):
                    return convert_quat(np.array(self.sim.data.body_xquat[body]), to="xyzw")

                return {f"{name}_pos": pos, f"{name}_quat": quat}

            for name in CUBES:
                for key, fn in pose_sensors(name).items():
                    observables[key] = Observable(name=key, sensor=fn, sampling_rate=self.control_freq)
            return observables

        def _check_success(self):
            """The tower stands as ``order`` says: each cube on the next, the last on the table."""
            gripper = self.robots[0].gripper
            z = {n: float(self.sim.data.body_xpos[self.cube_body_ids[n]][2]) for n in CUBES}
            for upper, lower in zip(self.order[:-1], self.order[1:], strict=True):
                if not (self.check_contact(self.cubes[upper], self.cubes[lower])
                        and z[upper] > z[lower] + HALF_SIZE):
                    return False
            bottom = self.order[-1]
            on_table = z[bottom] < self.table_offset[2] + 2 * HALF_SIZE
            top = self.cubes[self.order[0]]
            return bool(on_table and not self._check_grasp(gripper=gripper, object_geoms=top))

    _CLASS.append(Stack3)
    return Stack3
