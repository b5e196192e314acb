"""Planned transits: a step's free-space move found by the motion planner when the skill's own is not clear.

A step is first reproduced as before: its skill's primitive adapted from the
demonstration (with the whole-arm repairs), or the scene's hand-written
transit (up, across, down). When that cannot keep the robot clear, and the
plan runs with the motion planner (``planner="ompl"``, the default; ``plan
--planner``), the step's move to its goal is planned in joint space instead
by :func:`skillbank.robots.plan_motion` (OMPL's RRTConnect, every body of the
arm, the gripper and the scene checked by :func:`skillbank.robots.clearance`),
from the configuration the previous step ended in to a clear configuration
over the goal, and a straight approach line brings the tool onto the goal
(the binding's ``approach``, else :data:`PLANNED_APPROACH` along the tool's
axis). Like the hand-written transit, the planned one carries the step's
move in place of the primitive; the gripper and other recorded streams are
the primitive's, as with a transit.
"""

from __future__ import annotations

import numpy as np

from ..core import quaternion_to_matrix
from ..robots import MotionPlanningError, plan_motion, time_law
from ._start import clear_starts

__all__ = ["PLANNERS", "PLANNED_APPROACH", "planned_end", "planned_transit",
           "TRANSIT_JOINT_SPEED"]

#: ``planner`` values of :func:`~skillbank.planning.plan_task` (``plan --planner``): ``"ompl"`` plans a
#: step's move with OMPL when the skill's own (and the hand-written transit) is not clear; ``"none"``
#: refuses such a step, as before the planner.
PLANNERS = ("ompl", "none")
#: Metres above the goal (along the tool's axis) where a planned transit ends when the binding gives no
#: approach: the last of the move is a straight line onto the goal, as a press needs.
PLANNED_APPROACH = 0.05
#: Peak joint speed (rad/s) of a planned transit's segments, unless the robot's limits are lower.
TRANSIT_JOINT_SPEED = 1.0
#: Most configurations of one pose taken at whole turns of its joints (:func:`_turns`).
MAX_TURNS = 64
#: Sample spacing (s) of a planned transit.
_DT = 0.01


def planned_end(goal, goal_q, near):
    """Where a planned transit ends: the binding's approach point, else :data:`PLANNED_APPROACH` above the
    goal along the tool's axis (straight up without an orientation)."""
    if near is not None:
        return np.asarray(near, dtype=float)
    axis = np.array([0.0, 0.0, -1.0]) if goal_q is None else quaternion_to_matrix(
        np.asarray(goal_q, dtype=float)[None])[0][:, 2]
    return np.asarray(goal, dtype=float) - PLANNED_APPROACH * axis


def _timed(model, Q, duration, joint_speed):
    """The waypoints ``Q`` sampled along the straight joint segments between them, on a time base each
    segment minimum-jerk from rest to rest: the samples :func:`planned_transit` gives the time law.

    A segment lasts long enough that no joint exceeds ``joint_speed`` (rad/s, per joint) and that the
    tool point's path meets ``duration(length)`` (the chain's rule for a straight piece of that length);
    it has a sample per :data:`_DT` of that duration, denser towards the waypoints.
    """
    ts, qs, offset = [np.zeros(1)], [Q[:1]], 0.0
    for a, b in zip(Q[:-1], Q[1:], strict=True):
        dq = b - a
        probe = a + np.linspace(0.0, 1.0, 33)[:, None] * dq
        length = float(np.linalg.norm(np.diff(model.fk(probe)[0], axis=0), axis=1).sum())
        T = max(duration(length), float((1.875 * np.abs(dq) / joint_speed).max()))
        n = max(11, int(np.ceil(T / _DT)) + 1)
        tau = np.linspace(0.0, 1.0, n)
        s = tau ** 3 * (10.0 - 15.0 * tau + 6.0 * tau ** 2)
        seg = a + s[:, None] * dq
        seg[-1] = b
        ts.append(offset + tau[1:] * T)
        qs.append(seg[1:])
        offset += T
    return np.concatenate(ts), np.concatenate(qs)


def _turns(model, q) -> np.ndarray:
    """Every configuration of the same pose as ``q`` by whole turns of its joints, within the joint limits
    (up to ``2^k`` for ``k`` joints with a range over a turn): which way a wrist is turned decides whether
    it must fold the gripper back onto the forearm on the way."""
    lo, hi = model.limits.T
    options = [[v for v in q[j] + 2 * np.pi * np.arange(-1, 2) if lo[j] <= v <= hi[j]] or [q[j]]
               for j in range(model.n_joints)]
    grids = np.meshgrid(*options, indexing="ij")
    out = np.stack([g.ravel() for g in grids], axis=1)
    # joints without limits (or wider than two turns) would multiply them: the fewest turns first
    return out[np.argsort(np.abs(out - q).sum(axis=1), kind="stable")[:MAX_TURNS]]


def _nearest_turn(model, q, reference) -> np.ndarray:
    """``q`` with each joint turned by whole turns to be nearest ``reference``, within the joint limits."""
    T = _turns(model, q)
    return T[np.argmin(np.abs(T - reference).sum(axis=1))]


