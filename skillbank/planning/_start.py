"""A start the arm can take: the configuration of a start given as a pose, clear of itself and the scene.

A scene's ``start`` given as a tool pose (or a position alone, the orientation
then the first step's reproduction's) leaves the joints open: the UR5e reaches a
pose on up to eight inverse-kinematics branches, an arm with a numerical
solver on as many as its seeds find. The start is the configuration nearest
the demonstration's recorded joints (else the robot's home) **that is clear of
the robot itself and of the scene** (its obstacles, table and workspace) with
the planning margin, checked by :func:`skillbank.robots.clearance` as every
step is. The scene's objects are left out, as at the start of the first step
(the robot may rest on them, and leaves them). With none clear, one line names
every branch (or seed) tried and why it failed.
"""

from __future__ import annotations

import numpy as np

from ..robots import KinematicsError, clearance
from ..robots._base import wrap_angle

__all__ = ["clear_starts", "SEEDS"]

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


def clear_starts(model, scene, position, quaternion, *, reference=None, names=(), margin, label):
    """The start configurations at a tool pose that are clear, nearest ``reference`` first.

    Parameters
    ----------
    model : RobotModel
    scene : Scene
        Its ``names`` obstacles, table and workspace are checked, and the robot itself.
    position : array-like of shape (3,)
    quaternion : array-like of shape (4,)
    reference : array-like of shape (n_joints,), optional
        The joints to start nearest (the demonstration's recorded ones); default the robot's home.
    names : sequence of str
        The scene's obstacles that apply.
    margin : float
        Metres every body keeps (the planning margin).
    label : callable
        ``label(other)``: how a message names what a body came near (an obstacle, the table, a body).

    Returns
    -------
    list of ndarray of shape (n_joints,)
        At least one.

    Raises
    ------
    ValueError
        One line naming every branch (or seed) tried and why it failed: unreachable (or the solver's
        reason), or the body and what it comes near.
    """
    obstacles = {n: scene.obstacles[n] for n in names}
    table, workspace = getattr(scene, "table", None), getattr(scene, "workspace", None)
    clear, failed = [], []
    for name, q, why in _candidates(model, position, quaternion, reference):
        if q is None:
            failed.append(f"{name}: {why}")
            continue
        why = _why(clearance(model, q[None], obstacles, table=table, workspace=workspace), margin, label)
        if why is None:
            clear.append(q)
        else:
            failed.append(f"{name}: {why}")
    if clear:
        return clear
    kind = "branch" if len(model.branch_names) > 1 else "seed"
    raise ValueError(f"start: robot {model.name} has no configuration at the start pose (tool point "
                     f"{np.round(np.asarray(position, float), 4).tolist()}) clear of itself and of the scene "
                     f"(clearance margin {margin * 1000:g} mm; --clearance sets it); every {kind} tried: "
                     + "; ".join(failed) + "; move the start, or give it as joints (start.joints)")
