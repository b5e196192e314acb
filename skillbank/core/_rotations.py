"""Orientation geometry: unit quaternions, their continuity, SLERP and the log / exp maps.

Convention
----------
A quaternion is stored **scalar-last**, ``(x, y, z, w)``, as in scipy
(``Rotation.as_quat``) and ROS (``geometry_msgs/Quaternion``). An orientation
stream is an array of shape ``(n, 4)``; ``q`` and ``-q`` are the same
rotation, so a recorded stream may flip sign between samples, which
:func:`continuous_quaternions` undoes. :func:`check_quaternions` converts
scalar-first input (``(w, x, y, z)``, as Eigen's constructor or MATLAB) on
request.

The rotation vector of a quaternion relative to a reference
(:func:`log_map`) lives in the reference's body frame:
``q = reference * exp(v)``. Editing orientations means editing these vectors
(a flat space, where positions' tools apply) and mapping back with
:func:`exp_map`; the result is a unit quaternion by construction.

Everything is vectorised over samples and uses numpy only (scipy's
``Rotation`` and ``Slerp`` give the same answers, checked in the tests, but
importing ``scipy.spatial`` costs about 0.4 s).
"""

from __future__ import annotations

import numpy as np

from ._validation import check_array, check_fraction, check_time, summarise

__all__ = [
    "UNIT_TOLERANCE", "check_quaternions", "continuous_quaternions", "quaternion_multiply",
    "quaternion_conjugate", "quaternion_angle", "log_map", "exp_map", "slerp",
    "quaternion_to_matrix", "matrix_to_quaternion",
]

#: Largest accepted deviation of a quaternion's norm from 1 before it is renormalised. Four components
#: rounded to three decimals move the norm by at most 1e-3; a deviation ten times that is not rounding
#: but a wrong column, an Euler triple padded with a zero, or an unnormalised sum.
UNIT_TOLERANCE = 1e-2

#: Below this sine of half the angle the log / exp maps use their Taylor series (error < 1e-16).
_SMALL = 1e-8


def check_quaternions(value, *, name: str = "quaternions", scalar_first: bool = False,
                      tolerance: float = UNIT_TOLERANCE) -> np.ndarray:
    """Check unit quaternions and return them scalar-last, renormalised to norm 1.

    Parameters
    ----------
    value : array-like of shape (n, 4) or (4,)
        Quaternions, scalar-last ``(x, y, z, w)`` unless ``scalar_first``.
    name : str, default="quaternions"
        Argument name for error messages.
    scalar_first : bool, default=False
        The input is ``(w, x, y, z)``; the output is always scalar-last.
    tolerance : float, default=UNIT_TOLERANCE
        Largest accepted ``| |q| - 1 |``.

    Returns
    -------
    ndarray of float64, the shape of ``value``
        Scalar-last, each of norm 1 (signs as given: see :func:`continuous_quaternions`).

    Raises
    ------
    ValueError
        Naming ``name``: not real, not finite, not 4 components, zero norm
        or a norm further than ``tolerance`` from 1 (with the first such
        sample).

    Examples
    --------
    >>> check_quaternions([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.7071, 0.7071]]).round(4).tolist()
    [[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.7071, 0.7071]]
    >>> check_quaternions([1.0, 0.0, 0.0, 0.0], scalar_first=True).tolist()
    [0.0, 0.0, 0.0, 1.0]
    """
    tolerance = check_fraction(tolerance, name="tolerance", low=0.0, high=0.5)
    q = check_array(value, name=name, ndim=(1, 2))
    if q.shape[-1] != 4:
        raise ValueError(f"{name}: expected quaternions of 4 components (x, y, z, w), got shape {q.shape}")
    if scalar_first:
        q = q[..., [1, 2, 3, 0]]
    # The components are at most MAX_MAGNITUDE (1e100): squaring them in float64 cannot overflow.
    norm = np.sqrt(np.einsum("...i,...i->...", q, q))
    bad = np.flatnonzero(np.abs(np.atleast_1d(norm) - 1.0) > tolerance)
    if bad.size:
        norms = np.atleast_1d(norm)
        where = f"sample {int(bad[0])}" if q.ndim == 2 else "the quaternion"
        what = "zero norm" if norms[bad[0]] == 0 else f"norm {float(norms[bad[0]]):.6g}"
        more = f" ({bad.size} such samples: {summarise(bad)})" if q.ndim == 2 else ""
        raise ValueError(f"{name}: expected unit quaternions (norm within {tolerance:g} of 1), got {what} "
                         f"at {where}{more}")
    return q / norm[..., None]


