"""Free-space motion planning in joint space: OMPL's planners checked by the whole robot's clearance.

:func:`plan_motion` finds a joint path from one configuration to another
that keeps every body of the robot (its links' capsules, the mounted
gripper's and an object held in it) ``margin`` metres from the obstacles,
the table, the workspace bounds and itself. The search is OMPL's (the Open
Motion Planning Library, BSD-3-Clause, the planners MoveIt uses; extra
``plan``): RRTConnect by default, in the arm's joint space within its joint
limits, and the path is then shortened by OMPL's simplifier.

Every check is :func:`skillbank.robots.clearance`, the one collision test of
the robot. A state is valid when its smallest signed distance is at least
``margin``. A motion between two states (a straight segment in joint space)
is checked whole in one vectorised call, densified so that no body point
moves more than ``m`` between checked configurations; by the clearance bound
(its module docstring) every configuration of the segment is then at least
the smallest sampled distance minus ``m / 2`` clear. So a motion is valid
when its samples keep ``margin + m / 2``, invalid when one is nearer than
``margin``, and checked again with ``m`` four times smaller in between: ``m``
is ``4 max_move`` first (most motions are clearly free or clearly blocked),
then ``max_move``, then ``max_move / 4`` (a motion that leaves a state close
to an obstacle, as a press's start is to its button's table). The returned
path is measured again, densified at the default resolution, and refused if
it does not keep the margin (which the bound says cannot happen).

A held object is a :class:`~skillbank.core.Sphere` or :class:`~skillbank.core.Box` in the tool
frame: it becomes a capsule on the flange (a sphere exactly, a box the capsule that contains its
corners, :func:`enclosing_capsule`), checked against the world and the arm like the gripper's bodies.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field

import numpy as np

from ..core._obstacles import Box, Sphere
from ..core._validation import check_positive
from ._bodies import Capsule
from ._clearance import clearance
from ._description import enclosing_capsule

__all__ = ["MotionPlan", "MotionPlanningError", "plan_motion", "PLANNERS", "MOTION_TIME_LIMIT",
           "PLANNER_MAX_MOVE", "INSTALL_OMPL"]

#: OMPL planners :func:`plan_motion` can run, by name (OMPL's ``geometric`` class names). Not PRM: it grows
#: its roadmap on a second thread that calls the validity checks (Python callables); a PRM solve hung in
#: CI under load (2026-12-07: the test's thread asleep inside OMPL's ``solve`` for over 20 minutes).
PLANNERS = ("rrtconnect", "rrt", "kpiece", "bkpiece", "lbkpiece")
_OMPL_NAMES = {"rrtconnect": "RRTConnect", "rrt": "RRT", "kpiece": "KPIECE1", "bkpiece": "BKPIECE1",
               "lbkpiece": "LBKPIECE1"}
#: Seconds a search may take by default before it gives up.
MOTION_TIME_LIMIT = 5.0
#: Densification bound (m) of the motions the planner checks: a point of a body moves at most this much
#: between checked configurations, and states keep half of it more than the margin (module docstring).
PLANNER_MAX_MOVE = 0.02
#: A motion is checked first at this many times ``max_move``: clear by that bound, it is valid; a sample
#: nearer than the margin, it is not; else it is checked again this many times finer, down to
#: ``max_move / _COARSE`` (module docstring).
_COARSE = 4
#: Nearest other starts and goals tried in place of the path's ends (:func:`_nearer_ends`).
_END_TRIES = 8
#: The longest motion (rad, joint space) a search tree grows by (OMPL's range).
STEP = 1.0
#: Half-width (rad) of the box around the start and goal that the search samples in, within the limits:
#: no joint turns more than half a turn beyond the span of the two.
SPAN = np.pi
#: The one line that names what to install.
INSTALL_OMPL = "pip install 'skillbank[plan]'"


class MotionPlanningError(ValueError):
    """No collision-free joint path was found (or the start or goal is not clear): one line saying why."""


@dataclass
class MotionPlan:
    """A joint path found by :func:`plan_motion`.

    Attributes
    ----------
    joints : ndarray of shape (n, n_joints)
        The waypoints, from the start to the goal; consecutive ones are joined by straight joint-space
        segments, each checked whole.
    clearance : Clearance
        The whole robot's clearance along the path, densified at the default (fine) resolution.
    planner : str
        The OMPL planner that found it.
    planning_time, simplify_time : float
        Seconds the search and the simplification took.
    n_checked : int
        Motions the planner checked.
    notes : list of str
    """

    joints: np.ndarray
    clearance: object
    planner: str
    planning_time: float
    simplify_time: float
    n_checked: int = 0
    notes: list = field(default_factory=list)

    @property
    def length(self) -> float:
        """The path's length in joint space (rad, Euclidean)."""
        return float(np.linalg.norm(np.diff(self.joints, axis=0), axis=1).sum())


