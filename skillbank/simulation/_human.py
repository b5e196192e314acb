"""A human-like demonstrator: robosuite driven the way a person at a keyboard does (issue 42, item 5).

The scripted recorder (:mod:`._robosuite`) moves the tool along smooth minimum-jerk paths;
people do not. At a keyboard (or a SpaceMouse nudged) they press a key for one control step,
look, press again, stop to think, let the hand coast past the goal and press back, take the
object a few centimetres off its centre, sometimes close the gripper too early and try again.
:class:`HumanDemonstrator` is a closed-loop operator that does this: it watches the
observations (where the tool and the objects are, which way the fingers close) and emits
quantised ``OSC_POSE`` delta pulses, one axis at a time, with gaps, pauses and reaction time.
Its habits are keyword-only parameters whose defaults match robosuite's own teleoperated Lift
demonstrations (docs/simulation.md, "A human-like demonstrator"). All randomness comes from
``random_state``. :func:`record_human` (in ``_human_file``) writes its successful episodes in
robosuite's raw collection format through robosuite's ``DataCollectionWrapper``.
"""

from __future__ import annotations

import math

import numpy as np

from ..core._rotations import log_map, quaternion_conjugate, quaternion_multiply, quaternion_to_matrix
from ..core._validation import check_fraction, check_positive
from ._robosuite import (
    CONTROL_FREQ,
    TASKS,
    Task,
    _box,
    _closing_axis,
    _joint_now,
    _objects,
    _rotation,
    _turn_way,
    _yaw,
    with_object_poses,
)

__all__ = ["HumanDemonstrator"]

#: Control steps the environment's check must hold before the person stops (robosuite's collection
#: script ends a demonstration after 10 such steps).
SUCCESS_HOLD = 10
#: Control steps an episode may last at most (120 s at 20 Hz).
MAX_STEPS = 2400
#: Tasks of several objects, one demonstration moving each in turn (the tallest first: fingers closing
#: on a low object beside a tall one tip it over). Their parts are :data:`TASKS`' single-object tasks,
#: and robosuite's own check of the whole task says whether it was done.
MULTI_TASKS = {
    "PickPlace": tuple(TASKS[f"PickPlace{name}"] for name in ("Cereal", "Milk", "Can", "Bread")),
    "NutAssembly": (TASKS["NutAssemblySquare"],
                    Task(pick="RoundNut", site="RoundNut_handle_site", site_out=0.01, across=1, peg="peg2",
                         release=0.13)),
}
#: The farthest off centre (m) a grasp of these objects holds: a can (7.1 cm across) held 2-3 cm off
#: its axis slips out of the Panda's fingers as it is carried, a square nut's handle is 4 cm long.
OFF_CENTRE_LIMIT = {"Can": 0.015, "Milk": 0.01, "Bread": 0.01, "Cereal": 0.01, "SquareNut": 0.01}


class _Done(Exception):
    """The task has been done (the check held for :data:`SUCCESS_HOLD` steps), or time ran out."""


class _Lost(Exception):
    """What the person watches does not follow the keys (the object slipped out of the fingers)."""


def _wrap(angle: float, period: float) -> float:
    """``angle`` brought into ``(-period / 2, period / 2]``."""
    return float(angle - period * math.floor(angle / period + 0.5))


def _check_range(value, *, name: str, low: float = 0.0, high: float = math.inf, integer=False) -> tuple:
    """A ``(lo, hi)`` pair with ``low <= lo <= hi <= high``."""
    try:
        lo, hi = value
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a pair (low, high), got {value!r}") from None
    kind = "integers" if integer else "numbers"
    for v in (lo, hi):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not (
                math.isfinite(v) and low <= v <= high) or (integer and v != int(v)):
            raise ValueError(f"{name}: expected two {kind} in [{low}, {high}], low <= high, got {value!r}")
    if lo > hi:
        raise ValueError(f"{name}: expected low <= high, got {value!r}")
    return (int(lo), int(hi)) if integer else (float(lo), float(hi))


