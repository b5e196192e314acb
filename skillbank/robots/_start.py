"""A configuration the arm can take at a tool pose: the IK solutions clear of itself and of the world.

A tool pose leaves the joints open: the UR5e reaches one on up to eight
inverse-kinematics branches, an arm with a numerical solver on as many as its
seeds find. :func:`clear_configurations` lists those that are clear (checked by
:func:`~skillbank.robots.clearance` with a margin), nearest a reference
(the demonstration's recorded joints, else the robot's home) first, and why
each other one is not. The one place a start is chosen: a plan's start given
as a pose (:func:`skillbank.planning._start.clear_starts`, which also gives a
planned transit its end) and a reuse's or an edit's start with a robot
(:func:`skillbank.selection.make_executable`).
"""

from __future__ import annotations

import numpy as np

from ._base import KinematicsError, wrap_angle
from ._clearance import clearance

__all__ = ["clear_configurations", "SEEDS"]

#: Seeds beyond the recorded joints and home for an arm with one numerical "branch", from a fixed generator
#: (the same scene always gives the same start): towards uniform draws within the joint limits (±π where a
#: joint has none) ...
SEEDS = 6
#: ... each that fraction of the way from the recorded joints (or home) to a uniform draw: far seeds leave
#: a damped solver held at a joint limit more often than they find another posture.
SPREAD = 0.5
#: How a branch the pose is not solved on is named (:class:`~skillbank.robots.KinematicsError` reasons).
_REASONS = {"joint limit": "unreachable within the joint limits", "singularity": "at a singularity"}


def _candidates(model, position, quaternion, reference):
    """``[(label, joints or None, why)]`` in order of preference: the branches (or seeds) at the pose."""
    reference = np.asarray(model.home if reference is None else reference, float)
    if len(model.branch_names) > 1:  # closed-form branches: every one at once, nearest the reference first
        sols = model.ik_all(position, quaternion)
        gap = np.where(np.isnan(sols), np.inf, np.abs(wrap_angle(sols - reference)))
        order = np.argsort(np.linalg.norm(gap, axis=1), kind="stable")
        seeds = [(model.branch_names[b], dict(branch=int(b), q_seed=reference)) for b in order]
    else:  # a numerical solver: the recorded joints (or home), home, and a few fixed others
        lo, hi = (np.where(np.isfinite(x), x, np.copysign(np.pi, x)) for x in model.limits.T)
        rng = np.random.default_rng(0)
        seeds = [("seed " + ("home" if np.allclose(reference, model.home) else "recorded"), reference),
                 ("seed home", np.asarray(model.home, float))]
        seeds += [(f"seed {k}", reference + SPREAD * (rng.uniform(lo, hi) - reference))
                  for k in range(1, SEEDS + 1)]
        seeds = [(label, dict(q_seed=s)) for k, (label, s) in enumerate(seeds)
                 if not any(np.array_equal(s, t) for _, t in seeds[:k])]
    out, found = [], []
    for label, kwargs in seeds:
        try:
            q = np.asarray(model.ik(position, quaternion, **kwargs), float)
        except KinematicsError as exc:
            out.append((label, None, _REASONS.get(exc.reason, exc.reason)))
            continue
        except ValueError:
            out.append((label, None, "unreachable"))
            continue
        if any(np.abs(wrap_angle(q - p)).max() < 1e-3 for p in found):
            continue  # a seed that converged to a configuration already tried
        found.append(q)
        out.append((label, q, None))
    return out


def _why(res, margin, label) -> str | None:
    """Why the configuration checked in ``res`` is not clear (None: it is)."""
    hit = res.first_contact(margin)
    if hit is None:
        return None
    _, body, other = hit
    d = float(res.min_distance)
    depth = f"{-d * 1000:.3g} mm into" if d < 0 else f"within {d * 1000:.3g} mm of"
    return f"its {body} {depth} {label(other)}"


def clear_configurations(model, position, quaternion, *, reference=None, obstacles=None, table=None,
                         workspace=None, margin, label=str, ignore=()):
    """The configurations at a tool pose that are clear, nearest ``reference`` first, and why others are not.

    Parameters
    ----------
    model : RobotModel
        With bodies; the robot itself is checked too (self-collision).
    position : array-like of shape (3,)
    quaternion : array-like of shape (4,)
        Scalar-last.
    reference : array-like of shape (n_joints,), optional
        The joints to be nearest (the demonstration's recorded ones); default the robot's home.
    obstacles, table, workspace, ignore
        As :func:`~skillbank.robots.clearance` takes them.
    margin : float
        Metres every body keeps.
    label : callable, default=str
        ``label(other)``: how a reason names what a body came near (an obstacle, the table, a body).

    Returns
    -------
    clear : list of ndarray of shape (n_joints,)
        Possibly empty.
    failed : list of str
        ``"<branch or seed>: <why>"`` for every other one tried: unreachable (or the solver's reason), or
        the body and what it comes near.

    Examples
    --------
    >>> from skillbank.core import Sphere
    >>> from skillbank.robots import robot_model
    >>> robot = robot_model("ur5e")
    >>> p, q = robot.fk(robot.home)
    >>> clear, failed = clear_configurations(robot, p, q, margin=0.005)
    >>> bool(np.allclose(clear[0], robot.home)), len(clear) + len(failed)
    (True, 8)
    """
    clear, failed = [], []
    for name, q, why in _candidates(model, position, quaternion, reference):
        if q is None:
            failed.append(f"{name}: {why}")
            continue
        why = _why(clearance(model, q[None], obstacles, table=table, workspace=workspace, ignore=ignore),
                   margin, label)
        if why is None:
            clear.append(q)
        else:
            failed.append(f"{name}: {why}")
    return clear, failed
