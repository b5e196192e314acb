"""DTW landmark features (the DTW itself is :func:`skillbank.metrics.dtw_many`)."""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from ..core._validation import check_finite_result, check_fraction, check_positive, numerical_errors
from ..metrics import dtw_many
from ._features import resampled_input

__all__ = ["DTWFeatures"]


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
        with numerical_errors("DTWFeatures.fit"):
            return self._fit(X, k, window)

    def _fit(self, X, k, window):
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
        with numerical_errors("DTWFeatures.transform"):
            cols = [dtw_many(R, landmark, window) for landmark in self.landmarks_]
            F = np.column_stack(cols) / R.shape[1]
        return check_finite_result(F, name="DTWFeatures.transform")
