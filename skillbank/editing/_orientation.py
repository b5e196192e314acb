"""Orientation editing: meet start, goal and via orientations while keeping the rotation profile.

An orientation stream is edited by a *correction field*: every sample ``q_i``
is turned by a world-frame rotation ``C_i = exp(w_i)``, ``q'_i = C_i q_i``. The
rotation vectors ``w_i`` live in a flat space (the tangent space at each
demonstrated sample), so they are edited with the same Laplacian machinery as
positions: the correction of least Laplacian energy that takes each
constrained sample exactly to its target (:class:`LaplacianSystem`). With a
start and a goal only, the correction blends from one end's to the other's
the way LTE moves a path whose ends move: flat at both ends, so the
demonstrated angular velocity at the start and the goal is kept.

Why a correction and not an edit of the rotation vectors themselves about one
reference: the demonstrated relative rotation between successive samples,
``q_i^-1 q_{i+1}``, changes by exactly the rotation ``C_i^-1 C_{i+1}``, whose angle
is at most ``|w_{i+1} - w_i|`` (to first order), the step of a smooth field. A
constant correction (start and goal both turned by the same rotation) keeps
every relative rotation exactly: the demonstrated twist of the tool, about its
own axes, stays the same twist. Editing ``log(r^-1 q_i)`` about a fixed
reference ``r`` instead distorts the profile wherever the path is far from ``r``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import Constraints, check_quaternions, continuous_quaternions
from ..core._rotations import _exp, _log, quaternion_conjugate, quaternion_multiply
from ..core._validation import check_finite_result, check_time, numerical_errors
from ._laplacian import LaplacianSystem

__all__ = ["OrientationEdit", "edit_orientation", "relative_rotations"]


@dataclass
class OrientationEdit:
    """Outcome of an orientation edit.

    Attributes
    ----------
    q : ndarray of shape (n_steps, 4)
        The edited orientations: unit quaternions, scalar-last, sign-continuous.
    correction : ndarray of shape (n_steps, 3)
        The world-frame rotation vector applied to each sample (``q = exp(correction) * q_in``).
    orientation_error : float
        Largest angle (radians) between a constrained sample and its target.
    """

    q: np.ndarray
    correction: np.ndarray
    orientation_error: float


def relative_rotations(q) -> np.ndarray:
    """Rotation vectors ``log(q_i^-1 q_{i+1})`` of the steps between successive samples (body frame).

    The rotation profile of an orientation stream: two streams with the same
    relative rotations turn the tool the same way about its own axes.

    Examples
    --------
    >>> s = np.sin(0.05)
    >>> relative_rotations([[0, 0, 0, 1.0], [0, 0, s, np.cos(0.05)]]).round(12).tolist()
    [[0.0, 0.0, 0.1]]
    """
    q = continuous_quaternions(check_quaternions(q, name="q"))
    return _log(quaternion_multiply(quaternion_conjugate(q[:-1]), q[1:]))


@numerical_errors("edit_orientation")
def edit_orientation(q, constraints=None, *, t=None, anchor_ends: bool = True) -> OrientationEdit:
    """Turn an orientation stream to meet the orientation constraints, keeping its rotation profile.

    Parameters
    ----------
    q : array-like of shape (n_steps, 4)
        Unit quaternions, scalar-last; signs are made continuous first.
    constraints : Constraints, optional
        Its ``start_orientation``, ``goal_orientation`` and ``via_orientation``
        are met exactly (to round-off, ~1e-15 rad); positions are ignored.
    t : array-like of shape (n_steps,), optional
        Time stamps: they weight the Laplacian as in LTE. Default unit spacing.
    anchor_ends : bool, default=True
        When only some orientations are constrained, hold a start or goal
        that is not given at the stream's own (zero correction there), as
        LTE holds positions.

    Returns
    -------
    OrientationEdit

    Raises
    ------
    ValueError
        Naming ``q`` for non-unit quaternions or the wrong shape, ``t`` for a
        bad time base, ``constraints`` for two orientations on one sample.

    Examples
    --------
    >>> c = np.cos(np.pi / 4)
    >>> q = np.tile([0.0, 0.0, 0.0, 1.0], (5, 1))
    >>> res = edit_orientation(q, Constraints(goal_orientation=[0.0, 0.0, c, c]))
    >>> res.q[[0, 2, 4]].round(6).tolist()
    [[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.382683, 0.92388], [0.0, 0.0, 0.707107, 0.707107]]
    """
    q = check_quaternions(q, name="q")
    if q.ndim != 2:
        raise ValueError(f"q: expected an orientation stream of shape (n_steps, 4), got shape {q.shape}")
    q = continuous_quaternions(q)
    n = q.shape[0]
    t = np.arange(n, dtype=float) if t is None else check_time(t, n_steps=n)
    c = Constraints() if constraints is None else constraints
    if not isinstance(c, Constraints):
        raise ValueError(f"constraints: expected a skillbank Constraints, got {type(c).__name__}")
    if not c.has_orientation:
        return OrientationEdit(q=q, correction=np.zeros((n, 3)), orientation_error=0.0)
    if anchor_ends:
        c = c.replace(start_orientation=q[0] if c.start_orientation is None else c.start_orientation,
                      goal_orientation=q[-1] if c.goal_orientation is None else c.goal_orientation)
    idx, targets = c.resolve_orientation(n)
    # World-frame corrections target * q^-1 at the constrained samples (the shorter rotation of the two).
    wanted = _log(quaternion_multiply(targets, quaternion_conjugate(q[idx])))
    W = LaplacianSystem(n, t).solve(idx, wanted)
    W[idx] = wanted
    out = quaternion_multiply(_exp(W), q)
    # The constrained samples are the targets themselves (exp(log) round trip avoided), on the stream's sign.
    out[idx] = np.where(np.sum(out[idx] * targets, axis=1, keepdims=True) < 0, -targets, targets)
    out = continuous_quaternions(out / np.linalg.norm(out, axis=1, keepdims=True))
    check_finite_result(out, name="edit_orientation")
    return OrientationEdit(q=out, correction=W, orientation_error=c.orientation_error(out))
