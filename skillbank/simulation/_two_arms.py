"""Two-arm demonstrations recorded in robosuite: ``skillbank sim record robosuite:TwoArmLift``.

A scripted demonstrator drives both arms of a robosuite two-arm task at once, each with its own
operational-space controller, the way two people (or one with two hands on two SpaceMice) would: each
arm goes its own way at its own pace, and where the task needs both (a pot lifted by its two handles) the
one that is ready first waits for the other. What a task asks is data (:data:`TWO_ARM_TASKS`). The file
is robomimic's layout, as :func:`~skillbank.simulation.record` writes for one arm, with each arm's
observations under its prefix (``robot0_...``, ``robot1_...``), the arms' actions side by side and
``data.attrs["robots"]`` (each arm's :func:`~skillbank.simulation._robosuite.robot_frames`);
:func:`skillbank.io.read_robomimic` reads it as one demonstration per arm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import chain

import numpy as np

from ..io import robosuite_objects as _objects
from ..io import with_object_poses
from ._robosuite import CONTROL_FREQ, _closing_axis, _min_jerk, _pose, _turn, osc_action

__all__ = ["TWO_ARM_TASKS", "TwoArmTask", "two_arm_episode"]


@dataclass(frozen=True)
class TwoArmTask:
    """What the demonstrator does with two arms in one robosuite environment.

    ``obj``: the object both arms work on (its observation name). A lift: ``sites``, per arm, the site of
    the object's model it grasps; ``lift``, metres both raise the object together once every arm holds
    it. A handover: ``grip`` names a box geom of the object with two places to hold it, ``places``, each
    a fraction of its half length from its centre toward the geom ``toward`` (a hammer's handle, toward
    its head). Arm 0 grasps the place farther from arm 1, lifts it and turns it about the vertical so
    that the other place points at arm 1, halfway between the arms and ``meet`` metres above the
    table's top; arm 1 grasps that place; only then does arm 0 let go.
    """

    obj: str
    sites: tuple = ()
    lift: float = 0.0
    grip: str | None = None
    toward: str | None = None
    places: tuple = ()
    meet: float = 0.25


#: The robosuite two-arm tasks the recorder knows.
TWO_ARM_TASKS = {
    # the pot by its two handles, lifted together (robosuite checks its bottom 10 cm above the table)
    "TwoArmLift": TwoArmTask(obj="pot", sites=("pot_handle0", "pot_handle1"), lift=0.2),
    # the hammer picked by one end of its handle and handed over by the other (near the head or its free
    # end, whichever is nearer arm 1)
    # (robosuite checks that arm 1 holds the handle, arm 0 nothing, and the hammer 10 cm above the table;
    # a head held from above leaves no room for a finger beside the handle)
    "TwoArmHandover": TwoArmTask(obj="hammer", grip="hammer_handle", toward="hammer_head",
                                 places=(-0.7, 0.5), meet=0.25),
}


class _Arms:
    """Steps every arm of the environment at once toward its own targets, and keeps what robomimic
    records (each arm's observations under its prefix, the actions side by side)."""

    def __init__(self, env, obs):
        self.env, self.n = env, len(env.robots)
        self.obs = with_object_poses(env, obs)
        self.objects = _objects(self.obs)
        self.quat = [np.array(self.obs[f"robot{k}_eef_quat"], float) for k in range(self.n)]
        self.grip = [-1.0] * self.n  # open
        self.rows = {"obs": [], "actions": [], "rewards": [], "dones": [], "states": []}

    def tool(self, k) -> np.ndarray:
        return np.array(self.obs[f"robot{k}_eef_pos"], float)

    def _keys(self):
        keys = [f"robot{k}_{part}" for k in range(self.n)
                for part in ("eef_pos", "eef_quat", "joint_pos", "gripper_qpos")]
        return keys + [f"{o}_{part}" for o in self.objects for part in ("pos", "quat")]

    def step(self, targets):
        action = np.concatenate([osc_action(self.obs, f"robot{k}_", targets[k], self.quat[k], self.grip[k],
                                            robot.part_controllers["right"])
                                 for k, robot in enumerate(self.env.robots)])
        self.rows["states"].append(np.array(self.env.sim.get_state().flatten()))
        self.rows["obs"].append({k: np.array(self.obs[k], float) for k in self._keys()})
        obs, reward, done, _ = self.env.step(action)
        self.obs = with_object_poses(self.env, obs)
        self.rows["actions"].append(action)
        self.rows["rewards"].append(float(reward))
        self.rows["dones"].append(int(done))

    def run(self, moves):
        """Step every arm along its own moves (an iterator of tool targets per arm, ``None``: this arm
        holds) until all are done; an arm whose moves end first holds where it is."""
        moves = [iter(()) if m is None else iter(m) for m in moves]
        last = [self.tool(k) for k in range(self.n)]
        going = [True] * self.n
        while True:
            for k in range(self.n):
                if going[k]:
                    target = next(moves[k], None)
                    if target is None:
                        going[k] = False
                        last[k] = self.tool(k)
                    else:
                        last[k] = np.asarray(target, float)
            if not any(going):
                return
            self.step(list(last))

    def move(self, k, goal, steps, *, within=0.005, settle=CONTROL_FREQ):
        """Arm ``k``'s minimum-jerk move to ``goal`` (a generator: its targets, step by step), then up to
        ``settle`` steps more until its tool is ``within`` metres of it."""
        goal = np.asarray(goal, float)
        start = self.tool(k)
        for s in _min_jerk(steps)[1:]:
            yield start + s * (goal - start)
        for _ in range(int(settle)):
            if np.linalg.norm(goal - self.tool(k)) < within:
                return
            yield goal

    def hold(self, k, steps, grip=None):
        if grip is not None:
            self.grip[k] = grip
        here = self.tool(k)
        for _ in range(int(steps)):
            yield here


def _geom(env, name) -> tuple:
    """``(centre, turn, half sizes)`` of a box geom of the scene as it lies now."""
    i = env.sim.model.geom_name2id(name)
    turn = np.array(env.sim.data.geom_xmat[i], float).reshape(3, 3)
    return np.array(env.sim.data.geom_xpos[i], float), turn, np.array(env.sim.model.geom_size[i], float)


def _along(env, name, toward, fraction) -> np.ndarray:
    """The point of box geom ``name`` ``fraction`` of its half length from its centre toward geom
    ``toward`` along its longest axis."""
    centre, turn, half = _geom(env, name)
    a = int(np.argmax(half))
    axis = turn[:, a] if turn[:, a] @ (_geom(env, toward)[0] - centre) > 0 else -turn[:, a]
    return centre + fraction * half[a] * axis


def _across(env, name) -> np.ndarray:
    """The horizontal direction across a box geom's thinnest side that lies level: the way two fingers
    close on it from above."""
    _, turn, half = _geom(env, name)
    level = [a for a in range(3) if np.linalg.norm(turn[:2, a]) > 0.7]
    a = min(level, key=lambda a: half[a])
    d = turn[:, a] * [1, 1, 0]
    return d / np.linalg.norm(d)


def _close_along(env, arms, k, direction):
    """Turn arm ``k``'s tool about the vertical so that its fingers close along ``direction``."""
    closing = _closing_axis(env, k)
    a = math.atan2(direction[1], direction[0]) - math.atan2(closing[1], closing[0])
    arms.quat[k] = _turn(arms.quat[k], (a + math.pi / 2) % math.pi - math.pi / 2)


def _grasp(arms, k, at, steps, rng, *, above=0.12):
    """Arm ``k``'s moves to grasp at ``at`` from above: over it, down, close, let the fingers settle."""
    side = rng.uniform(0, 2 * math.pi)
    over = at + np.r_[0.03 * math.cos(side), 0.03 * math.sin(side), above + rng.uniform(-0.02, 0.02)]
    return chain(arms.move(k, over, steps(k, 1.6)), arms.hold(k, steps(k, rng.uniform(0.0, 0.4))),
                 arms.move(k, at + [0.0, 0.0, 0.04], steps(k, 0.8)),
                 arms.move(k, at, steps(k, 0.6), within=0.003),
                 arms.hold(k, steps(k, rng.uniform(0.4, 0.7)), grip=1.0))


def _handover(env, arms, task, steps, rng):
    """Arm 0 picks ``task.grip`` and presents it to arm 1, which takes it; then arm 0 lets go."""
    base = [np.asarray(r.base_pos, float) for r in env.robots]
    # arm 0 holds the place farther from arm 1: the turn that presents the other to arm 1 is under a
    # quarter turn (a half turn of the wrist meets the Panda's last joint's limit)
    give, take = sorted(task.places, key=lambda f: -np.linalg.norm(
        _along(env, task.grip, task.toward, f)[:2] - base[1][:2]))
    _close_along(env, arms, 0, _across(env, task.grip))
    at = _along(env, task.grip, task.toward, give) + [0.0, 0.0, rng.uniform(-0.004, 0.0)]
    arms.run([_grasp(arms, 0, at, steps, rng), None])
    # lift, and turn about the vertical so that the place arm 1 takes points at arm 1's base
    start = arms.tool(0)
    offset = (_along(env, task.grip, task.toward, take) - start) * [1, 1, 0]
    want = (base[1] - start) * [1, 1, 0]
    turn = math.atan2(want[1], want[0]) - math.atan2(offset[1], offset[0])
    turn = (turn + math.pi) % (2 * math.pi) - math.pi
    c, s_ = math.cos(turn), math.sin(turn)
    offset = np.array([c * offset[0] - s_ * offset[1], s_ * offset[0] + c * offset[1], 0.0])
    table = float(env.sim.data.site_xpos[env.sim.model.site_name2id("table_top")][2])
    # the two places straddle the point halfway between the arms' bases: each arm reaches as far (a
    # Panda reaches about 0.8 m; the bases of robosuite's handover stand 1.62 m apart)
    meet = (base[0] + base[1]) / 2 * [1, 1, 0] + [0.0, 0.0, table + task.meet] - offset / 2
    meet = meet + np.r_[rng.uniform(-0.02, 0.02, 2), 0.0]
    arms.run([arms.move(0, start + [0.0, 0.0, 0.12], steps(0, 1.0)), None])
    arms.quat[0] = _turn(arms.quat[0], turn)
    arms.run([chain(arms.move(0, meet, steps(0, 2.0)), arms.hold(0, steps(0, rng.uniform(0.3, 0.6)))), None])
    # arm 1 takes it where it is now
    at = _along(env, task.grip, task.toward, take) + [0.0, 0.0, rng.uniform(-0.004, 0.0)]
    _close_along(env, arms, 1, _across(env, task.grip))
    arms.run([None, _grasp(arms, 1, at, steps, rng, above=0.1)])
    # only then does arm 0 open and leave, back toward its base and up
    home = (base[0] - arms.tool(0)) * [1, 1, 0]
    away = arms.tool(0) + 0.12 * home / max(np.linalg.norm(home), 1e-9) + [0.0, 0.0, 0.06]
    arms.run([chain(arms.hold(0, steps(0, rng.uniform(0.3, 0.5)), grip=-1.0),
                    arms.move(0, away, steps(0, 1.0))), None])
    arms.run([None, chain(arms.move(1, arms.tool(1) + [0.0, 0.0, 0.05], steps(1, 0.8)),
                          arms.hold(1, steps(1, rng.uniform(0.3, 0.6))))])


def two_arm_episode(env, task: TwoArmTask, rng) -> tuple:
    """One scripted two-arm episode; ``(rows, success)``."""
    arms = _Arms(env, env.reset())
    # each arm's pace: two hands, or two people, seldom move alike
    speed = rng.uniform(0.7, 1.4, arms.n)

    def steps(k, seconds):
        return max(3, int(round(seconds * speed[k] * CONTROL_FREQ)))

    arms.run([arms.hold(k, steps(k, rng.uniform(0.3, 0.6))) for k in range(arms.n)])  # a look at the scene
    if task.grip is not None:
        _handover(env, arms, task, steps, rng)
        return arms.rows, bool(env._check_success())
    centre = np.array(arms.obs[f"{task.obj}_pos"], float)
    moves = []
    for k, site in enumerate(task.sites):
        if site is None:
            moves.append(None)
            continue
        at = _pose(env, "site", site)[:3, 3]
        # the fingers close along the line from the object's centre out to its handle: across the bar
        out = (at - centre) * [1, 1, 0]
        out = out / max(np.linalg.norm(out), 1e-9)
        closing = _closing_axis(env, k)
        a = math.atan2(out[1], out[0]) - math.atan2(closing[1], closing[0])
        arms.quat[k] = _turn(arms.quat[k], (a + math.pi / 2) % math.pi - math.pi / 2)
        along = np.cross([0.0, 0.0, 1.0], out)
        grasp = at + rng.uniform(-0.01, 0.01) * along + [0.0, 0.0, rng.uniform(-0.006, 0.0)]
        side = rng.uniform(0, 2 * math.pi)
        above = grasp + np.r_[0.03 * math.cos(side), 0.03 * math.sin(side), rng.uniform(0.08, 0.14)]
        moves.append(chain(arms.move(k, above, steps(k, 1.6)),
                           arms.hold(k, steps(k, rng.uniform(0.0, 0.4))),
                           arms.move(k, grasp + [0.0, 0.0, 0.04], steps(k, 0.8)),
                           arms.move(k, grasp, steps(k, 0.6), within=0.003),
                           arms.hold(k, steps(k, rng.uniform(0.4, 0.7)), grip=1.0)))
    arms.run(moves)  # the arm that holds its handle first waits for the other
    if task.lift:
        n = steps(int(np.argmax(speed)), 1.6)  # together: at the pace of the slower
        arms.run([None if site is None else arms.move(k, arms.tool(k) + [0.0, 0.0, task.lift], n)
                  for k, site in enumerate(task.sites)])
        arms.run([arms.hold(k, steps(k, rng.uniform(0.3, 0.6))) for k in range(arms.n)])
    return arms.rows, bool(env._check_success())
