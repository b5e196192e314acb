"""Shape and smoothness metrics of sampled trajectories."""

from __future__ import annotations

import numpy as np

from ..core import Demonstration, laplacian_matrix
from ..core._validation import check_array, check_time
from ._distances import metric

__all__ = [
    "swept_error_area", "angular_similarity", "angular_similarity_matrix", "curvature_deviation",
    "jerk_cost", "path_length",
]


def _same_length(P, Q, *, min_samples=1):
    P = check_array(P, name="P", ndim=(1, 2), as_2d=True, min_samples=min_samples)
    Q = check_array(Q, name="Q", ndim=(1, 2), as_2d=True, min_samples=min_samples)
    if P.shape != Q.shape:
        raise ValueError(f"Q: expected the shape of P {P.shape} (same number of samples), got {Q.shape}")
    return P, Q


#: Dimensions up to which a triangle's area comes from its 2 x 2 minors (d (d - 1) / 2 of them per row).
_MINORS_UP_TO = 16


def _triangle_areas(U, V):
    """Areas of the triangles spanned by rows of U and V, in any dimension (Lagrange's identity)."""
    # Lagrange's identity takes fourth powers of the coordinates, which overflow from ~1e77 on:
    # scale each row by a power of two near its size first (exact, so ordinary results are unchanged).
    size = np.maximum(np.abs(U).max(axis=1, initial=0.0), np.abs(V).max(axis=1, initial=0.0))
    scale = np.ldexp(1.0, np.frexp(size)[1])[:, None]
    U, V = U / scale, V / scale
    if U.shape[1] <= _MINORS_UP_TO:
        # |u x v|^2 as the sum of the squared 2 x 2 minors: no cancellation between |u|^2 |v|^2 and (u.v)^2,
        # which loses the area of a thin triangle (relative error 3e-10 found by Hypothesis in 2-D)
        i, j = np.triu_indices(U.shape[1], k=1)
        minors = U[:, i] * V[:, j] - U[:, j] * V[:, i]
        return 0.5 * np.sqrt(np.einsum("ij,ij->i", minors, minors)) * scale[:, 0] ** 2
    uu, vv, uv = (np.einsum("ij,ij->i", a, b) for a, b in ((U, U), (V, V), (U, V)))
    return 0.5 * np.sqrt(np.maximum(uu * vv - uv * uv, 0.0)) * scale[:, 0] ** 2


@metric
def swept_error_area(P, Q) -> float:
    """Area swept between two curves of equal length.

    For each pair of consecutive samples the quadrilateral ``P_i, P_{i+1},
    Q_{i+1}, Q_i`` is split along its diagonal ``P_i Q_{i+1}`` into two
    triangles, whose areas ``|u||v| sin(angle) / 2`` are defined in any number
    of dimensions; the result is the sum over all ``n - 1`` quadrilaterals. In
    2-D, for quadrilaterals that do not fold over, this is the area between the
    curves. 1-D curves sweep no area (add a time column to compare them).

    Examples
    --------
    >>> swept_error_area([[0, 0], [1, 0], [2, 0]], [[0, 1], [1, 1], [2, 1]])
    2.0
    """
    P, Q = _same_length(P, Q)
    if P.shape[1] == 1:
        return 0.0
    A, B, C, D = P[:-1], P[1:], Q[1:], Q[:-1]
    return float(_triangle_areas(B - A, C - A).sum() + _triangle_areas(C - A, D - A).sum())


def _positions(x, name: str) -> np.ndarray:
    """Array-like or Demonstration (its ``"position"`` stream) as ``(n_steps, n_dims)``."""
    if isinstance(x, Demonstration):
        if "position" not in x.streams:
            raise ValueError(f"{name}: expected a Demonstration with a 'position' stream, "
                             f"got streams {x.stream_names}")
        x = x["position"]
    return check_array(x, name=name, ndim=(1, 2), as_2d=True)