class _Holding:
    """A robot model with a held object's capsule added to its bodies (on the flange frame)."""

    def __init__(self, model, capsule):
        self._model, self._capsule = model, capsule

    def __getattr__(self, name):
        return getattr(self._model, name)

    @property
    def bodies(self):
        return tuple(self._model.bodies) + (self._capsule,)

    def self_collision_pairs(self):
        bodies = self.bodies
        held = self._capsule
        return tuple(self._model.self_collision_pairs()) + tuple(
            (b.name, held.name) for b in bodies[:-1] if abs(b.frame - held.frame) > 1)


def _held_capsule(model, held):
    """The held object (in the tool frame) as a capsule on the flange frame."""
    if not isinstance(held, (Sphere, Box)) or held.n_dims != 3:
        raise ValueError(f"held: expected a 3-D skillbank.core Sphere or Box in the tool frame, got {held!r}")
    tool = np.asarray(model.tool, dtype=float)
    if isinstance(held, Sphere):
        c = tool[:3, :3] @ held.center + tool[:3, 3]
        return Capsule("held", model.n_joints, tuple(c), tuple(c), float(held.radius))
    corners = np.array([[x, y, z] for x in (held.lower[0], held.upper[0]) for y in (held.lower[1],
                        held.upper[1]) for z in (held.lower[2], held.upper[2])])
    a, b, r = enclosing_capsule(corners @ tool[:3, :3].T + tool[:3, 3])
    return Capsule("held", model.n_joints, tuple(np.asarray(a, float)), tuple(np.asarray(b, float)), float(r))


def _ompl():
    try:
        from ompl import base, geometric, util  # optional extra 'plan': imported when a motion is planned
    except ImportError:
        raise ImportError(f"motion planning needs OMPL: {INSTALL_OMPL}") from None
    return base, geometric, util


def _nearer_ends(Q, starts, goals, valid, tries=_END_TRIES):
    """The path ``Q`` with its first and last waypoints replaced by the given start and goal nearest their
    neighbours (of those ``tries`` nearest) that the motion from the neighbour allows: the search takes
    whichever goal it meets first, which may be the same pose with a joint a whole turn further."""
    Q = Q.copy()
    for end, near, options in ((-1, -2, goals), (0, 1, starts)):
        if len(options) < 2 or len(Q) < 2:
            continue
        gap = np.linalg.norm(options - Q[near], axis=1)
        for k in np.argsort(gap, kind="stable")[:tries]:
            if gap[k] >= np.linalg.norm(Q[end] - Q[near]) - 1e-12:
                break
            if valid(np.stack([Q[near], options[k]])):
                Q[end] = options[k]
                break
    return Q


def _seed(random_state) -> int:
    """OMPL's seed (it ignores 0) from ``random_state`` (None: a fresh one)."""
    if random_state is None:
        return int(np.random.default_rng().integers(1, 2 ** 31 - 1))
    if isinstance(random_state, (bool, np.bool_)) or not isinstance(random_state, (int, np.integer)):
        raise ValueError(f"random_state: expected an integer seed or None, got {random_state!r}")
    return int(np.random.default_rng(int(random_state)).integers(1, 2 ** 31 - 1))


