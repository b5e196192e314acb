"""The joint a part of an articulated object moves about, found from the poses it was seen at.

A door turns about its hinge, a handle about its latch, a drawer slides along its rail: over one
stretch of a demonstration the part's poses are a rotation about one fixed line, or a translation along
one direction, of its first pose. :func:`fit_joint` finds which of the two explains the poses better and
its axis, a point on it and the joint's value at every pose; :class:`Joint` moves any pose (the tool that
holds the part, the part in a new scene) as the joint would.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._rotations import exp_map, log_map, quaternion_multiply, quaternion_to_matrix
from ._validation import check_array

__all__ = ["Joint", "fit_joint", "JOINT_KINDS"]

#: What :func:`fit_joint` tells apart.
JOINT_KINDS = ("revolute", "prismatic")
#: m and rad: less motion than this is no motion; a part that moved less has no joint to find
_STILL = (1e-4, 1e-3)


@dataclass(frozen=True)
class Joint:
    """One joint of an articulated object, in the frame its poses were given in.

    ``kind``: ``"revolute"`` (a rotation by ``values`` radians about the line through ``point`` along
    ``axis``, right-handed) or ``"prismatic"`` (a translation by ``values`` metres along ``axis``;
    ``point`` is where the part started). ``values``: the joint's value at each fitted pose, 0 at the
    first, its sign chosen so that the largest is positive (the way the part was moved). ``residual``
    (m): the root mean square distance between the fitted poses and the joint's account of them,
    measured at the part's origin and at points ``scale`` metres from it along its own axes (so a
    turn the joint does not explain counts as much as a slide it does not).
    """

    kind: str
    axis: np.ndarray
    point: np.ndarray
    values: np.ndarray
    residual: float
    scale: float

    def move(self, positions, quaternions, value):
        """Poses moved by the joint from value 0 to ``value`` (each pose by its own where arrays).

        Parameters
        ----------
        positions : array-like of shape (..., 3)
        quaternions : array-like of shape (..., 4)
            Scalar-last (x, y, z, w).
        value : float or array-like broadcast against the poses

        Returns
        -------
        (positions, quaternions)

        Examples
        --------
        >>> j = Joint("revolute", np.array([0.0, 0.0, 1.0]), np.zeros(3), np.zeros(1), 0.0, 0.1)
        >>> p, q = j.move([1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], np.pi / 2)
        >>> np.round(p, 6).tolist(), np.round(q, 6).tolist()
        ([0.0, 1.0, 0.0], [0.0, 0.0, 0.707107, 0.707107])
        """
        p = np.asarray(positions, float)
        q = np.asarray(quaternions, float)
        v = np.asarray(value, float)
        if self.kind == "prismatic":
            shape = np.broadcast_shapes(q.shape, v.shape + (4,))
            return p + v[..., None] * self.axis, np.broadcast_to(q, shape)
        turn = exp_map(v[..., None] * self.axis)
        R = quaternion_to_matrix(turn)
        moved = np.einsum("...ij,...j->...i", R, p - self.point) + self.point
        return moved, quaternion_multiply(turn, q)


def _points(positions, quaternions, scale):
    """The part's origin and three points ``scale`` metres along its axes, at every pose: (n, 4, 3)."""
    R = quaternion_to_matrix(quaternions)
    offsets = np.concatenate([np.zeros((1, 3)), scale * np.eye(3)])
    return positions[:, None, :] + np.einsum("nij,kj->nki", R, offsets)


def _residual(joint: Joint, positions, quaternions) -> float:
    moved_p, moved_q = joint.move(positions[0], quaternions[0], joint.values)
    seen = _points(positions, quaternions, joint.scale)
    model = _points(np.asarray(moved_p), np.asarray(moved_q), joint.scale)
    return float(np.sqrt(np.mean(np.sum((seen - model) ** 2, axis=-1))))


def _signed(axis, values):
    """The axis and values with the sign that makes the value of largest magnitude positive."""
    k = int(np.argmax(np.abs(values)))
    return (axis, values) if values[k] >= 0 else (-axis, -values)


