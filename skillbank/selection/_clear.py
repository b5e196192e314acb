"""Keeping the whole robot clear of the obstacles: check a reproduction's joints, repair with via points.

A reproduction's tool path was edited around the obstacles, but the links
follow by inverse kinematics and can still come near one (the forearm under
a shelf, the upper arm beside a post). :func:`keep_clear` checks every
sample of the joint trajectory with :func:`skillbank.robots.clearance`
(densified, every body), and where a body comes closer than the margin it
*repairs* the reproduction as the method allows (the paper's LTE with a
displaced via point): a via point at that sample, displaced by the shortest
tool motion that moves that body away by what it lacks
(:func:`skillbank.robots.clearing_move`, which measures the effect through
the robot's own kinematics, so a link far from the tool is repaired too),
and the task is reproduced again. A contact that moving the tool cannot
clear (a body on the shoulder), or that is still there after
:data:`MAX_REPAIRS` via points, is returned as the reason, naming the body,
the obstacle and the time.
"""

from __future__ import annotations

import numpy as np

from ..core import ViaPoint
from ..robots import clearance, clearing_move

__all__ = ["MAX_REPAIRS", "keep_clear", "Repaired", "shift_near"]

#: Via points added to keep the robot clear before the reproduction is given up.
MAX_REPAIRS = 6
#: Earlier repair via points nearer than this phase to a new one move with it (the contact moved a little).
_SAME_PLACE = 0.04


def shift_near(via, phase, move, near):
    """Repair via points ``[(ViaPoint, *info)]`` within ``near`` of ``phase`` moved by ``move``, the same
    phase dropped (the new one takes it), the others kept.

    A contact that a via point pushed off often reappears a few samples away: the region moves together,
    instead of the earlier point springing back (which would undo its repair) or two points pulling apart.
    """
    out = []
    for v, *info in via:
        if v.phase == phase:
            continue
        if abs(v.phase - phase) <= near:
            v = ViaPoint(v.position + move, phase=v.phase)
        out.append((v, *info))
    return out


class Repaired:
    """What :func:`keep_clear` found: the reproduction, its clearance, the repairs, or why it failed."""

    __slots__ = ("result", "clearance", "via", "reason", "constraints")

    def __init__(self, result, clearance_, via, reason, constraints):
        self.result, self.clearance, self.via, self.reason = result, clearance_, via, reason
        self.constraints = constraints

    @property
    def notes(self) -> list:
        """One line per repair via point, for a result's notes."""
        return [f"repair: via point at phase {v.phase:.3f} keeps the robot's {body} clear of {other} "
                f"(tool moved {np.linalg.norm(move) * 1000:.3g} mm)" for v, body, other, move in self.via]


def _label(other: str, obstacles) -> str:
    if other.startswith("obstacles["):
        k = int(other.split("[")[1].rstrip("]"))
        return f"obstacle {k} ({obstacles[k].spec()})"
    return other


def keep_clear(make, constraints, model, *, margin, max_repairs=MAX_REPAIRS) -> Repaired:
    """Reproduce with ``make(constraints)`` until every body of ``model`` keeps ``margin`` from the obstacles.

    Parameters
    ----------
    make : callable
        ``make(constraints) -> (result, trajectory)``, the trajectory with ``position`` and ``joints``.
    constraints : Constraints
        The task; its obstacles are the world (named ``obstacles[k]``).
    model : RobotModel
    margin : float
        Metres every moving body keeps from every obstacle.
    max_repairs : int, default=MAX_REPAIRS

    Returns
    -------
    Repaired
        ``reason`` is None when the robot is clear (after ``len(via)`` repairs), else why not.
    """
    obstacles = list(constraints.obstacles)
    # the bodies on the base frame never move: no reproduction can change them, and a table given as an
    # obstacle is where the base stands
    fixed = [b.name for b in model.bodies if b.frame == 0]
    via, task, attempts = [], constraints, 0
    while True:
        result, traj = make(task)
        if not obstacles or "joints" not in traj.streams:
            return Repaired(result, None, via, None, task)
        joints = traj["joints"]
        # the obstacles only: a self-collision is the reproduction's shape, reported with its clearance
        # (skillbank.robots.clearance) by the commands, and no via point of the tool's says how to undo it
        res = clearance(model, joints, obstacles, t=traj.t, ignore=fixed, self_collision=False)
        hit = res.first_contact(margin)
        if hit is None:
            return Repaired(result, res, via, None, task)
        n = joints.shape[0]
        # the start and the goal are the task's (given, or the candidates' own): no repair may move them,
        # so a contact there is final
        ends = [j for j in (0, n - 1) if res.distance[j] < margin]
        i, body, other = (ends[0], *res.pairs[int(res.pair[ends[0]])]) if ends else hit
        d = float(res.distance[i])
        depth = f"{-d * 1000:.3g} mm into" if d < 0 else f"within {d * 1000:.3g} mm of"
        why = (f"the robot's {body} comes {depth} {_label(other, obstacles)} at t = {float(traj.t[i]):.4g} s "
               f"(its tool point is clear; clearance margin {margin * 1000:g} mm)")
        k = int(other.split("[")[1].rstrip("]"))
        if ends:
            return Repaired(result, res, via, why + f"; at its {'start' if i == 0 else 'goal'}, which no "
                            "repair moves", task)
        if attempts >= max_repairs or n < 3:
            return Repaired(result, res, via, why + (f", after {attempts} repair(s)" if attempts else ""),
                            task)
        # what the body lacks, and a margin again: the first-order move falls short where the arm bends
        move = clearing_move(model, joints[i], body, obstacles[k], 2 * margin - d)
        if move is None:
            return Repaired(result, res, via, why + "; moving the tool cannot clear it", task)
        attempts += 1
        phase = i / (n - 1)
        point = traj["position"][i] + move
        via = shift_near(via, phase, move, _SAME_PLACE) + [(ViaPoint(point, phase=phase), body, other, move)]
        user = tuple(constraints.via)
        task = constraints.replace(via=user + tuple(v for v, *_ in via))
