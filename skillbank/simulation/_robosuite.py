"""Demonstrations recorded in robosuite, in robomimic's HDF5 layout: ``skillbank sim record``.

A scripted demonstrator drives robosuite's UR5e (or another of its arms,
``robot=``), each with its default gripper (the UR5e's Robotiq 2F-85) and
operational-space controller (``OSC_POSE`` with delta inputs), the way a
person teleoperating would: it reaches above the object, comes down, closes
the gripper, lifts, carries and places, each move a minimum-jerk profile of
the tool point, the tool held at its start orientation. From episode to
episode the speed of every move, the pauses, the approach direction and the
grasp point vary (drawn from the seed), and only episodes that the
environment's own ``_check_success()`` accepts are kept.

What a task asks is data, not code: :data:`TASKS` names, per robosuite
environment, the object to pick (by its observation name, ``cube`` for
``cube_pos``) and where it goes (lifted by a height, or onto another
object). The recorder writes, per kept episode, ``data/demo_K`` with
``obs/`` (the tool pose ``robot0_eef_pos`` / ``robot0_eef_quat`` (x, y, z,
w), ``robot0_joint_pos``, ``robot0_gripper_qpos`` and every object's
``<name>_pos`` / ``<name>_quat``), ``actions``, ``rewards``, ``dones`` and
``states`` (MuJoCo's flattened state, so an episode can be replayed), and
the environment's arguments in ``data.attrs["env_args"]``, as robomimic
does; :func:`skillbank.io.read_robomimic` reads it back.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core import log_map, matrix_to_quaternion, quaternion_to_matrix
from ..core._pose_point import offset_pose_of
from ..core._rotations import quaternion_conjugate, quaternion_multiply
from ..core._validation import check_positive
from ..io import ROBOSUITE_POSE_OF, with_object_poses
from ..io import import_robosuite as import_quiet_robosuite
from ..io import robosuite_objects as _objects
from ..robots import pose_point

__all__ = ["TASKS", "record", "import_robosuite", "MISSING_ROBOSUITE", "CONTROL_FREQ", "RECORD_ROBOTS",
           "robosuite_robot", "recorded_robot"]

MISSING_ROBOSUITE = "sim record needs robosuite: pip install 'skillbank[sim]'"
#: Control steps per second (robosuite's default, and robomimic's datasets').
CONTROL_FREQ = 20


@dataclass(frozen=True)
class Task:
    """What the demonstrator does in one robosuite environment.

    ``pick``: the object to grasp (its observation name). ``lift``: metres to
    raise it (a lifting task); ``onto``: the object it is put on (a stacking
    task), the picked object's centre ``onto_height`` metres above its centre when it rests on it; ``into``:
    the name of the environment's attribute that lists its objects' places
    and the key of this one (a sorting task: ``target_bin_placements``
    indexed by ``object_to_id``), where it is let go ``drop`` metres above;
    ``peg``: a body the object goes over (an assembly task), let go with its
    centre ``release`` metres above the body's centre, turned about the
    vertical to a multiple of ``align`` radians first (a square hole on a
    square peg). ``site``: where to grasp (a site of the model, default the
    object's position), ``site_out`` metres further from the object's centre;
    ``across``: the object's axis (0, 1) the fingers
    close along (default: any two faces). ``turns``: an articulated object's joints (names in the
    simulator's model) the grasped part is moved about, in order, each by its angle (rad) toward the
    side of its range with room (a latch's lever pressed down, a door pulled open); the part is
    approached along the first joint's axis and grasped ``site_in`` metres in from its ``site``
    toward that axis.
    """

    pick: str
    lift: float = 0.0
    onto: str | None = None
    onto_height: float = 0.0
    into: tuple | None = None
    drop: float = 0.0
    site: str | None = None
    site_out: float = 0.0
    across: int | None = None
    peg: str | None = None
    release: float = 0.0
    align: float = 0.0
    turns: tuple = ()
    site_in: float = 0.0


#: The robosuite tasks the recorder knows (their objects are robosuite's own).
TASKS = {
    "Lift": Task(pick="cube", lift=0.15),
    "Stack": Task(pick="cubeA", onto="cubeB", onto_height=0.045),  # robosuite's 2 cm and 2.5 cm half-cubes
    "PickPlaceCan": Task(pick="Can", into=("target_bin_placements", "object_to_id", "can"), drop=0.08),
    "PickPlaceMilk": Task(pick="Milk", into=("target_bin_placements", "object_to_id", "milk"), drop=0.08),
    "PickPlaceBread": Task(pick="Bread", into=("target_bin_placements", "object_to_id", "bread"), drop=0.08),
    "PickPlaceCereal": Task(pick="Cereal", into=("target_bin_placements", "object_to_id", "cereal"),
                            drop=0.08),
    # the square nut by its handle (3.2 cm across its y axis), 1 cm out along it, clear of the ring, onto
    # the square peg (its top 0.1 m above the peg's centre)
    "NutAssemblySquare": Task(pick="SquareNut", site="SquareNut_handle_site", site_out=0.01, across=1,
                              peg="peg1", release=0.13, align=math.pi / 2),
    # robosuite's latched door: the lever pressed down past the latch (its tip clears the frame at about
    # 1.2 rad), then the door pulled about its hinge to its stop (0.4 rad; opened past 0.3)
    "Door": Task(pick="handle", site="Door_handle", site_in=0.03, turns=(("Door_latch_joint", 1.4),
                                                                           ("Door_hinge", 0.42))),
}


def import_robosuite():
    """The ``robosuite`` module, its set-up log off, or an ImportError of one line naming the extra."""
    return import_quiet_robosuite(MISSING_ROBOSUITE)


def parse_env(spec: str, known=None) -> str:
    """The task of ``robosuite:TASK``, checked against ``known`` (default the names of :data:`TASKS`).

    Examples
    --------
    >>> parse_env("robosuite:Lift")
    'Lift'
    """
    known = sorted(TASKS) if known is None else list(known)
    if not isinstance(spec, str) or not spec.startswith("robosuite:"):
        raise ValueError(f"env: expected robosuite:TASK (TASK one of {known}), got {spec!r}")
    task = spec.split(":", 1)[1]
    if task not in known:
        raise ValueError(f"env: the recorder knows robosuite tasks {known}, got {task!r}")
    return task


def _min_jerk_at(s):
    """The minimum-jerk profile at phases ``s`` in [0, 1]."""
    return 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5


def _min_jerk(n: int) -> np.ndarray:
    return _min_jerk_at(np.linspace(0.0, 1.0, max(int(n), 2)))


def osc_action(obs, prefix, target, quat, grip, controller) -> np.ndarray:
    """One arm's ``OSC_POSE`` delta action (and gripper command ``grip``) that moves its tool, observed as
    ``prefix + "eef_pos"`` / ``"eef_quat"``, toward position ``target`` and orientation ``quat`` (world).

    ``controller``: the arm's controller. Its ``output_max`` is the metres and radians one unit of input
    moves; its inputs are in the arm's base frame (robosuite's ``input_ref_frame="base"``, its
    ``origin_ori``): the same as the world's for an arm standing square to it, a quarter turn off for
    each arm of a two-arm task facing the other.
    """
    scale = np.abs(np.asarray(controller.output_max, float))
    base = getattr(controller, "origin_ori", None)
    turn = np.eye(3) if base is None or getattr(controller, "input_ref_frame", "base") != "base" else \
        np.asarray(base, float).reshape(3, 3)
    pos_err = turn.T @ (np.asarray(target, float) - obs[prefix + "eef_pos"])
    rot_err = turn.T @ log_map(quaternion_multiply(quat, quaternion_conjugate(obs[prefix + "eef_quat"])))
    return np.concatenate([np.clip(pos_err / scale[:3], -1, 1), np.clip(rot_err / scale[3:], -1, 1), [grip]])


class _Driver:
    """Steps the environment towards tool targets with OSC deltas, and keeps what robomimic records."""

    def __init__(self, env, obs, *, keep=True):
        """``obs``: the observations of the episode's reset; ``keep``: keep the rows robomimic records."""
        obs = with_object_poses(env, obs)  # a door's and its handle's turns, where robosuite shows none
        self.env, self.objects, self.keep = env, _objects(obs), keep
        self.obs = obs
        self.quat = np.array(self.obs["robot0_eef_quat"], float)  # held all episode
        self.rows = {"obs": [], "actions": [], "rewards": [], "dones": [], "states": []}
        self.grip = -1.0  # open

    def step(self, target):
        obs = self.obs
        action = osc_action(obs, "robot0_", target, self.quat, self.grip,
                            self.env.robots[0].part_controllers["right"])
        if self.keep:
            self.rows["states"].append(np.array(self.env.sim.get_state().flatten()))
            self.rows["obs"].append({k: np.array(obs[k], float) for k in self._keys()})
        obs, reward, done, _ = self.env.step(action)
        self.obs = with_object_poses(self.env, obs)
        if not self.keep:
            return
        self.rows["actions"].append(action)
        self.rows["rewards"].append(float(reward))
        self.rows["dones"].append(int(done))

    def posture(self, joints):
        """Keep the arm's spare joints at ``joints`` while its tool is driven (an arm of seven joints).

        robosuite's operational-space controller moves the tool and spends what the arm's redundancy
        leaves on holding the joints it was reset to: a planned move driven by its tool poses alone ended
        on the Panda 0.3 rad from the joints the plan had checked for clearance, so the check no longer
        said anything about the arm. The joints the plan passes through are the posture it holds instead.
        An arm of six joints has nothing to spare and is not changed. The controller is built again at
        each reset, with its own posture.
        """
        self.env.robots[0].part_controllers["right"].update_initial_joints(np.asarray(joints, float))

    def _keys(self):
        keys = ["robot0_eef_pos", "robot0_eef_quat", "robot0_joint_pos", "robot0_gripper_qpos"]
        return keys + [f"{o}_{part}" for o in self.objects for part in ("pos", "quat")]

    def move(self, goal, steps, *, within=0.005, settle=CONTROL_FREQ):
        """A minimum-jerk move to ``goal``, then up to ``settle`` steps more until the tool is ``within``
        metres of it (the controller lags the profile; the next move starts where the tool is)."""
        goal = np.asarray(goal, float)
        start = np.array(self.obs["robot0_eef_pos"], float)
        for s in _min_jerk(steps)[1:]:
            self.step(start + s * (goal - start))
        for _ in range(int(settle)):
            if np.linalg.norm(goal - self.obs["robot0_eef_pos"]) < within:
                break
            self.step(goal)

    def hold(self, steps, grip=None):
        if grip is not None:
            self.grip = grip
        here = np.array(self.obs["robot0_eef_pos"], float)
        for _ in range(int(steps)):
            self.step(here)


def _yaw(q) -> float:
    x, y, z, w = (float(v) for v in q)
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def _pads(env, arm: int = 0) -> np.ndarray:
    """The left finger pad's centre less the right's (m, world frame), from robosuite's pad geoms; ``arm``:
    which of the scene's arms."""
    geoms = _gripper(env, arm).important_geoms
    pad = {side: np.mean([env.sim.data.geom_xpos[env.sim.model.geom_name2id(n)]
                          for n in geoms[f"{side}_fingerpad"]], axis=0) for side in ("left", "right")}
    return pad["left"] - pad["right"]


def _gripper(env, arm: int = 0):
    """The robot's gripper model (robosuite keeps one per arm, by side, for some robots)."""
    gripper = env.robots[arm].gripper
    return gripper["right"] if isinstance(gripper, dict) else gripper


def _box(sim, geoms) -> tuple:
    """``(lo, hi)``: the world-aligned box (m) around the collision geoms ``geoms`` (names or ids) as they
    lie now.

    MuJoCo keeps each geom's box in the geom's own frame (``geom_aabb``: centre and half sizes); turned
    into the world, a box's half sizes along the world's axes are the absolute rotation times its own.
    """
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for name in geoms:
        i = int(name) if isinstance(name, int | np.integer) else sim.model.geom_name2id(name)
        turn = np.asarray(sim.data.geom_xmat[i], float).reshape(3, 3)
        box = np.asarray(sim.model.geom_aabb[i], float)
        centre = np.asarray(sim.data.geom_xpos[i], float) + turn @ box[:3]
        half = np.abs(turn) @ box[3:]
        lo, hi = np.minimum(lo, centre - half), np.maximum(hi, centre + half)
    return lo, hi


def _closing_axis(env, arm: int = 0) -> np.ndarray:
    """The horizontal direction the gripper closes along, from its finger pads."""
    axis = _pads(env, arm) * [1, 1, 0]
    return axis / max(np.linalg.norm(axis), 1e-9)


def _turn(q, angle) -> np.ndarray:
    """``q`` turned by ``angle`` about the vertical."""
    return quaternion_multiply(np.array([0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2)]),
                               np.asarray(q, float))