def _unit_steps(Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit displacements along the step axis (last but one) and a mask of the non-zero ones."""
    D = np.diff(Y, axis=-2)
    norm = np.sqrt(np.einsum("...i,...i->...", D, D))
    moving = norm > 0.0
    return D / np.where(moving, norm, 1.0)[..., None], moving


@metric
def angular_similarity_matrix(A, B) -> np.ndarray:
    """Angular similarity of every trajectory of ``A`` with every trajectory of ``B``.

    The batched form of :func:`angular_similarity`, used by clustering
    (:class:`skillbank.clustering.AngularSimilarityFeatures`).

    Parameters
    ----------
    A : array-like of shape (n_a, n_steps, n_dims)
    B : array-like of shape (n_b, n_steps, n_dims)
        Same number of samples and dimensions as ``A``.

    Returns
    -------
    ndarray of shape (n_a, n_b)

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 5)[:, None]
    >>> angular_similarity_matrix([t, -t], [t]).ravel().tolist()
    [0.0, 0.8]
    """
    A = check_array(A, name="A", ndim=3)
    B = check_array(B, name="B", ndim=3)
    if A.shape[1:] != B.shape[1:]:
        raise ValueError(f"B: expected trajectories of shape {A.shape[1:]} (n_steps, n_dims) like A, "
                         f"got {B.shape[1:]}; angular similarity needs the same number of samples")
    n = A.shape[1]
    UA, mA = _unit_steps(A)
    UB, mB = _unit_steps(B)
    out = np.empty((A.shape[0], B.shape[0]))
    # Chunk over A so that the (chunk, n_b, n - 1) block of cosines stays around 8 MB.
    chunk = max(1, int(1e6 // max(1, B.shape[0] * max(n - 1, 1))))
    for s in range(0, A.shape[0], chunk):
        cos = np.einsum("atd,btd->abt", UA[s:s + chunk], UB)
        angle = np.arccos(np.clip(cos, -1.0, 1.0))
        angle *= mA[s:s + chunk, None, :] & mB[None, :, :]  # a step standing still counts 0
        out[s:s + chunk] = angle.sum(axis=2) / (np.pi * n)
    return out


@metric
def angular_similarity(P, Q) -> float:
    """Angular (dis)similarity of two equally long trajectories, as defined by the paper's authors.

    For each of the ``n - 1`` steps, the angle between the displacement of ``P``
    and that of ``Q`` over the step, divided by pi; the sum over the steps is
    divided by ``n`` (not ``n - 1``). A step where either trajectory stands still
    counts 0. 0 for curves moving in the same directions, up to ``(n - 1) / n``
    for opposite ones. This is the paper's RAIL clustering feature; it is also
    exported as ``skillbank.clustering.angular_similarity``.

    Parameters
    ----------
    P, Q : array-like of shape (n_steps, n_dims) or (n_steps,), or Demonstration
        A Demonstration gives its ``"position"`` stream.

    Returns
    -------
    float

    Examples
    --------
    >>> angular_similarity([[0, 0], [1, 0], [2, 0]], [[0, 0], [0, 1], [1, 1]])
    0.16666666666666666
    """
    P, Q = _positions(P, "P"), _positions(Q, "Q")
    if P.shape[1] != Q.shape[1]:
        raise ValueError(f"Q: expected {P.shape[1]} columns to match P, got {Q.shape[1]}")
    if P.shape[0] != Q.shape[0]:
        raise ValueError(f"Q: expected the same number of samples as P ({P.shape[0]}), got {Q.shape[0]}; "
                         "resample them first")
    return float(angular_similarity_matrix(P[None], Q[None])[0, 0])


@metric
def curvature_deviation(P, Q, t=None) -> float:
    """Mean Euclidean distance between the Laplacian coordinates of two equally long curves.

    The Laplacian coordinate of a sample is the sample minus the weighted mean
    of its neighbours (the operator that LTE keeps, see
    :func:`skillbank.core.laplacian_matrix`); it measures local curvature and
    ignores translation. Returns ``mean_i |(L P)_i - (L Q)_i|``.

    Parameters
    ----------
    P, Q : array-like of shape (n_steps, n_dims)
    t : array-like of shape (n_steps,), optional
        Time stamps for the Laplacian weights (default: uniform).

    Examples
    --------
    >>> curvature_deviation([[0, 0], [1, 0], [2, 0]], [[0, 0], [1, 1], [2, 0]])
    1.0
    """
    P, Q = _same_length(P, Q)
    t = None if t is None else check_time(t, n_steps=P.shape[0])
    R = laplacian_matrix(P.shape[0], t) @ (P - Q)
    return float(np.linalg.norm(R, axis=1).mean())


@metric
def jerk_cost(Y, t) -> float:
    """Integral of the squared jerk, ``int |d^3 Y / dt^3|^2 dt``, on real time stamps.

    The jerk over each window of 4 samples is 6 times their third divided
    difference (exact for cubic motion, any spacing), placed at the window's
    mean time; the integral is a midpoint sum whose cells split
    ``[t_0, t_{n-1}]`` halfway between those times, so cubic motion gives
    exactly ``36 a^2 (t_{n-1} - t_0)`` for ``Y = a t^3``.

    Parameters
    ----------
    Y : array-like of shape (n_steps, n_dims), n_steps >= 4
    t : array-like of shape (n_steps,)
        Strictly increasing time stamps in seconds.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> round(jerk_cost(t**3, t), 12)  # jerk 6 for 1 s
    36.0
    """
    Y = check_array(Y, name="Y", ndim=(1, 2), as_2d=True, min_samples=4)
    t = check_time(t, n_steps=Y.shape[0])
    d1 = np.diff(Y, axis=0) / np.diff(t)[:, None]
    d2 = np.diff(d1, axis=0) / (t[2:] - t[:-2])[:, None]
    d3 = np.diff(d2, axis=0) / (t[3:] - t[:-3])[:, None]
    centre = (t[:-3] + t[1:-2] + t[2:-1] + t[3:]) / 4.0
    edges = np.concatenate([[t[0]], 0.5 * (centre[1:] + centre[:-1]), [t[-1]]])
    return float((36.0 * np.einsum("ij,ij->i", d3, d3) * np.diff(edges)).sum())


@metric
def path_length(Y) -> float:
    """Length of the polyline through the samples.

    Examples
    --------
    >>> path_length([[0, 0], [3, 4], [3, 5]])
    6.0
    """
    Y = check_array(Y, name="Y", ndim=(1, 2), as_2d=True)
    return float(np.linalg.norm(np.diff(Y, axis=0), axis=1).sum())