def continuous_quaternions(q) -> np.ndarray:
    """Flip signs (``q -> -q``, the same rotation) so consecutive quaternions have a dot product >= 0.

    The first sample keeps its sign. Interpolation and differences then take
    the short way between samples.

    Parameters
    ----------
    q : ndarray of shape (n, 4)
        Unit quaternions (see :func:`check_quaternions`).

    Returns
    -------
    ndarray of shape (n, 4)

    Examples
    --------
    >>> q = np.array([[0, 0, 0.6, 0.8], [0, 0, -0.8, -0.6], [0, 0, 0.6, 0.8]])
    >>> continuous_quaternions(q)[:, 2:].tolist()
    [[0.6, 0.8], [0.8, 0.6], [0.6, 0.8]]
    """
    q = np.asarray(q, dtype=float)
    dots = np.einsum("ij,ij->i", q[1:], q[:-1])
    # Each negative dot toggles every later sample: the parity of the toggles so far is its sign.
    flips = np.concatenate([[0], np.cumsum(dots < 0) % 2])
    return np.where(flips[:, None] == 1, -q, q)


def quaternion_conjugate(q) -> np.ndarray:
    """The inverse rotation of unit quaternions ``q`` (scalar-last).

    Examples
    --------
    >>> quaternion_conjugate([0.0, 0.6, 0.0, 0.8]).tolist()
    [-0.0, -0.6, -0.0, 0.8]
    """
    q = np.asarray(q, dtype=float)
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


def quaternion_multiply(p, q) -> np.ndarray:
    """Hamilton products ``p * q`` (the rotation ``q`` followed by ``p``), broadcast over samples.

    Examples
    --------
    >>> quaternion_multiply([0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 1.0, 0.0]).tolist()
    [0.0, 0.0, 0.0, -1.0]
    """
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    pv, pw = p[..., :3], p[..., 3:]
    qv, qw = q[..., :3], q[..., 3:]
    vec = pw * qv + qw * pv + np.cross(pv, qv)
    scalar = pw * qw - np.sum(pv * qv, axis=-1, keepdims=True)
    return np.concatenate([vec, scalar], axis=-1)


def quaternion_angle(p, q) -> np.ndarray:
    """The angle in radians (in [0, pi]) of the rotation taking ``p`` to ``q``, sample by sample.

    Computed as ``4 atan2(|p - q|, |p + q|)`` on the nearer sign of ``q`` (the
    quaternions, as 4-vectors, are half the rotation angle apart), exact also
    for tiny angles, where ``2 acos(|p.q|)`` loses half the digits.

    Examples
    --------
    >>> round(float(quaternion_angle([0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 0.0])), 6)
    3.141593
    """
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    q = np.where(np.sum(p * q, axis=-1, keepdims=True) < 0, -q, q)
    return 4.0 * np.arctan2(np.linalg.norm(p - q, axis=-1), np.linalg.norm(p + q, axis=-1))


def _log(q: np.ndarray) -> np.ndarray:
    """Rotation vectors (angle in [0, pi] times axis) of unit quaternions."""
    q = np.where(q[..., 3:] < 0, -q, q)  # the shorter of the two rotations q and -q describe
    v, w = q[..., :3], q[..., 3]
    s = np.linalg.norm(v, axis=-1)
    small = s < _SMALL
    # angle / sin(angle / 2) = 2 atan2(s, w) / s -> 2 / w (w ~ 1 there) with error ~s^2 / 3
    scale = np.where(small, 2.0 / np.where(small, w, 1.0), 2.0 * np.arctan2(s, w) / np.where(small, 1.0, s))
    return v * scale[..., None]


def _exp(v: np.ndarray) -> np.ndarray:
    """Unit quaternions of rotation vectors."""
    angle = np.linalg.norm(v, axis=-1)
    small = angle < _SMALL
    # sin(angle / 2) / angle -> 1/2 - angle^2 / 48
    scale = np.where(small, 0.5 - angle**2 / 48.0, np.sin(angle / 2.0) / np.where(small, 1.0, angle))
    return np.concatenate([v * scale[..., None], np.cos(angle / 2.0)[..., None]], axis=-1)


def log_map(q, reference=None) -> np.ndarray:
    """Rotation vectors of ``q`` relative to ``reference``, in the reference's frame.

    ``v = log(reference^-1 * q)``: the axis times the angle (at most pi) of
    the rotation that takes the reference to ``q``. The inverse is
    :func:`exp_map`.

    Parameters
    ----------
    q : array-like of shape (n, 4) or (4,)
        Unit quaternions, scalar-last.
    reference : array-like of shape (n, 4) or (4,), optional
        One reference for all samples or one per sample; default the
        identity.

    Returns
    -------
    ndarray of shape (n, 3) or (3,)

    Examples
    --------
    >>> c = np.cos(np.pi / 4)
    >>> log_map([0.0, 0.0, c, c]).round(6).tolist()
    [0.0, 0.0, 1.570796]
    >>> log_map([0.0, 0.0, c, c], reference=[0.0, 0.0, c, c]).tolist()
    [0.0, 0.0, 0.0]
    """
    q = check_quaternions(q, name="q")
    if reference is not None:
        q = quaternion_multiply(quaternion_conjugate(check_quaternions(reference, name="reference")), q)
    return _log(q)