def _across(tool_q, object_q, closing, axis) -> np.ndarray:
    """``tool_q`` turned about the vertical so the gripper closes along the object's ``axis`` (0 or 1)."""
    want = _yaw(object_q) + axis * math.pi / 2
    have = math.atan2(closing[1], closing[0])
    a = (want - have + math.pi / 2) % math.pi - math.pi / 2  # either way along it: at most a quarter turn
    return _turn(tool_q, a)


#: m: how far a 4 cm cube's top stands above where it is grasped, the object the approach's heights were
#: set for (:func:`_episode`)
CUBE_TOP = 0.02


def _facing(tool_q, object_q, closing, neighbours=()) -> np.ndarray:
    """``tool_q`` turned about the vertical so the gripper closes on two faces of the object.

    The turns that align it with the object's faces differ by quarter turns; the smallest is taken,
    unless another object stands near (``neighbours``, horizontal offsets from the object within
    0.12 m): then the one whose fingers open away from the nearest, as a person would.
    """
    a = (_yaw(object_q) + math.pi / 4) % (math.pi / 2) - math.pi / 4
    turns = [a, a + math.pi / 2, a - math.pi / 2]
    near = [np.asarray(v, float) * [1, 1, 0] for v in neighbours if np.linalg.norm(np.asarray(v)[:2]) < 0.12]
    if near:
        towards = min(near, key=np.linalg.norm)
        towards = towards / max(np.linalg.norm(towards), 1e-9)

        def along(turn):  # how much the fingers, turned, open towards the neighbour
            c, s_ = math.cos(turn), math.sin(turn)
            turned = [c * closing[0] - s_ * closing[1], s_ * closing[0] + c * closing[1], 0.0]
            return abs(float(towards @ turned))

        a = min(turns, key=lambda turn: (round(along(turn), 1), abs(turn)))
    turn = np.array([0.0, 0.0, math.sin(a / 2), math.cos(a / 2)])
    return quaternion_multiply(turn, np.asarray(tool_q, float))


