"""Curve distances by dynamic programming: discrete Fréchet over anti-diagonals, DTW by rows.

Both recurrences make cell ``(i, j)`` depend on ``(i-1, j)``, ``(i, j-1)`` and
``(i-1, j-1)`` only, so every cell of an anti-diagonal ``i + j = k`` depends on
the two previous anti-diagonals: each diagonal is one vectorised step, and
only two diagonals are kept in memory.
"""

from __future__ import annotations

import functools

import numpy as np

from ..core import Demonstration
from ..core._validation import check_array, check_finite_result, check_fraction, numerical_errors

__all__ = ["frechet_distance", "dtw_distance", "dtw_many", "metric"]


def metric(func):
    """Run a public metric under :func:`numerical_errors` and check its result is finite.

    Inputs are bounded by the validator; what can still overflow (a jerk on
    tiny time steps, say) becomes one ValueError naming the metric.
    """
    name = func.__name__

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with numerical_errors(name):
            return check_finite_result(func(*args, **kwargs), name=name)

    return wrapper


def _pair(P, Q):
    P, Q = (x["position"] if isinstance(x, Demonstration) and "position" in x else x for x in (P, Q))
    P = check_array(P, name="P", ndim=(1, 2), as_2d=True)
    Q = check_array(Q, name="Q", ndim=(1, 2), as_2d=True)
    if P.shape[1] != Q.shape[1]:
        raise ValueError(f"Q: expected {P.shape[1]} columns to match P, got {Q.shape[1]}")
    return P, Q


def _antidiagonal_dp(P, Q, combine):
    """Run ``cur = combine(dist, min(up, left, diag))`` over the anti-diagonals; value at the end."""
    n, m = P.shape[0], Q.shape[0]
    prev2 = np.full(n, np.inf)
    prev1 = np.full(n, np.inf)
    prev1[0] = float(np.linalg.norm(P[0] - Q[0]))
    for k in range(1, n + m - 1):
        lo, hi = max(0, k - m + 1), min(k, n - 1)
        i = np.arange(lo, hi + 1)
        D = P[lo:hi + 1] - Q[k - hi:k - lo + 1][::-1]
        dist = np.sqrt(np.einsum("ij,ij->i", D, D))
        best = prev1[i]  # left (i, j - 1); inf at j = 0 since diagonal k - 1 never set row k
        inner = slice(1 if lo == 0 else 0, None)  # up (i - 1, j) and diagonal (i - 1, j - 1) need i >= 1
        ii = i[inner]
        best[inner] = np.minimum(np.minimum(best[inner], prev1[ii - 1]), prev2[ii - 1])
        cur = np.full(n, np.inf)
        cur[lo:hi + 1] = combine(dist, best)
        prev2, prev1 = prev1, cur
    return float(prev1[n - 1])


@metric
def frechet_distance(P, Q) -> float:
    """Discrete Fréchet distance between two sampled curves.

    The smallest, over monotone couplings of the samples of ``P`` and ``Q``
    (both walked from first to last sample, never backwards), of the largest
    Euclidean distance between coupled samples (Eiter and Mannila, 1994).

    Parameters
    ----------
    P : array-like of shape (n, n_dims)
    Q : array-like of shape (m, n_dims)

    Returns
    -------
    float

    Examples
    --------
    >>> frechet_distance([[0, 0], [1, 0], [2, 0]], [[0, 1], [2, 1]])
    1.4142135623730951
    """
    P, Q = _pair(P, Q)
    return _antidiagonal_dp(P, Q, np.maximum)


def _band(n_rows: int, n_cols: int, window: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Column range [lo, hi] allowed on each row (Sakoe-Chiba band around the diagonal)."""
    if window is None:
        return np.zeros(n_rows, dtype=np.intp), np.full(n_rows, n_cols - 1, dtype=np.intp)
    centre = np.arange(n_rows) * ((n_cols - 1) / max(n_rows - 1, 1))
    radius = max(1.0, window * max(n_rows, n_cols))
    lo = np.clip(np.floor(centre - radius), 0, n_cols - 1).astype(np.intp)
    hi = np.clip(np.ceil(centre + radius), 0, n_cols - 1).astype(np.intp)
    return lo, hi


@metric
def dtw_many(Q: np.ndarray, R: np.ndarray, window: float | None = None) -> np.ndarray:
    """DTW cost of every trajectory in ``Q`` (n, n_rows, d) against one trajectory ``R`` (n_cols, d).

    The local cost is the Euclidean distance between samples; the result is
    the smallest sum of local costs along a monotone warping path
    (``D[i, j] = |Q_i - R_j| + min(D[i-1, j], D[i, j-1], D[i-1, j-1])``). Each
    row of the cost table is computed for all ``n`` trajectories at once: with
    ``P`` the running sum of the row's local costs, the left-to-right
    recurrence ``D[i, j] = min(b[j], c[i, j] + D[i, j-1])`` is
    ``P[j] + cummin(b - P)[j]``, so no loop runs over columns or trajectories,
    and only one row is kept (memory linear in the lengths).

    Examples
    --------
    >>> R = np.array([[0.0], [1.0], [2.0]])
    >>> dtw_many(np.array([[[0.0], [0.0], [1.0], [2.0]]]), R).tolist()
    [0.0]
    """
    Q = check_array(Q, name="Q", ndim=3)
    R = check_array(R, name="R", ndim=2, n_dims=Q.shape[2])
    if window is not None:
        window = check_fraction(window, name="window")
    n, n_rows, _ = Q.shape
    n_cols = R.shape[0]
    lo, hi = _band(n_rows, n_cols, window)
    cols = np.arange(n_cols)
    prev = None
    for i in range(n_rows):
        diff = Q[:, i, None, :] - R[None, :, :]
        cost = np.sqrt(np.einsum("ncd,ncd->nc", diff, diff))
        outside = (cols < lo[i]) | (cols > hi[i])
        cost[:, outside] = 0.0
        P = np.cumsum(cost, axis=1)
        if prev is None:
            b = np.full((n, n_cols), np.inf)
            b[:, 0] = cost[:, 0]
        else:
            b = cost + np.minimum(prev, np.concatenate([np.full((n, 1), np.inf), prev[:, :-1]], axis=1))
        b[:, outside] = np.inf
        row = P + np.minimum.accumulate(b - P, axis=1)
        row[:, outside] = np.inf
        prev = row
    return prev[:, -1]


@metric
def dtw_distance(P, Q, *, window=None) -> float:
    """Dynamic time warping distance: least total Euclidean cost of a monotone alignment.

    ``D[i, j] = |P_i - Q_j| + min(D[i-1, j], D[i, j-1], D[i-1, j-1])``, and the
    result is ``D[n-1, m-1]`` (not normalised by the path length). Lengths may
    differ. Computed by :func:`dtw_many`, in memory linear in the lengths.

    Parameters
    ----------
    P : array-like of shape (n, n_dims)
    Q : array-like of shape (m, n_dims)
    window : float in (0, 1], optional
        Sakoe-Chiba band half-width as a fraction of the longer length; None for no band.

    Returns
    -------
    float

    Examples
    --------
    >>> dtw_distance([[0.0], [1.0], [2.0]], [[0.0], [2.0]])
    1.0
    """
    P, Q = _pair(P, Q)
    if window is not None:
        window = check_fraction(window, name="window")
    return float(dtw_many(P[None], Q, window)[0])