def _revolute(positions, quaternions, scale) -> Joint:
    turns = log_map(quaternions, quaternions[0])  # in the first pose's frame
    R0 = quaternion_to_matrix(quaternions[0])
    turns = turns @ R0.T  # the same rotations, in the world's frame (applied on the left)
    # the axis every turn shares: the principal direction of the rotation vectors, weighted by their size
    axis = np.linalg.svd(turns, full_matrices=False)[2][0]
    axis, values = _signed(axis, turns @ axis)
    # the line: each pose is the first turned about it, p_i = R_i (p_0 - c) + c, so
    # (I - R_i) c = p_i - R_i p_0; the point on it nearest the first position closes the system (a line
    # has no other point to prefer)
    R = quaternion_to_matrix(exp_map(values[:, None] * axis))
    rows = np.concatenate([(np.eye(3) - R).reshape(-1, 3), axis[None, :]])
    rhs = np.concatenate([(positions - np.einsum("nij,j->ni", R, positions[0])).reshape(-1),
                          [axis @ positions[0]]])
    point = np.linalg.lstsq(rows, rhs, rcond=None)[0]
    joint = Joint("revolute", axis, point, values, 0.0, scale)
    return Joint("revolute", axis, point, values, _residual(joint, positions, quaternions), scale)


def _prismatic(positions, quaternions, scale) -> Joint:
    moved = positions - positions[0]
    axis = np.linalg.svd(moved, full_matrices=False)[2][0]
    axis, values = _signed(axis, moved @ axis)
    joint = Joint("prismatic", axis, positions[0].copy(), values, 0.0, scale)
    residual = _residual(joint, positions, quaternions)
    return Joint("prismatic", axis, positions[0].copy(), values, residual, scale)


def fit_joint(positions, quaternions, *, kind=None) -> Joint:
    """The joint that best explains a part's poses: a rotation about a line or a slide along an axis.

    Both are fitted (the rotations' common axis and the line they turn about by least squares; the
    slide's direction as the displacements' principal one) and the one whose account of the poses is
    closer is returned (:attr:`Joint.residual`, measured at the part's origin and at points as far from
    it as the part travelled, so turns and slides are weighed in the same metres). Whether the joint
    explains the motion at all is the caller's to judge from ``residual`` against the travel.

    Parameters
    ----------
    positions : array-like of shape (n, 3)
        The part's origin (m), in any one frame.
    quaternions : array-like of shape (n, 4)
        Its orientation, scalar-last (x, y, z, w), in the same frame.
    kind : {"revolute", "prismatic"}, optional
        Fit only this kind.

    Returns
    -------
    Joint

    Raises
    ------
    ValueError
        Fewer than 3 poses, arrays of the wrong shape or not finite, or a part that did not move.

    Examples
    --------
    A door's corner, turned about a hinge at (1, 0, 0) by up to 0.4 rad:

    >>> import numpy as np
    >>> a = np.linspace(0.0, 0.4, 9)
    >>> p = np.c_[1 - np.cos(a), -np.sin(a), np.zeros(9)]
    >>> q = np.c_[np.zeros((9, 2)), np.sin(a / 2), np.cos(a / 2)]
    >>> j = fit_joint(p, q)
    >>> j.kind, np.round(j.axis, 6).tolist(), np.round(j.point, 6).tolist(), round(float(j.values[-1]), 6)
    ('revolute', [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], 0.4)
    """
    positions = check_array(positions, name="positions", n_dims=3)
    quaternions = check_array(quaternions, name="quaternions", n_dims=4)
    if quaternions.shape != (len(positions), 4):
        raise ValueError(f"quaternions: expected an ({len(positions)}, 4) array (x, y, z, w), one per "
                         f"position, got shape {quaternions.shape}")
    if len(positions) < 3:
        raise ValueError(f"positions: a joint is fitted to 3 poses or more, got {len(positions)}")
    norms = np.linalg.norm(quaternions, axis=1)
    if np.any(np.abs(norms - 1.0) > 1e-3):
        raise ValueError("quaternions: expected unit quaternions (x, y, z, w); normalise them first")
    if kind is not None and kind not in JOINT_KINDS:
        raise ValueError(f"kind: expected one of {list(JOINT_KINDS)}, got {kind!r}")
    quaternions = quaternions / norms[:, None]
    travel = float(np.linalg.norm(positions - positions[0], axis=1).max())
    turn = float(np.linalg.norm(log_map(quaternions, quaternions[0]), axis=1).max())
    if travel < _STILL[0] and turn < _STILL[1]:
        raise ValueError(f"the part moved {travel * 1e3:.2f} mm and turned {np.degrees(turn):.3f} degrees: "
                         "no joint can be found from poses that did not move")
    scale = max(travel, 0.01)
    fits = [f(positions, quaternions, scale) for k, f in (("revolute", _revolute), ("prismatic", _prismatic))
            if kind in (None, k)]
    return min(fits, key=lambda j: j.residual)