def _rotation(axis, angle) -> np.ndarray:
    """The quaternion of a turn by ``angle`` about the unit ``axis``."""
    return np.r_[np.asarray(axis, float) * math.sin(angle / 2), math.cos(angle / 2)]


def _joint_now(sim, j) -> tuple:
    """``(axis, anchor, value)`` of joint ``j`` of the scene as it stands: its axis and a point on it in
    the world, and its position."""
    return (np.array(sim.data.xaxis[j], float), np.array(sim.data.xanchor[j], float),
            float(sim.data.qpos[sim.model.jnt_qposadr[j]]))


def _turn_way(sim, j, site) -> float:
    """+1 or -1: the way a demonstrator turns joint ``j``: toward the side of its range with room (a door
    pulled open from its stop); with room both ways, so that the part's far end ``site`` goes down (a
    lever is pressed, not lifted)."""
    axis, anchor, value = _joint_now(sim, j)
    low, high = (float(v) for v in sim.model.jnt_range[j])
    if abs((high - value) - (value - low)) > 1e-6:
        return 1.0 if high - value > value - low else -1.0
    return 1.0 if np.cross(axis, np.asarray(site, float) - anchor)[2] < 0 else -1.0


def _articulated(driver, env, task: Task, rng, steps):
    """Grasp an articulated object's part and move it about its joints (``task.turns``), in order.

    The recorder reads the joints from the simulator's model (a script knows the scene; what a skill
    learns is found from the recorded poses alone, :func:`skillbank.core.fit_joint`). The gripper comes
    in along the first joint's axis, its fingers closing across the part's height, and each turn moves
    the tool along the joint's arc with the part.
    """
    model, data = env.sim.model, env.sim.data
    site = np.array(data.site_xpos[model.site_name2id(task.site)], float)
    joints = [model.joint_name2id(name) for name, _ in task.turns]
    axis, anchor, _ = _joint_now(env.sim, joints[0])
    inward = axis if (anchor - site) @ axis > 0 else -axis
    along = (anchor - site) - inward * ((anchor - site) @ inward)  # from the part's end toward its joint
    grasp = site + along / max(np.linalg.norm(along), 1e-9) * (task.site_in + rng.uniform(-0.005, 0.005))
    # the tool's approach axis (its z) turned onto ``inward``, its closing direction onto the vertical
    R0 = quaternion_to_matrix(driver.quat)
    closing = _pads(env)
    closing = closing - R0[:, 2] * (closing @ R0[:, 2])
    closing /= max(np.linalg.norm(closing), 1e-9)
    up = np.array([0.0, 0.0, 1.0])
    turn = np.c_[inward, up, np.cross(inward, up)] @ np.c_[R0[:, 2], closing, np.cross(R0[:, 2], closing)].T
    driver.quat = matrix_to_quaternion(turn @ R0)
    driver.move(grasp - rng.uniform(0.10, 0.14) * inward, steps(2.0))
    driver.hold(steps(rng.uniform(0.2, 0.5)))
    driver.move(grasp - 0.03 * inward, steps(0.8))
    driver.move(grasp, steps(0.8), within=0.003)
    driver.hold(steps(rng.uniform(0.4, 0.7)), grip=1.0)
    for j, (_, angle) in zip(joints, task.turns, strict=True):
        axis, anchor, _ = _joint_now(env.sim, j)
        angle = _turn_way(env.sim, j, site) * angle * rng.uniform(0.95, 1.05)
        q0, p0 = driver.quat.copy(), np.array(driver.obs["robot0_eef_pos"], float)
        for s in _min_jerk(steps(2.0 * abs(angle)))[1:]:
            driver.quat = quaternion_multiply(_rotation(axis, s * angle), q0)
            driver.step(anchor + _axis_turn(axis, s * angle) @ (p0 - anchor))
        driver.hold(steps(rng.uniform(0.1, 0.3)))
        site = np.array(data.site_xpos[model.site_name2id(task.site)], float)
    driver.hold(steps(rng.uniform(0.3, 0.5)), grip=-1.0)
    driver.move(np.array(driver.obs["robot0_eef_pos"], float) - 0.08 * inward, steps(0.8))