class HumanDemonstrator:
    """An operator at a keyboard: short command pulses, pauses, overshoot and correction.

    Parameters
    ----------
    pulse : float, default=1.0
        The translation command of a key press, as a fraction of the controller's largest step
        (robosuite's keyboard saturates it: 1).
    turn_pulse : float, default=0.6
        The rotation command of a key press. robosuite 1.5's controller turns the tool 0.017 rad for
        robosuite's keyboard's 0.15, where the recorded people's taps turned it 0.07 rad (robosuite
        1.4): 0.6 turns it 0.07 rad.
    pulse_steps : int, default=1
        Control steps a key is held down (a tap).
    gap : (int, int), default=(1, 3)
        Control steps between two taps of a run (drawn uniformly, both ends included).
    pause_probability : float, default=0.06
        After a tap, the chance that the person stops to look for ``pause`` seconds.
    pause : (float, float), default=(0.5, 2.5)
        Seconds of such a stop.
    reaction : (float, float), default=(0.3, 1.0)
        Seconds between the end of one run of taps and the next (the person looks and decides).
    start : (float, float), default=(1.5, 6.0)
        Seconds before the first tap (the objects settle; the person finds the scene).
    overshoot : float, default=0.02
        Metres a run may be carried past its goal (0.15 rad for a turn per 0.02 m); then corrected.
    overshoot_probability : float, default=0.5
        The chance that a long run overshoots.
    off_centre : (float, float), default=(0.01, 0.03)
        Metres off the grasp point's centre along the graspable axis (across the fingers' closing
        direction), either way.
    retry_probability : float, default=0.25
        The chance that the first grasp is closed too early (above the object); the person sees
        the object stay, opens and tries again.
    random_state : int or numpy Generator, optional
        Where every draw comes from.

    Examples
    --------
    >>> person = HumanDemonstrator(pause_probability=0.1, random_state=0)
    >>> person.off_centre
    (0.01, 0.03)
    """

    def __init__(self, *, pulse=1.0, turn_pulse=0.6, pulse_steps=1, gap=(1, 3), pause_probability=0.06,
                 pause=(0.5, 2.5), reaction=(0.3, 1.0), start=(1.5, 6.0), overshoot=0.02,
                 overshoot_probability=0.5, off_centre=(0.01, 0.03), retry_probability=0.25,
                 random_state=None):
        self.pulse, self.turn_pulse, self.pulse_steps, self.gap = pulse, turn_pulse, pulse_steps, gap
        self.pause_probability, self.pause = pause_probability, pause
        self.reaction, self.start = reaction, start
        self.overshoot, self.overshoot_probability = overshoot, overshoot_probability
        self.off_centre, self.retry_probability = off_centre, retry_probability
        self.random_state = random_state
        self.check()

    def check(self) -> HumanDemonstrator:
        """Check every parameter (one ValueError naming it); return self."""
        check_fraction(self.pulse, name="pulse", low=1e-3, high=1.0)
        check_fraction(self.turn_pulse, name="turn_pulse", low=1e-3, high=1.0)
        check_positive(self.pulse_steps, name="pulse_steps", integer=True)
        if self.pulse_steps > CONTROL_FREQ:
            raise ValueError(f"pulse_steps: expected at most {CONTROL_FREQ} (a second), got "
                             f"{self.pulse_steps!r}")
        _check_range(self.gap, name="gap", high=10 * CONTROL_FREQ, integer=True)
        check_fraction(self.pause_probability, name="pause_probability")
        for name in ("pause", "reaction", "start"):
            _check_range(getattr(self, name), name=name, high=60.0)
        check_fraction(self.overshoot, name="overshoot", high=0.1)
        check_fraction(self.overshoot_probability, name="overshoot_probability")
        _check_range(self.off_centre, name="off_centre", high=0.05)
        check_fraction(self.retry_probability, name="retry_probability")
        if not (self.random_state is None or isinstance(self.random_state, np.random.Generator) or (
                isinstance(self.random_state, (int, np.integer)) and not isinstance(self.random_state, bool)
                and self.random_state >= 0)):
            raise ValueError(f"random_state: expected a non-negative integer or a numpy Generator, got "
                             f"{self.random_state!r}")
        return self

    def episode(self, env, task, rng=None) -> bool:
        """Drive one episode of ``env`` (reset here) through ``task``; True when the task was done.

        ``env``: a robosuite environment with one arm and ``OSC_POSE`` delta control, possibly wrapped
        (robosuite's ``DataCollectionWrapper`` records what it is stepped with); ``task``: a
        :class:`~skillbank.simulation._robosuite.Task`, a tuple of them (several objects, one after
        the other), or a key of ``TASKS`` or :data:`MULTI_TASKS`; ``rng``: a numpy Generator
        (default: one from ``random_state``).
        """
        if isinstance(task, str):
            task = MULTI_TASKS[task] if task in MULTI_TASKS else TASKS[task]
        task = (task,) if isinstance(task, Task) else tuple(task)
        rng = np.random.default_rng(self.random_state) if rng is None else rng
        operator = _Operator(self, env, env.reset(), rng, limit=MAX_STEPS * len(task))
        try:
            operator.perform(task)
            while True:  # done moving: the person waits for the check, as robosuite's collection does
                operator.idle(1)
        except _Done:
            pass
        return operator.held >= SUCCESS_HOLD


