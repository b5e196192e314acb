"""Several arms of one robosuite environment, each driven by its own executor, stepped together.

robosuite steps a two-arm task with both arms' actions at once. Each arm's skills are run by the one-arm
executor (:func:`skillbank.simulation._evaluate._run_segments`), in a thread of its own, against an
:class:`ArmEnv`: the environment as that arm sees it (its robot, its observations under ``robot0_``, its
seven action columns). An arm's step hands its action to :class:`Lockstep` and waits; once every arm
still running has handed one in, the environment steps with all of them and every arm goes on. The
threads never run at the same time, so an episode is the same whatever the scheduler does; an arm whose
skills are done holds still (its gripper as it left it) while the others go on.
"""

from __future__ import annotations

import re
import threading

import numpy as np

from ..io import with_object_poses

__all__ = ["Lockstep", "ArmEnv", "arm_obs"]

_ROBOT = re.compile(r"^robot(\d+)_(.*)$")


def arm_obs(obs, k) -> dict:
    """The observations as arm ``k`` sees them: its own under ``robot0_``, no other arm's, every object's.

    Examples
    --------
    >>> sorted(arm_obs({"robot0_eef_pos": 0, "robot1_eef_pos": 1, "pot_pos": 2}, 1).items())
    [('pot_pos', 2), ('robot0_eef_pos', 1)]
    """
    out = {}
    for key, value in obs.items():
        m = _ROBOT.match(key)
        if m is None:
            out[key] = value
        elif int(m.group(1)) == k:
            out["robot0_" + m.group(2)] = value
    return out


class Stopped(Exception):
    """Raised in an arm's thread when the episode ended for another reason (another arm failed)."""


class Lockstep:
    """The one environment, stepped once every running arm has handed in its action."""

    def __init__(self, env, obs, n: int):
        self.env, self.n = env, n
        self.obs = with_object_poses(env, obs)
        self.cond = threading.Condition()
        self.pending = [None] * n
        self.running = [True] * n
        self.rest = [np.r_[np.zeros(6), -1.0] for _ in range(n)]  # what an arm that is done hands in
        self.steps = 0
        self.stopped = False
        #: the segment each arm has come to (its gate reached), the number of its segments when done
        self.reached = [0] * n

    def act(self, k, action):
        """Arm ``k``'s action for this step; the observations after the step, once every arm has acted."""
        with self.cond:
            if self.stopped:
                raise Stopped
            self.pending[k] = np.asarray(action, float)
            step = self.steps
            self._step_if_all()
            while self.steps == step and not self.stopped:
                self.cond.wait()
            if self.steps == step:
                raise Stopped
            return self.obs

    def done(self, k, grip):
        """Arm ``k`` runs no more; it holds still with the gripper commanded ``grip``."""
        with self.cond:
            self.running[k] = False
            self.rest[k] = np.r_[np.zeros(6), float(grip)]
            self._step_if_all()
            self.cond.notify_all()

    def stop(self):
        """End the episode for every arm (one failed)."""
        with self.cond:
            self.stopped = True
            self.cond.notify_all()

    def _step_if_all(self):
        waiting = any(r and p is None for r, p in zip(self.running, self.pending, strict=True))
        if not any(self.running) or waiting:
            return
        if all(p is None for p in self.pending):
            return
        action = np.concatenate([p if r and p is not None else rest
                                 for p, r, rest in zip(self.pending, self.running, self.rest, strict=True)])
        self.obs = with_object_poses(self.env, self.env.step(action)[0])
        self.pending = [None] * self.n
        self.steps += 1
        self.cond.notify_all()


class ArmEnv:
    """The environment as arm ``k`` sees it: its robot only, its observations under ``robot0_``, its
    actions stepped together with the other arms' (:class:`Lockstep`); everything else is the
    environment's own."""

    def __init__(self, env, k: int, lockstep: Lockstep):
        self._env, self.k, self.lockstep = env, int(k), lockstep
        self.robots = [env.robots[self.k]]

    def __getattr__(self, name):
        return getattr(self._env, name)

    def step(self, action):
        return arm_obs(self.lockstep.act(self.k, action), self.k), 0.0, False, {}