def _axis_turn(axis, angle) -> np.ndarray:
    """The rotation matrix of a turn by ``angle`` about the unit ``axis``."""
    return quaternion_to_matrix(_rotation(axis, angle))


def _episode(env, task: Task, rng) -> tuple:
    """One scripted episode; ``(rows, success)``."""
    driver = _Driver(env, env.reset())
    speed = rng.uniform(0.7, 1.4)  # the person's pace, this episode

    def steps(seconds):
        return max(3, int(round(seconds * speed * CONTROL_FREQ)))

    driver.hold(max(3, int(rng.uniform(0.3, 0.6) * CONTROL_FREQ)))  # a look at the scene: objects settle
    if task.turns:
        _articulated(driver, env, task, rng, steps)
        return driver.rows, bool(env._check_success())
    target = np.array(driver.obs[f"{task.pick}_pos"], float)
    if task.site is not None:
        target = np.array(env.sim.data.site_xpos[env.sim.model.site_name2id(task.site)], float)
        out = (target - driver.obs[f"{task.pick}_pos"]) * [1, 1, 0]
        target = target + task.site_out * out / max(np.linalg.norm(out), 1e-9)  # clear of the object's body
    # the wrist turns to the object's faces (its turn about the vertical, modulo a quarter turn): a
    # parallel gripper closes on two faces, not on two edges
    others = [np.asarray(driver.obs[f"{o}_pos"], float) - target for o in driver.objects if o != task.pick]
    if task.across is not None:
        driver.quat = _across(driver.quat, driver.obs[f"{task.pick}_quat"], _closing_axis(env), task.across)
    else:
        driver.quat = _facing(driver.quat, driver.obs[f"{task.pick}_quat"], _closing_axis(env), others)
    grasp = target + np.r_[rng.uniform(-0.006, 0.006, 2), rng.uniform(-0.004, 0.002)]
    # the heights below are a 4 cm cube's (its top 2 cm above where it is grasped): a taller object (a
    # cereal box's top 7.5 cm above its centre) is approached as much higher, so that the last move comes
    # straight down past its top, not slanting through it from the side the approach came from
    from ._support import object_top  # the scene's geometry, read where it is read for every use

    top = object_top(env, task.pick)
    taller = 0.0 if top is None else max(0.0, top - target[2] - CUBE_TOP)
    side = rng.uniform(0, 2 * math.pi)
    above = grasp + np.r_[0.04 * math.cos(side), 0.04 * math.sin(side), rng.uniform(0.10, 0.16) + taller]
    driver.move(above, steps(1.6))  # the approach comes from a side that varies ...
    driver.hold(steps(rng.uniform(0.0, 0.4)))
    driver.move(grasp + [0.0, 0.0, 0.05 + taller], steps(0.8))  # ... and ends straight down onto the object
    driver.move(grasp, steps(0.8))
    driver.hold(steps(rng.uniform(0.4, 0.7)), grip=1.0)  # close and let the fingers settle
    if task.peg is not None:
        peg = np.array(env.sim.data.body_xpos[env.sim.model.body_name2id(task.peg)], float)
        driver.move(driver.obs["robot0_eef_pos"] + [0.0, 0.0, 0.15], steps(1.0))
        # turn the object to the peg's square while it is held: the held offset turns with the wrist
        for _ in range(3 if task.align else 0):  # a held object can slip as it turns: look and turn again
            yaw = _yaw(driver.obs[f"{task.pick}_quat"])
            turn = -(((yaw + task.align / 2) % task.align) - task.align / 2)
            if abs(turn) < 0.02:
                break
            driver.quat = _turn(driver.quat, turn)
            driver.hold(steps(0.8))
        held = np.array(driver.obs[f"{task.pick}_pos"], float) - driver.obs["robot0_eef_pos"]
        over = peg - held + [0.0, 0.0, task.release]
        lift = float(driver.obs["robot0_eef_pos"][2])
        driver.move(over * [1, 1, 0] + [0.0, 0.0, lift], steps(1.6))
        driver.move(over + [0.0, 0.0, 0.03], steps(0.8))
        driver.move(over, steps(0.6), within=0.002)
        driver.hold(steps(rng.uniform(0.3, 0.5)), grip=-1.0)
        driver.move(driver.obs["robot0_eef_pos"] + [0.0, 0.0, 0.1], steps(0.8))
    elif task.into is not None:
        places, ids, key = task.into
        goal = np.asarray(getattr(env, places)[getattr(env, ids)[key]], float)
        held = np.array(driver.obs[f"{task.pick}_pos"], float) - driver.obs["robot0_eef_pos"]
        over = goal - held * [1, 1, 0] + np.r_[rng.uniform(-0.01, 0.01, 2), 0.0]
        lift = max(float(driver.obs["robot0_eef_pos"][2]), float(goal[2])) + rng.uniform(0.15, 0.2)
        driver.move(driver.obs["robot0_eef_pos"] * [1, 1, 0] + [0.0, 0.0, lift], steps(1.0))
        driver.move(over * [1, 1, 0] + [0.0, 0.0, lift], steps(1.8))
        driver.move(over + [0.0, 0.0, task.drop - held[2]], steps(1.0))
        driver.hold(steps(rng.uniform(0.3, 0.5)), grip=-1.0)
        driver.move(driver.obs["robot0_eef_pos"] + [0.0, 0.0, 0.1], steps(0.8))
    elif task.onto is None:
        driver.move(grasp + [0.0, 0.0, task.lift], steps(1.4))
        driver.hold(steps(rng.uniform(0.3, 0.6)))
    else:
        base = np.array(driver.obs[f"{task.onto}_pos"], float)
        held = np.array(driver.obs[f"{task.pick}_pos"], float) - driver.obs["robot0_eef_pos"]
        place = base + [0.0, 0.0, task.onto_height + 0.004] - held  # the tool, with the object 4 mm above
        driver.move(driver.obs["robot0_eef_pos"] + [0.0, 0.0, 0.1], steps(0.8))
        driver.move(place + [0.0, 0.0, 0.05], steps(1.5))
        driver.move(place, steps(0.8))
        driver.hold(steps(rng.uniform(0.3, 0.5)), grip=-1.0)
        driver.move(place + [0.0, 0.0, 0.08], steps(0.8))
    return driver.rows, bool(env._check_success())