class _Operator:
    """One episode's person: what it sees (the observations) and the keys it presses."""

    def __init__(self, habits: HumanDemonstrator, env, obs, rng, *, limit=MAX_STEPS):
        self.h, self.env, self.rng, self.limit = habits, env, rng, limit
        self.sim_env = getattr(env, "env", env)  # the environment under a wrapper
        self.obs = with_object_poses(self.sim_env, obs)
        self.objects = _objects(self.obs)
        # metres and radians per unit of the controller's input: how far a push of the puck goes
        self.scale = np.abs(np.asarray(self.sim_env.robots[0].part_controllers["right"].output_max, float))
        self.grip, self.steps, self.held, self.grasps = -1.0, 0, 0, 0
        # what the person has learnt of the arm: how far one tap moves it from rest, and how far it
        # coasts once the taps stop (translation in metres, rotation in radians), refined as it goes
        self.travel, self.coast = [0.015, 0.04], [0.01, 0.03]

    # -- what the person does with the keys ------------------------------------------------------
    def _step(self, action):
        obs, _, _, _ = self.env.step(action)
        self.obs = with_object_poses(self.sim_env, obs)
        self.steps += 1
        self.held = self.held + 1 if self.sim_env._check_success() else 0
        if self.held >= SUCCESS_HOLD or self.steps >= self.limit:
            raise _Done

    def idle(self, steps):
        action = np.zeros(7)
        action[6] = self.grip
        for _ in range(int(steps)):
            self._step(action)

    def wait(self, seconds):
        self.idle(max(1, int(round(self.rng.uniform(*seconds) * CONTROL_FREQ))))

    def tap(self, key: int, sign: float):
        puck = np.zeros(6)
        puck[key] = sign * (self.h.pulse if key < 3 else self.h.turn_pulse)
        self.push(puck, self.h.pulse_steps)

    def push(self, puck, steps: int, *, gap=True):
        """The puck of a SpaceMouse held at ``puck`` (six numbers in [-1, 1], the controller's input: moves
        along and turns about the world's axes; a key's tap is one of them) for ``steps`` control steps,
        then (``gap``) let go for a gap between taps, and now and then a pause to look."""
        action = np.zeros(7)
        action[:6] = np.asarray(puck, float)
        action[6] = self.grip
        for _ in range(int(steps)):
            self._step(action)
        if not gap:
            return
        self.idle(self.rng.integers(self.h.gap[0], self.h.gap[1] + 1))
        if self.rng.random() < self.h.pause_probability:
            self.wait(self.h.pause)

    def press_grip(self, closed: bool):
        self.grip = 1.0 if closed else -1.0
        self.idle(1)
        self.wait((0.6, 1.2))  # the fingers take their time; the person watches them

    # -- what the person sees ---------------------------------------------------------------------
    def tool(self) -> np.ndarray:
        return np.array(self.obs["robot0_eef_pos"], float)

    def at(self, name) -> np.ndarray:
        return np.array(self.obs[f"{name}_pos"], float)

    def closing(self) -> float:
        """The heading (rad) of the direction the fingers close along."""
        axis = _closing_axis(self.sim_env)
        return math.atan2(axis[1], axis[0])

    def settled(self, read, limit=CONTROL_FREQ):
        """Watch until ``read()`` stops changing (at most ``limit`` steps); its value then."""
        last = read()
        for _ in range(limit):
            self.idle(2)
            now = read()
            if abs(now - last) < 1e-3:
                return now
            last = now
        return last

    # -- a run of taps on one key, corrected until the quantity is within its goal ----------------
    def reach(self, key: int, read, goal: float, tol: float, *, period=None, overshoot=True, tries=5):
        """Tap ``key`` until ``read()`` is within ``tol`` of ``goal`` (or as near as one tap allows).

        ``read``: the quantity watched (a tool or object coordinate for keys 0-2, a heading for 3-5,
        which ``period`` wraps). The first run may carry past the goal (overshoot); then the person
        looks and taps back.
        """
        kind = 0 if key < 3 else 1

        def error(aim):
            e = aim - read()
            return _wrap(e, period) if period else e

        total = 0
        for attempt in range(tries):
            e = error(goal)
            if abs(e) <= max(tol, 0.55 * self.travel[kind]):
                return
            direction = 1.0 if e > 0 else -1.0
            aim = goal
            if overshoot and attempt == 0 and abs(e) > 3 * self.travel[kind] and (
                    self.rng.random() < self.h.overshoot_probability):
                beyond = self.h.overshoot * (1.0 if key < 3 else 7.5)  # 0.02 m, 0.15 rad
                aim = goal + direction * self.rng.uniform(0.3, 1.0) * beyond
            taps, before = 0, read()
            while direction * error(aim) > self.coast[kind] and taps < 60:
                self.tap(key, direction)
                taps += 1
                total += 1
                if (taps % 10 == 0 and abs(error(before)) < 2 * self.travel[kind]) or total > 80:
                    raise _Lost
            if taps == 0:  # within the coast of the goal, but not within tolerance: a single tap
                self.tap(key, direction)
                taps = 1
            last = read()
            after = self.settled(read)
            moved = after - last
            if period:
                moved = _wrap(moved, 2 * math.pi)
            self.coast[kind] = 0.5 * self.coast[kind] + 0.5 * max(0.0, direction * moved)
            if taps == 1:
                step = after - before
                self.travel[kind] = 0.5 * self.travel[kind] + 0.5 * abs(
                    _wrap(step, 2 * math.pi) if period else step)
            self.wait(self.h.reaction)

    def move(self, goal, *, keys=(0, 1, 2), watch=None, tol=0.006):
        """Bring the tool (or ``watch``, an object it holds) to ``goal`` key by key, in ``keys``' order."""
        def coordinate(k):
            return (lambda: float(self.at(watch)[k])) if watch else (lambda: float(self.tool()[k]))

        for k in keys:
            self.reach(k, coordinate(k), float(goal[k]), tol)

    # -- the task -----------------------------------------------------------------------------------
    def perform(self, tasks: tuple):
        self.wait(self.h.start)
        for k, task in enumerate(tasks):
            if k:
                self.wait(self.h.reaction)  # a look for the next object
            self.one(task)

    def one(self, task: Task):
        """Grasp the task's object and take it where it goes; again (up to three times) if it slips."""
        self.start_height = float(self.at(task.pick)[2])
        if task.turns:
            try:
                self.open(task)
            except _Lost:  # lost the part (a lever slipped out of the fingers): the person gives up
                raise _Done from None
            return
        for _ in range(3):
            try:
                self.grasp(task)
                if task.peg is not None:
                    self.assemble(task)
                elif task.into is not None:
                    self.sort(task)
                elif task.onto is not None:
                    self.stack(task)
                else:
                    self.lift(task)
                return
            except _Lost:  # it slipped: open, lift the hand, and take it again
                if self.grip > 0:
                    self.press_grip(False)
                self.tap(2, 1.0)
                self.wait(self.h.reaction)
        raise _Done

    def grasp_point(self, task: Task) -> tuple:
        """Where to grasp now, and the horizontal unit vector of the graspable axis."""
        target = self.at(task.pick)
        if task.site is not None:
            sim = self.sim_env.sim
            target = np.array(sim.data.site_xpos[sim.model.site_name2id(task.site)], float)
            out = (target - self.at(task.pick)) * [1, 1, 0]
            target = target + task.site_out * out / max(np.linalg.norm(out), 1e-9)
        # not so low that the palm comes down on a tall object's top (the Panda's is 3.7 cm above its
        # grip site: on the can, 8 cm tall, it pressed the can into the bin and flung it)
        sim = self.sim_env.sim
        geoms = [n for n in sim.model.geom_names if n and n.startswith(f"{task.pick}_g") and "vis" not in n]
        if geoms:
            target[2] = max(target[2], _box(sim, geoms)[1][2] - 0.03)
        c = self.closing()
        return target, np.array([-math.sin(c), math.cos(c), 0.0])

    def turn_to(self, task: Task):
        """Turn the wrist (taps about the vertical) until the fingers close on two of the object's faces."""
        q = self.obs[f"{task.pick}_quat"]
        if task.across is not None:
            goal, period = _yaw(q) + task.across * math.pi / 2, math.pi
        else:
            goal, period = _yaw(q), math.pi / 2
        self.reach(5, self.closing, goal, 0.15, period=period)  # roughly square: the fingers square it

    def grasp(self, task: Task):
        """Over the object, the wrist turned, down off its centre, closed; again while it is not held."""
        side = self.rng.choice([-1.0, 1.0])
        limit = OFF_CENTRE_LIMIT.get(task.pick, math.inf)
        self.off_range = (min(self.h.off_centre[0], 0.5 * limit), min(self.h.off_centre[1], limit))
        off = side * self.rng.uniform(*self.off_range)
        early = self.grasps == 0 and self.rng.random() < self.h.retry_probability
        self.grasps += 1
        order = (0, 1) if self.rng.random() < 0.5 else (1, 0)
        for attempt in range(3):
            if attempt == 0:
                target, _ = self.grasp_point(task)
                if self.grasps == 1:  # over it at the height the hand is, then down
                    self.move(target, keys=order, tol=0.01)
                else:  # high enough to pass over what it dropped it beside
                    self.move(target + [0, 0, 0.1], keys=(2,) + order, tol=0.01)
                self.turn_to(task)
            target, along = self.grasp_point(task)
            point = target + off * along
            self.move(point, keys=order, tol=0.006)
            self.move(point + [0, 0, 0.03], keys=(2,))
            self.off_centre(task, side)  # a look before the end: off centre as meant, centred across
            if not (early and attempt == 0):  # else it closes too early, 3 cm above: the fingers meet over it
                for _ in range(3):
                    self.move(point, keys=(2,), tol=0.006)
                    if self.tool()[2] < point[2] + 0.02:
                        break
                    self.tap(2, 1.0)  # a finger came down on the object: up, line up again, down
                    self.tap(2, 1.0)
                    self.off_centre(task, side)
            height = float(self.at(task.pick)[2])
            self.press_grip(True)
            self.tap(2, 1.0)
            self.tap(2, 1.0)
            self.settled(lambda: float(self.tool()[2]))
            if float(self.at(task.pick)[2]) > height + 0.01:
                return  # it came up with the hand
            self.press_grip(False)  # missed: open, look again, and go down again
            self.wait(self.h.reaction)
        raise _Done  # three misses: the person gives up (the episode is not kept)

    def off_centre(self, task: Task, side: float, across_tol=0.006):
        """Single taps until the tool is ``off_centre`` off the grasp point along the graspable axis (on
        ``side``) and within ``across_tol`` of it across: a person lines the fingers up by eye."""
        lo, hi = self.off_range
        for _ in range(6):
            target, along = self.grasp_point(task)
            across = np.array([along[1], -along[0], 0.0])
            rel = (self.tool() - target) * [1, 1, 0]
            s, c = side * float(rel @ along), float(rel @ across)
            if lo <= s <= hi and abs(c) <= across_tol:
                return
            if abs(c) > across_tol:
                axis, change = across, -c
            else:
                axis, change = side * along, 0.5 * (lo + hi) - s
            k = int(np.argmax(np.abs(axis[:2])))
            self.tap(k, 1.0 if change * axis[k] > 0 else -1.0)
            self.settled(lambda k=k: float(self.tool()[k]))
            self.wait(self.h.reaction)

    # -- a part of an articulated object: a door's handle pressed down, the door pulled open ------------
    def approach_axis(self) -> np.ndarray:
        """The direction the tool points (its z axis, world)."""
        return quaternion_to_matrix(np.asarray(self.obs["robot0_eef_quat"], float))[:, 2]

    def _joint(self, name) -> tuple:
        """``(axis, anchor, value)`` of a joint of the scene, as the person sees the part turn about it."""
        sim = self.sim_env.sim
        return _joint_now(sim, sim.model.joint_name2id(name))

    def open(self, task: Task):
        """Point the hand at the part, take it, and move it about each of its joints in turn.

        With key taps the person turns the wrist until it points at the door with the fingers across the
        lever, and comes in and closes; then works each joint with a SpaceMouse's pushes
        (:meth:`turn_part`).
        """
        sim = self.sim_env.sim
        site = lambda: np.array(sim.data.site_xpos[sim.model.site_name2id(task.site)], float)  # noqa: E731
        axis, anchor, _ = self._joint(task.turns[0][0])
        inward = axis if (anchor - site()) @ axis > 0 else -axis
        # the wrist turned down-to-forward (about the world's x), then about the vertical to face the door
        self.reach(3, lambda: math.atan2(self.approach_axis()[1], -self.approach_axis()[2]),
                   math.atan2(inward[1], -inward[2]), 0.08, period=2 * math.pi)
        self.reach(5, lambda: math.atan2(self.approach_axis()[1], self.approach_axis()[0]),
                   math.atan2(inward[1], inward[0]), 0.08, period=2 * math.pi)
        along = (anchor - site()) - inward * ((anchor - site()) @ inward)
        grasp = site() + along / max(np.linalg.norm(along), 1e-9) * (
            task.site_in + self.rng.uniform(-0.008, 0.008))
        k = int(np.argmax(np.abs(inward)))
        order = [i for i in (0, 2) if i != k] if self.rng.random() < 0.5 else [i for i in (2, 0) if i != k]
        self.move(grasp - self.rng.uniform(0.08, 0.12) * inward, keys=tuple(order) + (k,), tol=0.01)
        self.move(grasp, keys=tuple(order), tol=0.006)
        self.move(grasp, keys=(k,), tol=0.006)
        self.press_grip(True)
        for name, angle in task.turns:
            self.turn_part(task, name, angle * self.rng.uniform(0.95, 1.05), site)
        while True:  # the part where it was taken: the person holds it until the task is seen done
            self.idle(1)

    def turn_part(self, task: Task, name: str, angle: float, site):
        """Pushes that carry the held part ``angle`` radians about joint ``name`` (the way
        :func:`_turn_way` says: toward the side of its range with room, else the part's far end down).

        The person watches the part and pushes the puck toward where the hand would be with the part a
        little further on, moving and turning at once, until the part has gone ``angle`` or as far as it
        goes; a part that will not move ends the episode.
        """
        sim = self.sim_env.sim
        axis, anchor, start = self._joint(name)
        sign = _turn_way(sim, sim.model.joint_name2id(name), site())
        p0, q0 = self.tool(), np.asarray(self.obs["robot0_eef_quat"], float)
        reached = 0.0  # how far the hand has been asked to go: a person pushes on, never back
        best, since = 0.0, 0  # the furthest the part has gone, and the pushes since it went further
        for _ in range(600):
            _, _, value = self._joint(name)
            done = sign * (value - start)
            best, since = (done, 0) if done > best + 0.01 else (best, since + 1)
            # done; or as far as it goes (a lever pressed to where it stops): the person goes on
            if done >= angle or (since >= 8 and best >= 0.8 * angle):
                return
            # the hand leads the part (the fingers give a little): the person pushes on by a little at
            # each push, or to a little past where the part is, up to a little past the aim
            reached = min(1.15 * angle, max(reached + 0.04, done + 0.1))
            ahead = sign * reached
            turn = _rotation(axis, ahead)
            want_p = anchor + quaternion_to_matrix(turn) @ (p0 - anchor)
            want_q = quaternion_multiply(turn, q0)
            now_q = np.asarray(self.obs["robot0_eef_quat"], float)
            error = np.r_[want_p - self.tool(),
                          log_map(quaternion_multiply(want_q, quaternion_conjugate(now_q)))]
            # the part resists (a latch's spring): the person pushes the SpaceMouse's puck the way the hand
            # has to go, moving and turning at once, as far as the hand is off, and keeps it pushed (let
            # go, the spring takes the lever back), looking again every few steps; not quite the right way
            steps = int(self.rng.integers(2, 6))
            push = error / self.scale * (1.0 + self.rng.normal(scale=0.15, size=6))
            self.push(np.clip(push, -1.0, 1.0), steps, gap=False)
        raise _Done  # the part would not move: the person gives up

    def lift(self, task: Task):
        self.move([0, 0, self.start_height + task.lift], keys=(2,), watch=task.pick, tol=0.02)

    def _carry_to(self, task: Task, goal, above: float):
        """Up to ``above`` metres over the goal's height, across (watching the object), then down."""
        watch = task.pick
        height = max(float(goal[2]), float(self.at(watch)[2])) + above
        self.move([0, 0, height], keys=(2,), watch=watch, tol=0.02)
        order = (0, 1) if self.rng.random() < 0.5 else (1, 0)
        self.move(goal, keys=order, watch=watch, tol=0.006)

    def stack(self, task: Task):
        base = self.at(task.onto)
        goal = base + [0, 0, task.onto_height + 0.01]
        self._carry_to(task, goal, 0.1)
        self.move(goal, keys=(0, 1), watch=task.pick, tol=0.006)
        self.move(goal, keys=(2,), watch=task.pick, tol=0.006)
        self.press_grip(False)
        self.tap(2, 1.0)

    def sort(self, task: Task):
        places, ids, key = task.into
        goal = np.asarray(getattr(self.sim_env, places)[getattr(self.sim_env, ids)[key]], float)
        goal = goal + [0, 0, task.drop]
        self._carry_to(task, goal, 0.15)
        self.move(goal, keys=(2,), watch=task.pick, tol=0.015)
        self.press_grip(False)
        self.tap(2, 1.0)

    def assemble(self, task: Task):
        sim = self.sim_env.sim
        peg = np.array(sim.data.body_xpos[sim.model.body_name2id(task.peg)], float)
        self.move(self.tool() + [0, 0, 0.12], keys=(2,), tol=0.02)
        if task.align:  # turn the held nut square to the peg, watching the nut
            self.reach(5, lambda: _yaw(self.obs[f"{task.pick}_quat"]), 0.0, 0.06, period=task.align)
        goal = peg + [0, 0, task.release]
        self._carry_to(task, goal, 0.05)
        self.move(goal, keys=(2,), watch=task.pick, tol=0.01)
        for _ in range(3):  # a held nut swings and turns as the hand moves: look again, once it hangs still
            self.settled(lambda: float(self.at(task.pick)[0]) + float(self.at(task.pick)[1]))
            yaw = _yaw(self.obs[f"{task.pick}_quat"])
            if task.align and abs(_wrap(yaw, task.align)) > 0.08:
                self.reach(5, lambda: _yaw(self.obs[f"{task.pick}_quat"]), 0.0, 0.06, period=task.align)
            elif np.linalg.norm((self.at(task.pick) - goal)[:2]) < 0.006:
                break
            self.move(goal, keys=(0, 1), watch=task.pick, tol=0.004)
        self.press_grip(False)
        self.tap(2, 1.0)
