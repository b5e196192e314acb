"""Curve distances computed by dynamic programming over anti-diagonals.

Both recurrences make cell ``(i, j)`` depend on ``(i-1, j)``, ``(i, j-1)`` and
``(i-1, j-1)`` only, so every cell of an anti-diagonal ``i + j = k`` depends on
the two previous anti-diagonals: each diagonal is one vectorised step, and
only two diagonals are kept in memory.
"""

from __future__ import annotations

import numpy as np

from .._validation import check_array

__all__ = ["frechet_distance", "dtw_distance"]


def _pair(P, Q):
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


def dtw_distance(P, Q) -> float:
    """Dynamic time warping distance: least total Euclidean cost of a monotone alignment.

    ``D[i, j] = |P_i - Q_j| + min(D[i-1, j], D[i, j-1], D[i-1, j-1])``, and the
    result is ``D[n-1, m-1]`` (not normalised by the path length).

    Parameters
    ----------
    P : array-like of shape (n, n_dims)
    Q : array-like of shape (m, n_dims)

    Returns
    -------
    float

    Examples
    --------
    >>> dtw_distance([[0.0], [1.0], [2.0]], [[0.0], [2.0]])
    1.0
    """
    P, Q = _pair(P, Q)
    return _antidiagonal_dp(P, Q, np.add)