def _ompl_path(limits, starts, goals, state_ok, motion_ok, *, failure, span=SPAN, planner="RRTConnect",
               step=STEP, time_limit=MOTION_TIME_LIMIT, simplify=True, random_state=None):
    """A joint path from one of ``starts`` to one of ``goals`` found by OMPL and shortened by its simplifier:
    the one OMPL set-up of :func:`plan_motion` and of the simulation's transits, whatever checks them.

    Parameters
    ----------
    limits : array-like of shape (n_joints, 2)
        The joints' lower and upper limits.
    starts, goals : ndarray of shape (k, n_joints)
        Clear configurations, within the limits, of which any one will do; the path starts and ends on
        ones given, exactly.
    state_ok : callable
        ``state_ok(q) -> bool``: the configuration ``q (n_joints,)`` is clear.
    motion_ok : callable
        ``motion_ok(q_a, q_b) -> bool``: the straight joint-space motion from ``q_a`` to ``q_b`` is clear
        (checked whole: OMPL's own validator, which samples at a resolution, is not used).
    failure : callable
        ``failure() -> str``: the one-line message of the error raised when no path is found; called after
        the search, so that it can name what the checks ran into.
    span : float, default=SPAN
        Radians beyond the range of the starts and goals that a joint may take in the search (within the
        limits).
    planner : str, default="RRTConnect"
        The class name of an OMPL geometric planner.
    step : float, default=STEP
        The longest motion (rad) the search grows by, for planners that take one (OMPL's range).
    time_limit : float, default=MOTION_TIME_LIMIT
        Seconds the search may take.
    simplify : bool, default=True
        Shorten the path with OMPL's simplifier, every pass it makes (not cut by a clock); False: the
        path as the search found it.
    random_state : int, optional
        Seeds OMPL's random numbers (:func:`_seed`): the same seed and checks, the same path.

    Returns
    -------
    joints : ndarray of shape (n, n_joints)
        The waypoints, joined by straight motions each of which ``motion_ok`` allowed.
    planning_time, simplify_time : float
        Seconds the search took, and the simplification with the choice of ends.

    Raises
    ------
    MotionPlanningError
        ``failure()``: no path within the time limit.
    ImportError
        OMPL is not installed (one line naming the extra).
    """
    ob, og, ou = _ompl()
    ou.setLogLevel(ou.LOG_NONE)  # OMPL's own output is not ours to print; failures are raised below
    ou.RNG.setSeed(_seed(random_state))  # before the planner's samplers exist: they draw their seeds from it
    lo, hi = np.asarray(limits, dtype=float).T
    n = len(lo)
    space = ob.RealVectorStateSpace(n)
    bounds = ob.RealVectorBounds(n)
    both = np.concatenate([starts, goals])
    # within the limits and ``span`` beyond the range of the ends: no joint winds round further
    low = np.maximum(lo, both.min(axis=0) - span)
    high = np.minimum(hi, both.max(axis=0) + span)
    for j in range(n):
        bounds.setLow(j, float(low[j]))
        bounds.setHigh(j, float(max(high[j], low[j] + 1e-9)))  # OMPL refuses an empty range
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)

    def array(state):
        return np.fromiter((state[j] for j in range(n)), dtype=float, count=n)

    def valid(state):
        return state_ok(array(state))

    class _Motion(ob.MotionValidator):  # the caller's check, one call per motion
        def checkMotion(self, s1, s2, *last):
            return motion_ok(array(s1), array(s2))

    si.setStateValidityChecker(valid)
    validator = _Motion(si)  # held here for as long as OMPL calls it
    si.setMotionValidator(validator)
    si.setup()
    pdef = ob.ProblemDefinition(si)

    def state(q):
        out = si.allocState()
        for j in range(n):
            out[j] = float(q[j])
        return out

    # any start will do (a first step's pose), and any goal (every branch and turn of a pose)
    for q in starts:
        pdef.addStartState(state(q))
    ends = ob.GoalStates(si)
    for q in goals:
        ends.addState(state(q))
    pdef.setGoal(ends)
    search = getattr(og, planner)(si)
    if hasattr(search, "setRange"):  # the longest motion a tree grows by: short ones are cheap to check
        search.setRange(float(step))
    search.setProblemDefinition(pdef)
    search.setup()
    t0 = _time.perf_counter()
    search.solve(float(time_limit))
    planning_time = _time.perf_counter() - t0
    if not pdef.hasExactSolution():
        raise MotionPlanningError(failure())
    path = pdef.getSolutionPath()
    Q = np.array([array(path.getState(k)) for k in range(path.getStateCount())])
    # the start and the goal reached, exactly (not to round-off)
    Q[0] = starts[np.argmin(np.abs(starts - Q[0]).max(axis=1))]
    Q[-1] = goals[np.argmin(np.abs(goals - Q[-1]).max(axis=1))]
    t1 = _time.perf_counter()

    def pair_ok(pair):
        return motion_ok(pair[0], pair[1])

    Q = _nearer_ends(Q, starts, goals, pair_ok)
    if simplify:
        path = og.PathGeometric(si)
        for q in Q:
            path.append(state(q))
        # every pass OMPL's simplifier makes (each bounded by its own counts), never cut by a clock: a
        # simplifier stopped after so many seconds returns another path on a busy machine than on an
        # idle one (two workers against one, a loaded CI); seeded, the same path wherever it runs
        og.PathSimplifier(si).simplifyMax(path)
        kept = Q[[0, -1]]
        Q = np.array([array(path.getState(k)) for k in range(path.getStateCount())])
        Q[0], Q[-1] = kept  # the simplifier keeps the ends: exactly, not to round-off
        Q = _nearer_ends(Q, starts, goals, pair_ok)
    return Q, planning_time, _time.perf_counter() - t1