def exp_map(v, reference=None) -> np.ndarray:
    """Unit quaternions ``reference * exp(v)`` of rotation vectors ``v`` (the inverse of :func:`log_map`).

    Parameters
    ----------
    v : array-like of shape (n, 3) or (3,)
        Rotation vectors (axis times angle, radians) in the reference's frame.
    reference : array-like of shape (n, 4) or (4,), optional
        Default the identity.

    Returns
    -------
    ndarray of shape (n, 4) or (4,), scalar-last

    Examples
    --------
    >>> exp_map([0.0, 0.0, np.pi]).round(6).tolist()
    [0.0, 0.0, 1.0, 0.0]
    """
    v = check_array(v, name="v", ndim=(1, 2))
    if v.shape[-1] != 3:
        raise ValueError(f"v: expected rotation vectors of 3 components, got shape {v.shape}")
    q = _exp(v)
    if reference is not None:
        q = quaternion_multiply(check_quaternions(reference, name="reference"), q)
    return q


def slerp(t, q, t_new) -> np.ndarray:
    """Orientations at times ``t_new``, by spherical linear interpolation of the stream ``(t, q)``.

    Between two samples the rotation turns about one fixed axis at a constant
    rate (the shorter way: the stream is made continuous first). Outside
    ``[t[0], t[-1]]`` the edge orientation is held, as
    :meth:`Demonstration.from_clocks` holds every stream's edges.

    Parameters
    ----------
    t : array-like of shape (n,)
        Strictly increasing times.
    q : array-like of shape (n, 4)
        Unit quaternions, scalar-last.
    t_new : array-like of shape (m,)
        Any times.

    Returns
    -------
    ndarray of shape (m, 4)
        Unit quaternions, continuous where ``t_new`` increases.

    Examples
    --------
    >>> s = np.sin(np.pi / 4)
    >>> slerp([0.0, 1.0], [[0, 0, 0, 1.0], [0, 0, s, s]], [0.5]).round(6).tolist()
    [[0.0, 0.0, 0.382683, 0.92388]]
    """
    q = check_quaternions(q, name="q")
    if q.ndim != 2:
        raise ValueError(f"q: expected an orientation stream of shape (n, 4), got shape {q.shape}")
    t = check_time(t, name="t", n_steps=q.shape[0])
    t_new = check_array(t_new, name="t_new", ndim=1)
    q = continuous_quaternions(q)
    if q.shape[0] == 1:
        return np.repeat(q, t_new.shape[0], axis=0)
    lo = np.clip(np.searchsorted(t, t_new, side="right") - 1, 0, q.shape[0] - 2)
    u = np.clip((t_new - t[lo]) / (t[lo + 1] - t[lo]), 0.0, 1.0)
    step = _log(quaternion_multiply(quaternion_conjugate(q[lo]), q[lo + 1]))
    return quaternion_multiply(q[lo], _exp(u[:, None] * step))


def quaternion_to_matrix(q) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of unit quaternions ``(..., 4)``, scalar-last.

    Examples
    --------
    >>> quaternion_to_matrix([0.0, 0.0, 1.0, 0.0]).round(12).tolist()
    [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    q = np.asarray(q, dtype=float)
    x, y, z, w = (q[..., k] for k in range(4))
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


def matrix_to_quaternion(R) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` (scalar-last, ``w >= 0``) of rotation matrices ``(..., 3, 3)``.

    Each one is computed from the largest of ``w, x, y, z`` (Shepperd's
    choice), so no component is recovered from a difference of nearly equal
    numbers.

    Examples
    --------
    >>> matrix_to_quaternion(np.diag([-1.0, -1.0, 1.0])).tolist()
    [0.0, 0.0, 1.0, 0.0]
    """
    R = np.asarray(R, dtype=float)
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    # 4 w^2, 4 x^2, 4 y^2, 4 z^2 (up to round-off; the largest is at least 1)
    diag = np.stack([1 + m00 + m11 + m22, 1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22],
                    axis=-1)
    k = np.argmax(diag, axis=-1)
    r = np.sqrt(np.take_along_axis(diag, k[..., None], axis=-1)[..., 0])  # 2 |largest component|
    d21, d02, d10 = R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]
    s01, s02, s12 = R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1]
    # Rows: 4 * (x, y, z, w) times the largest component, for each choice of the largest.
    cases = np.stack([
        np.stack([d21, d02, d10, r * r], axis=-1),
        np.stack([r * r, s01, s02, d21], axis=-1),
        np.stack([s01, r * r, s12, d02], axis=-1),
        np.stack([s02, s12, r * r, d10], axis=-1),
    ], axis=-2)
    q = np.take_along_axis(cases, k[..., None, None], axis=-2)[..., 0, :] / (2.0 * r[..., None])
    return np.where(q[..., 3:] < 0, -q, q)
