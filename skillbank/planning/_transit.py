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
from ..robots import MotionPlanningError, plan_motion
from ..robots._base import wrap_angle
from ._start import clear_starts

__all__ = ["PLANNERS", "PLANNED_APPROACH", "planned_end", "planned_transit", "MAX_GOAL_CONFIGURATIONS",
           "TRANSIT_JOINT_SPEED"]

#: ``planner`` values of :func:`~skillbank.planning.plan_task` (``plan --planner``): ``"ompl"`` plans a
#: step's move with OMPL when the skill's own (and the hand-written transit) is not clear; ``"none"``
#: refuses such a step, as before the planner.
PLANNERS = ("ompl", "none")
#: Metres above the goal (along the tool's axis) where a planned transit ends when the binding gives no
#: approach: the last of the move is a straight line onto the goal, as a press needs.
PLANNED_APPROACH = 0.05
#: Pairs of start and end configurations tried in turn (the same branch first) before giving up.
MAX_GOAL_CONFIGURATIONS = 3
#: Peak joint speed (rad/s) of a planned transit's segments, unless the robot's limits are lower.
TRANSIT_JOINT_SPEED = 1.0
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


def _nearest_turn(model, q, reference) -> np.ndarray:
    """``q`` with each joint turned by whole turns to be nearest ``reference``, within the joint limits:
    the same pose, and no turn of a wrist the planner would have to undo."""
    lo, hi = model.limits.T
    out = reference + wrap_angle(q - reference)
    for shift in (2 * np.pi, -2 * np.pi):
        out = np.where(out < lo, out + shift, out) if shift > 0 else np.where(out > hi, out + shift, out)
    return np.where((out < lo) | (out > hi), q, out)


def _timed(model, Q, duration, joint_speed):
    """The waypoints ``Q`` as a sampled joint trajectory: each segment minimum-jerk from rest to rest.

    A segment lasts long enough that no joint exceeds ``joint_speed`` (rad/s, per joint) and that the
    tool point's path meets ``duration(length)`` (the chain's rule for a straight piece of that length).
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


def _pairs(model, starts, ends):
    """(start, end) configurations to plan between, in order: the same inverse-kinematics branch first
    (a change of branch turns the shoulder, elbow or wrist over, the hardest move for a planner), then by
    distance in joint space; each end turned to be nearest its start."""
    pairs = []
    for i, q0 in enumerate(starts):
        b0 = int(model.branch_of(q0)[0])
        for j, q1 in enumerate(ends):
            q1 = _nearest_turn(model, q1, q0)
            same = int(model.branch_of(q1)[0]) == b0
            pairs.append(((not same, float(np.linalg.norm(q1 - q0)), i, j), q0, q1))
    pairs.sort(key=lambda item: item[0])
    return [(q0, q1) for _, q0, q1 in pairs]


def planned_transit(model, scene, *, where, starts, end, end_q, names, objects, margin, duration, limits,
                    random_state=None, time_limit=None, label):
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
        first step's start pose.
    end, end_q : ndarray
        The transit's last tool pose.
    names, objects : sequence of str
    margin : float
    duration : callable
        ``duration(length)``: seconds a straight piece of that length takes (the chain's rule).
    limits : dict
        The plan's limits (``joint_velocity`` caps the segments' speed).
    random_state : int, optional
    time_limit : float, optional
        Seconds the search may take per pair of start and end configurations.
    label : callable
        ``label(other)``: how a message names an obstacle.

    Returns
    -------
    piece : dict
        ``t``, ``position``, ``orientation`` (forward kinematics) and ``joints``.
    plan : MotionPlan

    Raises
    ------
    MotionPlanningError
        No clear configuration at the end pose, or no path between the first
        :data:`MAX_GOAL_CONFIGURATIONS` pairs tried (each one's reason).
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
    for q0, q_end in _pairs(model, starts, ends)[:MAX_GOAL_CONFIGURATIONS]:
        try:
            plan = plan_motion(model, q0, q_end, obstacles=obstacles, table=scene.table,
                               workspace=scene.workspace, margin=margin, random_state=random_state,
                               label=label, **kwargs)
            break
        except MotionPlanningError as exc:
            failures.append(str(exc).removeprefix("motion planning: "))
    else:
        raise MotionPlanningError(f"{where}: the motion planner found no transit: " + "; ".join(failures))
    speed = np.full(model.n_joints, TRANSIT_JOINT_SPEED)
    if "joint_velocity" in limits:
        speed = np.minimum(speed, np.broadcast_to(limits["joint_velocity"], speed.shape))
    t, J = _timed(model, plan.joints, duration, speed)
    position, orientation = model.fk(J)
    position[-1] = end  # exactly, not to round-off: the approach starts here
    return {"t": t, "position": position, "orientation": orientation, "joints": J}, plan