def plan_motion(model, q_start, q_goal, *, obstacles=None, table=None, workspace=None, held=None,
                margin=0.005, ignore=(), self_collision=True, planner="rrtconnect",
                time_limit=MOTION_TIME_LIMIT, max_move=PLANNER_MAX_MOVE, span=SPAN,
                simplify=True, step=STEP, random_state=None, label=None) -> MotionPlan:
    """A joint path from ``q_start`` to ``q_goal`` that keeps every body of the robot clear.

    Parameters
    ----------
    model : RobotModel
        With bodies (:attr:`RobotModel.bodies`).
    q_start, q_goal : array-like of shape (n_joints,) or (k, n_joints)
        Within the joint limits: one configuration, or several of which any one will do (the
        branches and whole turns of one pose); those not clear are left out, and the path starts and
        ends on ones given.
    obstacles : mapping of str to Obstacle, or sequence of Obstacle, optional
        3-D spheres and boxes in the world frame (:func:`clearance`'s).
    table : Box, optional
    workspace : (lower, upper) or Box, optional
    held : Sphere or Box, optional
        An object held by the tool, in the tool frame (module docstring); checked like a body.
    margin : float, default=0.005
        Metres every body keeps from everything it is checked against.
    ignore : iterable
        :func:`clearance`'s ``ignore``.
    self_collision : bool, default=True
    planner : {"rrtconnect", "rrt", "kpiece", "bkpiece", "lbkpiece"}
        OMPL's planner (RRTConnect, RRT, KPIECE1, BKPIECE1, LBKPIECE1 (lazy)).
    time_limit : float, default=MOTION_TIME_LIMIT
        Seconds the search may take.
    max_move : float, default=PLANNER_MAX_MOVE
        Densification bound (m) of the planner's checks (module docstring).
    span : float, default=SPAN
        Radians beyond the start's and goal's range that a joint may take in the search.
    simplify : bool, default=True
        Shorten the path by OMPL's simplifier (vertex reduction, shortcuts, smoothing: every pass, not
        cut by a clock, so that a seed gives the same path on any machine); False: the path as the
        search found it.
    step : float, default=STEP
        The longest motion (rad, in joint space) the search grows its trees by (OMPL's range).
    random_state : int, optional
        Seeds OMPL's random numbers: the same seed, the same path.
    label : callable, optional
        ``label(other)``: how an error names what a body came near (default its name).

    Returns
    -------
    MotionPlan

    Raises
    ------
    MotionPlanningError
        One line: the start or the goal not clear (the body and what it comes near), or no path found
        within the time limit (the start, the goal and the obstacle nearest the configurations the
        search reached).
    ImportError
        OMPL is not installed (one line naming the extra).

    Examples
    --------
    >>> from skillbank.core import Box
    >>> from skillbank.robots import robot_model
    >>> robot = robot_model("ur5e")
    >>> a, b = [0.5, -1.4, 1.6, -1.8, -1.57, 0.0], [2.6, -1.4, 1.6, -1.8, -1.57, 0.0]
    >>> wall = Box([-0.2, 0.1, 0.0], [0.2, 0.14, 0.6])  # in the way of the shoulder's turn
    >>> path = plan_motion(robot, a, b, obstacles={"wall": wall}, random_state=0)  # doctest: +SKIP
    >>> path.clearance.min_distance >= 0.005  # doctest: +SKIP
    True
    """
    label = label or (lambda other: other)
    margin = check_positive(margin, name="margin", allow_zero=True)
    max_move = check_positive(max_move, name="max_move")
    time_limit = check_positive(time_limit, name="time_limit")
    span = check_positive(span, name="span", allow_zero=True)
    step = check_positive(step, name="step")
    if not isinstance(simplify, (bool, np.bool_)):
        raise ValueError(f"simplify: expected True or False, got {simplify!r}")
    if planner not in PLANNERS:
        raise ValueError(f"planner: expected one of {list(PLANNERS)}, got {planner!r}")
    Q0 = model.check_joints(q_start, name="q_start")
    Q1 = model.check_joints(q_goal, name="q_goal")
    lo, hi = model.limits.T
    for name, Q in (("q_start", Q0), ("q_goal", Q1)):
        bad = np.argwhere((Q < lo) | (Q > hi))
        if bad.size:
            k, j = (int(x) for x in bad[0])
            raise ValueError(f"{name}: expected joints within the limits of robot {model.name}, got "
                             f"{model.joint_names[j]} = {Q[k, j]:.6g} rad outside [{lo[j]:.6g}, {hi[j]:.6g}]")
    robot = model if held is None else _Holding(model, _held_capsule(model, held))
    world = dict(obstacles=obstacles, table=table, workspace=workspace, ignore=ignore,
                 self_collision=self_collision)

    def where(q):
        return "[" + ", ".join(f"{v:.4g}" for v in q) + "]"

    def clear(name, Q):
        """The configurations that keep the margin; none: the first one's reason, in one line."""
        D = np.array([clearance(robot, q[None], **world) for q in Q], dtype=object)
        keep = np.array([res.min_distance >= margin for res in D])
        if keep.any():
            return Q[keep]
        res, q = D[0], Q[0]
        d = res.min_distance
        depth = f"{-d * 1000:.3g} mm into" if d < 0 else f"within {d * 1000:.3g} mm of"
        more = "" if len(Q) == 1 else f" (and the {len(Q) - 1} other {name} configuration(s) given)"
        raise MotionPlanningError(
            f"motion planning: the {name} {where(q)} is not clear{more}: the robot's {res.body} comes "
            f"{depth} {label(res.other)} (clearance margin {margin * 1000:g} mm)")

    Q0, Q1 = clear("start", Q0), clear("goal", Q1)
    q0, q1 = Q0[0], Q1[0]
    blocked = {}  # what the failed checks ran into: other -> [count, distance, body, q]
    checked = [0]

    def measure(Q):
        checked[0] += 1
        if Q.shape[0] == 1:  # a state: its distance is exact
            res = clearance(robot, Q, **world)
            if res.min_distance >= margin:
                return True
        else:  # a motion: coarse first, finer only where a sample is too near to tell (module docstring)
            move = _COARSE * max_move
            while True:
                res = clearance(robot, Q, max_move=move, **world)
                if res.min_distance >= margin + move / 2:
                    return True
                if res.min_distance < margin or move <= max_move / _COARSE:
                    break
                move /= _COARSE
        # the obstacle the search keeps running into is what blocks it: named in the failure
        seen = blocked.setdefault(res.other, [0, np.inf, None, None])
        seen[0] += 1
        if res.min_distance < seen[1]:
            seen[1:] = [res.min_distance, res.body, Q[res.index]]
        return False

    def failure():
        if not blocked:
            why = "no configuration it reached came near anything: the search ran out of time"
        else:
            other, (count, d, body, q) = max(blocked.items(), key=lambda item: item[1][0])
            depth = f"{-d * 1000:.3g} mm into" if d < 0 else f"within {d * 1000:.3g} mm of"
            why = (f"blocked by {label(other)} ({count} of the {checked[0]} motions checked ran into it; "
                   f"the robot's {body} came {depth} it at {where(q)})")
        others = [f" (or {len(Q) - 1} other configuration(s))" if len(Q) > 1 else "" for Q in (Q0, Q1)]
        return (f"motion planning: no collision-free path from {where(q0)}{others[0]} to "
                f"{where(q1)}{others[1]} found by OMPL {_OMPL_NAMES[planner]} in {time_limit:g} s: {why} "
                f"(clearance margin {margin * 1000:g} mm)")

    Q, planning_time, spent = _ompl_path(
        model.limits, Q0, Q1, lambda q: measure(q[None]), lambda a, b: measure(np.stack([a, b])),
        failure=failure, span=span, planner=_OMPL_NAMES[planner], step=step, time_limit=time_limit,
        simplify=bool(simplify), random_state=random_state)
    q0, q1 = Q[0], Q[-1]
    final = clearance(robot, Q, **world)
    if final.min_distance < margin:  # never a silent success: the bound says this cannot happen
        raise MotionPlanningError(
            f"motion planning: the path OMPL {_OMPL_NAMES[planner]} found from {where(q0)} to {where(q1)} "
            f"comes within {final.min_distance * 1000:.3g} mm of {label(final.other)} (the robot's "
            f"{final.body}; clearance margin {margin * 1000:g} mm)")
    return MotionPlan(joints=Q, clearance=final, planner=_OMPL_NAMES[planner], planning_time=planning_time,
                      simplify_time=spent, n_checked=checked[0])