#: robosuite's single-arm robots the recorder drives (each with its default gripper and OSC_POSE).
RECORD_ROBOTS = ("UR5e", "Panda", "Sawyer", "IIWA", "Jaco", "Kinova3", "XArm7")


def robosuite_robot(robot) -> str:
    """``robot`` as robosuite spells its arm (:data:`RECORD_ROBOTS`), whatever its case: ``"panda"`` ->
    ``"Panda"``, ``"ur5e"`` -> ``"UR5e"``; one line listing the arms for anything else.

    Examples
    --------
    >>> robosuite_robot("panda"), robosuite_robot("UR5E"), robosuite_robot("xarm7")
    ('Panda', 'UR5e', 'XArm7')
    """
    key = robot.strip().lower() if isinstance(robot, str) else None
    for name in RECORD_ROBOTS:
        if name.lower() == key:
            return name
    raise ValueError(f"robot: expected one of robosuite's single arms {list(RECORD_ROBOTS)} (any case), got "
                     f"{robot!r}")


def _robot_name(value) -> str | None:
    """An arm's name from what a recording says: a name, ``{"name": ...}`` (``data.attrs["robot"]``) or
    robomimic's ``env_args`` (``{"env_kwargs": {"robots": [...]}}``), as JSON text or parsed."""
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    if isinstance(value, str) and value.lstrip().startswith("{"):
        try:
            value = json.loads(value)
        except ValueError:
            return None
    if isinstance(value, dict):
        if "name" in value:
            return _robot_name(value["name"])
        robots = (value.get("env_kwargs") or {}).get("robots") if isinstance(value.get("env_kwargs"), dict) \
            else None
        return _robot_name(robots[0]) if isinstance(robots, list) and robots else None
    return value.strip() if isinstance(value, str) and value.strip() else None


