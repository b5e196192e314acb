"""Dynamic time warping, batched over trajectories, and DTW landmark features."""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from .._validation import check_fraction, check_positive
from ._features import as_trajectories, resampled_input

__all__ = ["dtw_distance", "DTWFeatures"]


def _band(n_rows: int, n_cols: int, window: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Column range [lo, hi] allowed on each row (Sakoe-Chiba band around the diagonal)."""
    if window is None:
        return np.zeros(n_rows, dtype=np.intp), np.full(n_rows, n_cols - 1, dtype=np.intp)
    centre = np.arange(n_rows) * ((n_cols - 1) / max(n_rows - 1, 1))
    radius = max(1.0, window * max(n_rows, n_cols))
    lo = np.clip(np.floor(centre - radius), 0, n_cols - 1).astype(np.intp)
    hi = np.clip(np.ceil(centre + radius), 0, n_cols - 1).astype(np.intp)
    return lo, hi


def dtw_many(Q: np.ndarray, R: np.ndarray, window: float | None = None) -> np.ndarray:
    """DTW cost of every trajectory in ``Q`` (n, n_rows, d) against one trajectory ``R`` (n_cols, d).

    The local cost is the Euclidean distance between samples; the result is
    the smallest sum of local costs along a monotone warping path. Each row of
    the cost table is computed for all ``n`` trajectories at once: with
    ``P`` the running sum of the row's local costs, the left-to-right
    recurrence ``D[i, j] = min(b[j], c[i, j] + D[i, j-1])`` is
    ``P[j] + cummin(b - P)[j]``, so no loop runs over columns or trajectories.

    Examples
    --------
    >>> R = np.array([[0.0], [1.0], [2.0]])
    >>> dtw_many(np.array([[[0.0], [0.0], [1.0], [2.0]]]), R).tolist()
    [0.0]
    """
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


def dtw_distance(A, B, *, window=None) -> float:
    """DTW distance between two trajectories (lengths may differ).

    Parameters
    ----------
    A : array-like of shape (n_a, n_dims) or Demonstration
    B : array-like of shape (n_b, n_dims) or Demonstration
    window : float in (0, 1], optional
        Sakoe-Chiba band half-width as a fraction of the longer length.

    Returns
    -------
    float
        Sum of Euclidean sample distances along the best warping path.

    Examples
    --------
    >>> dtw_distance([[0.0], [1.0], [2.0]], [[0.0], [1.0], [1.0], [2.0]])
    0.0
    """
    a, b = as_trajectories([A, B], name="A, B")
    if window is not None:
        window = check_fraction(window, name="window")
    return float(dtw_many(a[None], b, window)[0])


class DTWFeatures(TransformerMixin, BaseEstimator):
    """Time-warping-aware features: DTW distances to landmark trajectories.

    Trajectories are resampled in time to ``n_points`` and their start is
    subtracted. Landmarks are chosen from the training set by farthest-point
    sampling under DTW: the first is the trajectory nearest the (Euclidean)
    mean shape, each next one the trajectory farthest from all landmarks so
    far. The features of a trajectory are its DTW distances to the landmarks,
    divided by ``n_points`` (a mean per-sample distance, in the data's units).
    Two demonstrations of the same skill at different speeds get close
    features, unlike pointwise features.

    Parameters
    ----------
    n_landmarks : int, default=8
        Number of landmarks (capped at the number of distinct training
        trajectories).
    n_points : int, default=64
        Samples per trajectory after resampling.
    window : float in (0, 1] or None, default=0.2
        Sakoe-Chiba band as a fraction of ``n_points``; None for no band.

    Attributes
    ----------
    landmarks_ : ndarray of shape (n_landmarks_, n_points, n_dims)
    landmark_indices_ : ndarray of shape (n_landmarks_,)
        Indices of the landmarks in the training list.
    n_features_in_ : int
        Dimensions of each trajectory.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 100)[:, None]
    >>> trajs = [np.hstack([t ** p, np.sin(3 * t)]) for p in (1.0, 1.5, 2.0)]
    >>> DTWFeatures(n_landmarks=2, n_points=32).fit_transform(trajs).shape
    (3, 2)
    """

    def __init__(self, *, n_landmarks=8, n_points=64, window=0.2):
        self.n_landmarks = n_landmarks
        self.n_points = n_points
        self.window = window

    def _prepare(self, X, *, reset: bool) -> np.ndarray:
        R = resampled_input(self, X, reset=reset, by="time")
        return R - R[:, :1, :]

    def _window(self):
        return None if self.window is None else check_fraction(self.window, name="window")

    def fit(self, X, y=None):
        """Choose the landmarks among the training trajectories."""
        k = check_positive(self.n_landmarks, name="n_landmarks", integer=True)
        window = self._window()
        R = self._prepare(X, reset=True)
        flat = R.reshape(R.shape[0], -1)
        first = int(np.argmin(np.sum((flat - flat.mean(axis=0)) ** 2, axis=1)))
        chosen = [first]
        nearest = dtw_many(R, R[first], window)
        # The running-sum recurrence leaves round-off of this size on identical trajectories.
        tiny = 1e-9 * (1.0 + float(np.abs(R).max())) * R.shape[1]
        while len(chosen) < min(k, R.shape[0]):
            nxt = int(np.argmax(nearest))
            if nearest[nxt] <= tiny:  # every trajectory coincides with a landmark
                break
            chosen.append(nxt)
            nearest = np.minimum(nearest, dtw_many(R, R[nxt], window))
        self.landmark_indices_ = np.array(chosen, dtype=np.intp)
        self.landmarks_ = R[self.landmark_indices_]
        return self

    def transform(self, X):
        """Features of shape ``(n_trajectories, n_landmarks_)``."""
        check_is_fitted(self, "landmarks_")
        window = self._window()
        R = self._prepare(X, reset=False)
        if R.shape[1] != self.landmarks_.shape[1]:
            raise ValueError(f"n_points: changed from {self.landmarks_.shape[1]} at fit to {R.shape[1]}")
        cols = [dtw_many(R, landmark, window) for landmark in self.landmarks_]
        return np.column_stack(cols) / R.shape[1]