def _rounds(model, starts, ends, turn_starts):
    """``[(starts, ends)]`` to plan between, in order, each a search of its own:

    1. the preferred start's branch (the first start's), each end turned to be nearest it: the shortest
       moves, found first when there is one;
    2. the same branch at every whole turn of the joints (a first step's starts too): which way a wrist
       is turned decides whether it must fold the gripper onto the forearm on the way;
    3. every branch at the nearest turns (a change of branch turns the shoulder or the wrist over);
    4. every branch, every turn.

    A round that adds nothing to the one before is left out.
    """
    def spread(configs, turn):
        return np.concatenate([_turns(model, q) if turn else np.asarray(q, float)[None] for q in configs])

    starts = [np.asarray(q, float) for q in starts]
    branch = int(model.branch_of(starts[0])[0])
    S, E = spread(starts, turn_starts), spread(ends, True)
    same_s = S[model.branch_of(S) == branch]
    same_e = E[model.branch_of(E) == branch]
    near = np.array([_nearest_turn(model, q, starts[0]) for q in ends])
    first = np.array(starts[:1])
    out = []
    for S_, E_ in ((first, near[model.branch_of(near) == branch]), (same_s, same_e), (first, near), (S, E)):
        if len(E_) and not any(len(S_) == len(a) and len(E_) == len(b) for a, b in out):
            out.append((S_, E_))
    return out


def planned_transit(model, scene, *, where, starts, end, end_q, names, objects, margin, duration, limits,
                    random_state=None, time_limit=None, label, first=False):
    """A planned transit from one of ``starts`` to a clear configuration at the pose (``end``, ``end_q``).

    Parameters
    ----------
    model : RobotModel
    scene : Scene
        Its obstacles ``names``, solid ``objects`` (those the step does not act on), table and workspace
        are checked, with the robot itself.
    where : str
        The step, for messages.
    starts : sequence of ndarray of shape (n_joints,)
        Where the transit may start: the previous step's last joints, or the clear configurations at a
        first step's start pose (``first``: then at every whole turn too).
    end, end_q : ndarray
        The transit's last tool pose.
    names, objects : sequence of str
    margin : float
    duration : callable
        ``duration(length)``: seconds a straight piece of that length takes (the chain's rule): sets how
        densely each segment is sampled, and the time base the time law starts from.
    limits : dict
        The plan's limits: the transit is timed by :func:`skillbank.robots.time_law` (TOPP-RA, from rest
        to rest) under ``joint_velocity`` (at most :data:`TRANSIT_JOINT_SPEED`) and
        ``joint_acceleration``.
    random_state : int, optional
    time_limit : float, optional
        Seconds the search may take per pair of start and end configurations.
    label : callable
        ``label(other)``: how a message names an obstacle.

    Returns
    -------
    piece : dict
        ``t`` (the time law's), ``position``, ``orientation`` (forward kinematics) and ``joints``.
    plan : MotionPlan

    Raises
    ------
    MotionPlanningError
        No clear configuration at the end pose, or no path found (on the start's branch, then on any:
        each search's reason).
    """
    obstacles = {n: scene.obstacles[n] for n in names}
    for n in objects:
        shape = scene.solid(n)
        if shape is not None:
            obstacles[n] = shape
    try:
        ends = clear_starts(model, scene, end, end_q, reference=starts[0], names=names, margin=margin,
                            label=label)
    except ValueError as exc:  # said of a start pose: here it is the transit's end
        why = str(exc).removeprefix("start: ").replace("at the start pose", "at the end of the transit")
        raise MotionPlanningError(f"{where}: the motion planner has no end for the transit: "
                                  f"{why.split('; move the start')[0]}") from None
    kwargs = {} if time_limit is None else {"time_limit": time_limit}
    failures = []
    for S, E in _rounds(model, starts, ends, turn_starts=len(starts) > 1 or first):
        try:
            plan = plan_motion(model, S, E, obstacles=obstacles, table=scene.table, workspace=scene.workspace,
                               margin=margin, random_state=random_state, label=label, **kwargs)
            break
        except MotionPlanningError as exc:
            failures.append(str(exc).removeprefix("motion planning: "))
    else:
        raise MotionPlanningError(f"{where}: the motion planner found no transit: " + "; ".join(failures))
    speed = np.full(model.n_joints, TRANSIT_JOINT_SPEED)
    if "joint_velocity" in limits:
        speed = np.minimum(speed, np.broadcast_to(limits["joint_velocity"], speed.shape))
    given, J = _timed(model, plan.joints, duration, speed)
    # the samples stay on the straight segments the planner checked; only their times change: the time law
    # (TOPP-RA) under the joint speed and the arm's joint accelerations, from rest to rest; the
    # minimum-jerk time base, at rest at every waypoint, is the spline it also tries (the faster is kept)
    t = time_law(J, velocity=speed, acceleration=limits.get("joint_acceleration"), t=given)
    position, orientation = model.fk(J)
    position[-1] = end  # exactly, not to round-off: the approach starts here
    return {"t": t, "position": position, "orientation": orientation, "joints": J}, plan