def recorded_robot(demo) -> str | None:
    """The arm a demonstration was recorded on, or None where nothing says.

    From its metadata: ``arm`` (the robomimic and raw robosuite readers keep the arm the file names),
    else ``robot`` (a name or ``{"name": ...}``) or ``env_args``. Never from a file at a path the
    metadata holds: a library's rows do not make a command open files.

    Examples
    --------
    >>> from skillbank.core import Demonstration
    >>> recorded_robot(Demonstration([0.0, 1.0], {"x": [[0.0], [1.0]]}, {"robot": {"name": "Panda"}}))
    'Panda'
    """
    meta = getattr(demo, "metadata", None) or {}
    for key in ("arm", "robot", "env_args"):
        name = _robot_name(meta.get(key))
        if name is not None:
            return name
    return None


def _pose(env, kind: str, name: str) -> np.ndarray:
    """A body's or site's pose (4 x 4) in robosuite's world."""
    data, model = env.sim.data, env.sim.model
    T = np.eye(4)
    if kind == "body":
        i = model.body_name2id(name)
        T[:3, :3], T[:3, 3] = np.asarray(data.xmat[i]).reshape(3, 3), data.xpos[i]
    else:
        i = model.site_name2id(name)
        T[:3, :3], T[:3, 3] = np.asarray(data.site_xmat[i]).reshape(3, 3), data.site_xpos[i]
    return T


