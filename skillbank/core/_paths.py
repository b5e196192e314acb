"""Geometry of sampled paths: the one resampler and the path Laplacian.

Every part of skillbank that changes the number of samples of a trajectory
(featurisers, representations, trajectory editing, selection, metrics) calls
:func:`resample_many` (or its one-trajectory form :func:`resample`), and every
part that needs the Laplacian (differential) coordinates of a path calls
:func:`laplacian_matrix` / :func:`neighbour_weights`.
"""

from __future__ import annotations

import numpy as np

from ._validation import check_array, check_positive, check_time

__all__ = ["resample", "resample_many", "laplacian_matrix", "neighbour_weights"]

_BY = ("time", "arc_length")


def resample_many(trajs, times, n_points: int, by: str = "time") -> np.ndarray:
    """Resample trajectories of any lengths to ``n_points`` each, in one vectorised pass.

    ``by="time"`` spaces the new samples evenly in time from each
    trajectory's first to last time stamp; ``by="arc_length"`` evenly along
    the path (a trajectory that never moves falls back to time). Values are
    interpolated linearly.

    Parameters
    ----------
    trajs : list of ndarray of shape (n_k, n_dims)
    times : list of ndarray of shape (n_k,)
        Strictly increasing time stamps (``arange(n_k)`` for even phase).
    n_points : int
    by : {"time", "arc_length"}, default="time"

    Returns
    -------
    ndarray of shape (n_trajectories, n_points, n_dims)

    Examples
    --------
    >>> Y = np.array([[0.0], [1.0], [3.0]])
    >>> resample_many([Y], [np.arange(3.0)], 4, by="arc_length")[0].ravel().tolist()
    [0.0, 1.0, 2.0, 3.0]
    """
    if by not in _BY:
        raise ValueError(f"by: expected one of {list(_BY)}, got {by!r}")
    lengths = np.array([a.shape[0] for a in trajs])
    Y = np.concatenate(trajs)
    owner = np.repeat(np.arange(len(trajs)), lengths)
    first = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    # Per-sample progress in [0, 1] within its own trajectory.
    t = np.concatenate(times).astype(float)
    span_t = t[first + lengths - 1] - t[first]
    by_time = (t - t[first][owner]) / np.where(span_t > 0, span_t, 1.0)[owner]
    if by == "arc_length":
        step = np.zeros(Y.shape[0])
        step[1:] = np.linalg.norm(np.diff(Y, axis=0), axis=1)
        step[first] = 0.0
        # Each trajectory's own running sum: one over the whole batch, less the sum before the
        # trajectory, would lose the low bits of a short path after long ones.
        cum = np.concatenate([np.cumsum(step[f:f + n]) for f, n in zip(first, lengths, strict=True)])
        total = cum[first + lengths - 1]
        progress = np.where((total > 0)[owner], cum / np.where(total > 0, total, 1.0)[owner], by_time)
    else:
        progress = by_time
    # One global monotone key, trajectory index + progress, finds every query's sample in one
    # searchsorted. Adding 2k rounds away the low bits of a progress, so the index is then corrected
    # on the trajectory's own progress, and the weight taken from it: a trajectory resamples to the
    # same bits wherever it stands in the batch.
    key = 2.0 * owner + progress
    query = np.linspace(0.0, 1.0, n_points)
    q = np.tile(query, len(trajs))
    start_of = np.repeat(first, n_points)
    end_of = start_of + np.repeat(lengths, n_points) - 1
    hi = np.searchsorted(key, (2.0 * np.arange(len(trajs))[:, None] + query[None, :]).ravel(), side="left")
    hi = np.clip(hi, start_of, end_of)
    while True:  # hi: the first sample of the trajectory whose progress is >= q (else its last)
        up = (progress[hi] < q) & (hi < end_of)
        down = (hi > start_of) & (progress[np.maximum(hi - 1, 0)] >= q)
        if not (up.any() or down.any()):
            break
        hi = hi + up - down
    lo = np.maximum(hi - 1, start_of)
    gap = progress[hi] - progress[lo]
    w = np.where(gap > 0, (q - progress[lo]) / np.where(gap > 0, gap, 1.0), 0.0)
    out = Y[lo] + np.clip(w, 0.0, 1.0)[:, None] * (Y[hi] - Y[lo])
    return out.reshape(len(trajs), n_points, Y.shape[1])


def resample(Y, n_points: int, *, t=None, by: str = "time") -> np.ndarray:
    """One trajectory ``Y`` (n, n_dims) resampled to ``n_points`` samples (see :func:`resample_many`).

    Without ``t`` the samples are taken as evenly spaced (so ``by="time"``
    means evenly in phase). A trajectory that already has ``n_points`` evenly
    spaced samples is returned as an exact copy.

    Examples
    --------
    >>> resample(np.array([[0.0], [2.0]]), 3).ravel().tolist()
    [0.0, 1.0, 2.0]
    """
    Y = check_array(Y, name="Y", ndim=(1, 2), as_2d=True)
    n_points = check_positive(n_points, name="n_points", integer=True)
    n = Y.shape[0]
    t = np.arange(n, dtype=float) if t is None else check_time(t, n_steps=n)
    if n == n_points and by == "time" and _even(t):
        return Y.copy()
    return resample_many([Y], [t], n_points, by)[0]


def _even(t: np.ndarray) -> bool:
    if t.shape[0] < 3:
        return True
    grid = np.linspace(t[0], t[-1], t.shape[0])
    return bool(np.allclose(t, grid, rtol=0.0, atol=1e-9 * max(t[-1] - t[0], 1e-300)))


def neighbour_weights(n: int, t=None):
    """Weights ``a_i, b_i`` (``a_i + b_i = 1``) of the previous and next samples in Laplacian row ``i``.

    Uniform (1/2, 1/2) without time stamps; with ``t``, inversely proportional to
    the time steps so that a constant-velocity path has zero Laplacian.

    Examples
    --------
    >>> a, b = neighbour_weights(3, np.array([0.0, 1.0, 3.0]))
    >>> float(a[1]), float(b[1])
    (0.6666666666666666, 0.33333333333333337)
    """
    a = np.full(n, 0.5)
    if t is not None and n >= 3:
        dt = np.diff(t)
        a[1:-1] = dt[1:] / (dt[:-1] + dt[1:])
    return a, 1.0 - a


def laplacian_matrix(n: int, t=None):
    """The path Laplacian ``L`` as a sparse ``(n, n)`` matrix.

    Interior rows ``P_i - a_i P_{i-1} - b_i P_{i+1}``; the end rows are the
    one-neighbour rows ``P_0 - P_1`` and ``P_{n-1} - P_{n-2}``.

    Examples
    --------
    >>> laplacian_matrix(4).toarray()[1].tolist()
    [-0.5, 1.0, -0.5, 0.0]
    """
    import scipy.sparse as sp  # heavy; only the metrics that need L pay for it

    a, b = neighbour_weights(n, t)
    if n == 1:
        return sp.csr_matrix((1, 1))
    lower = -a[1:].copy()
    upper = -b[:-1].copy()
    upper[0] = -1.0
    lower[-1] = -1.0
    return sp.diags([lower, np.ones(n), upper], [-1, 0, 1], format="csr")