def robot_frames(env, arm: int = 0) -> dict:
    """Where the recorded arm stands and what its tool pose is: ``{"name", "base", "flange", "tool"}``.

    ``base``: the arm's base body (``robot0_base``) in the world; ``tool``: the pose the observations
    report, in the flange body (``robot0_right_hand``). robosuite 1.5 takes ``robot0_eef_pos`` from the
    gripper's grip site and ``robot0_eef_quat`` from the end-effector *body* (its issue 298), so the
    tool is the grip site's position with that body's orientation. With them a robot model's
    ``fk(robot0_joint_pos)`` is the recorded tool pose (``robot_model("panda", base=..., tool=...)``;
    docs/robots.md).
    """
    robot = env.robots[arm]
    prefix = robot.robot_model.naming_prefix  # robot0_, robot1_, ...
    gripper = robot.gripper["right"] if isinstance(robot.gripper, dict) else robot.gripper
    site = gripper.important_sites["grip_site"]
    eef = robot.robot_model.eef_name
    eef = eef["right"] if isinstance(eef, dict) else eef
    flange = np.linalg.inv(_pose(env, "body", f"{prefix}right_hand"))
    tool = flange @ _pose(env, "body", eef)
    tool[:3, 3] = (flange @ _pose(env, "site", site))[:3, 3]
    # the point by its name when robosuite's is the gripper's registered grip site (checked, not assumed)
    named = ROBOSUITE_POSE_OF.get(str(robot.name).lower())
    same = named is not None and np.abs(pose_point(named).transform - tool).max() < 1e-6
    pose_of = named if same else offset_pose_of(tool)
    return {"name": robot.name, "base": _pose(env, "body", f"{prefix}base").tolist(),
            "flange": "right_hand", "tool": tool.tolist(), "pose_of": pose_of}


def _env_args(task: str, horizon: int, seed: int, robot: str = "UR5e", arms: int = 1) -> dict:
    # robosuite 1.5 draws every placement from its own generator, seeded here
    kwargs = {"robots": [robot] * arms, "control_freq": CONTROL_FREQ, "horizon": horizon, "seed": seed,
              "has_renderer": False, "has_offscreen_renderer": False, "use_camera_obs": False,
              "ignore_done": True, "reward_shaping": False}
    if arms > 1:
        kwargs["env_configuration"] = "opposed"  # robosuite's default for two arms, said in the file
    return {"env_name": task, "type": 1, "env_version": None, "env_kwargs": kwargs}


def record(env: str, *, episodes: int, out, seed: int = 0, max_tries=None, progress=None,
           robot: str = "UR5e") -> dict:
    """Record ``episodes`` successful scripted demonstrations of robosuite task ``env`` into ``out``.

    Parameters
    ----------
    env : str
        ``robosuite:TASK``, TASK a key of :data:`TASKS`, or of
        :data:`~skillbank.simulation._two_arms.TWO_ARM_TASKS` (both arms, ``robot`` each).
    episodes : int
        Successful episodes to keep.
    out : path-like
        The HDF5 file written (robomimic's layout); it must not exist. Written whole or not at all.
    seed : int, default=0
        Seeds robosuite's object placement and the demonstrator's variations.
    max_tries : int, optional
        Episodes run at most (default ``3 * episodes``); fewer successes are an error.
    progress : callable, optional
        ``progress(kept, tried)`` after each episode.
    robot : str, default="UR5e"
        robosuite's arm (:data:`RECORD_ROBOTS`), with its default gripper. The file's
        ``data.attrs["robot"]`` (JSON, :func:`robot_frames`) says where it stood and which tool
        frame its poses are of; with two arms, ``data.attrs["robots"]`` lists both.

    Returns
    -------
    dict
        ``{"env", "episodes", "tried", "seed", "out", "samples", "robot"}``.
    """
    from ._two_arms import TWO_ARM_TASKS, two_arm_episode  # it builds on this module's driver

    task = parse_env(env, sorted(TASKS) + sorted(TWO_ARM_TASKS))
    two = task in TWO_ARM_TASKS
    robot = robosuite_robot(robot)
    episodes = check_positive(episodes, name="episodes", integer=True)
    tries = 3 * episodes if max_tries is None else check_positive(max_tries, name="max_tries", integer=True)
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed: expected a non-negative integer, got {seed!r}")
    out = Path(out)
    if out.exists():
        raise ValueError(f"out: {out} exists; give a new file")
    if not out.parent.is_dir():
        raise ValueError(f"out: the folder {out.parent} does not exist")
    suite = import_robosuite()
    import h5py  # core dependency; only when a file is written

    horizon = 1000
    args = _env_args(task, horizon, int(seed), robot, arms=2 if two else 1)
    rng = np.random.default_rng(seed)
    environment = suite.make(task, **args["env_kwargs"])
    kept, tried = [], 0
    frames = None
    try:
        while len(kept) < episodes and tried < tries:
            rows, ok = (two_arm_episode(environment, TWO_ARM_TASKS[task], rng) if two else
                        _episode(environment, TASKS[task], rng))
            tried += 1
            if ok:
                kept.append(rows)
            if progress is not None:
                progress(len(kept), tried)
        # fixed transforms, read after the episodes: an extra reset would move robosuite's placements
        frames = [robot_frames(environment, k) for k in range(len(environment.robots))]
    finally:
        environment.close()
    if len(kept) < episodes:
        raise ValueError(f"{env}: only {len(kept)} of {tried} scripted episodes succeeded, {episodes} were "
                         "asked; nothing was written (try another --seed)")
    part = out.with_name(out.name + ".part")
    try:
        with h5py.File(part, "w") as h5:
            data = h5.create_group("data")
            data.attrs["env_args"] = json.dumps(args)
            if two:
                data.attrs["robots"] = json.dumps(frames)
            else:
                data.attrs["robot"] = json.dumps(frames[0])
            total = 0
            for k, rows in enumerate(kept):
                g = data.create_group(f"demo_{k}")
                n = len(rows["actions"])
                g.attrs["num_samples"] = n
                total += n
                obs = g.create_group("obs")
                for key in rows["obs"][0]:
                    obs.create_dataset(key, data=np.stack([o[key] for o in rows["obs"]]))
                g.create_dataset("actions", data=np.stack(rows["actions"]))
                g.create_dataset("rewards", data=np.asarray(rows["rewards"], float))
                g.create_dataset("dones", data=np.asarray(rows["dones"], np.int64))
                g.create_dataset("states", data=np.stack(rows["states"]))
            data.attrs["total"] = total
        part.replace(out)
    except BaseException:
        part.unlink(missing_ok=True)
        raise
    return {"env": env, "episodes": len(kept), "tried": tried, "seed": int(seed), "out": str(out),
            "samples": int(total), "robot": robot}
