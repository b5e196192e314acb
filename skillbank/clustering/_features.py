"""Featurisers that turn a list of trajectories into a feature matrix for clustering."""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.decomposition import PCA
from sklearn.utils.validation import check_is_fitted

from ..core import Demonstration, resample_many
from ..core._validation import check_array, check_finite_result, check_positive, numerical_errors, summarise
from ..metrics import angular_similarity_matrix

__all__ = [
    "AngularSimilarityFeatures", "TrajectoryFeatures", "as_trajectories", "resampled_input", "pca_components",
]


def as_trajectories(X, *, name: str = "X", with_time: bool = False):
    """Validate a collection of trajectories.

    Accepts a list of arrays ``(n_steps, n_dims)`` or of
    :class:`~skillbank.Demonstration` (their ``"position"`` stream), or one
    3-D array ``(n_trajectories, n_steps, n_dims)``. Returns a list of
    float64 arrays (and, with ``with_time``, the matching time vectors: the
    demonstration's ``t`` or ``arange(n_steps)``).
    """
    if isinstance(X, Demonstration):
        raise ValueError(f"{name}: expected a list of trajectories, got a single Demonstration; "
                         "wrap it in a list")
    if isinstance(X, np.ndarray) and X.dtype != object:
        if X.ndim != 3:
            raise ValueError(f"{name}: expected a list of (n_steps, n_dims) trajectories or a 3-D array, "
                             f"got a {X.ndim}-D array of shape {X.shape}; wrap a single trajectory in a list")
        X = list(X)
    try:
        items = list(X)
    except TypeError:
        raise ValueError(f"{name}: expected a list of trajectories, got {type(X).__name__}") from None
    if not items:
        raise ValueError(f"{name}: expected at least one trajectory, got none")
    trajs, times = [], []
    for k, item in enumerate(items):
        if isinstance(item, Demonstration):
            if "position" not in item.streams:
                raise ValueError(f"{name}[{k}]: expected a Demonstration with a 'position' stream, "
                                 f"got streams {sorted(item.streams)}")
            trajs.append(item["position"])
            times.append(item.t)
        else:
            arr = check_array(item, name=f"{name}[{k}]", ndim=(1, 2), as_2d=True)
            trajs.append(arr)
            times.append(np.arange(arr.shape[0], dtype=float))
    dims = {a.shape[1] for a in trajs}
    if len(dims) > 1:
        first = trajs[0].shape[1]
        other = [f"{name}[{k}] has {a.shape[1]}" for k, a in enumerate(trajs) if a.shape[1] != first]
        raise ValueError(f"{name}: expected every trajectory to have the same number of dimensions, "
                         f"got {name}[0] has {first}, {summarise(other)}")
    return (trajs, times) if with_time else trajs


def _stack_equal(trajs, *, name: str, n_steps: int | None = None) -> np.ndarray:
    lengths = {a.shape[0] for a in trajs}
    if n_steps is not None:
        lengths.add(n_steps)
    if len(lengths) > 1:
        raise ValueError(f"{name}: angular similarity needs trajectories of equal length, got lengths "
                         f"{summarise(sorted(lengths))}; resample them first")
    return np.stack(trajs)


class AngularSimilarityFeatures(TransformerMixin, BaseEstimator):
    """Angular similarity of each trajectory to a few representatives (the paper's features).

    Parameters
    ----------
    representatives : list of array-like (n_steps, n_dims) or Demonstration
        One representative trajectory per feature. All trajectories, these
        and the ones transformed, must have the same length.

    Attributes
    ----------
    representatives_ : ndarray of shape (n_representatives, n_steps, n_dims)
    n_features_in_ : int
        Dimensions of each trajectory.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 50)
    >>> line, wave = np.column_stack([t, t]), np.column_stack([t, np.sin(6 * t)])
    >>> feats = AngularSimilarityFeatures(representatives=[line, wave]).fit_transform([line, wave])
    >>> feats.shape, round(float(feats[0, 0]), 6), round(float(feats[0, 1]), 3)
    ((2, 2), 0.0, 0.395)
    """

    def __init__(self, *, representatives):
        self.representatives = representatives

    def fit(self, X=None, y=None):
        """Validate and store the representatives (``X`` is only checked for length)."""
        reps = as_trajectories(self.representatives, name="representatives")
        self.representatives_ = _stack_equal(reps, name="representatives")
        self.n_features_in_ = self.representatives_.shape[2]
        if X is not None:
            self._check(X)
        return self

    def _check(self, X):
        trajs = as_trajectories(X, name="X")
        if trajs[0].shape[1] != self.n_features_in_:
            raise ValueError(f"X: expected trajectories with {self.n_features_in_} dimensions like the "
                             f"representatives, got {trajs[0].shape[1]}")
        return _stack_equal(trajs, name="X", n_steps=self.representatives_.shape[1])

    def transform(self, X):
        """Features of shape ``(n_trajectories, n_representatives)``."""
        check_is_fitted(self, "representatives_")
        R = self._check(X)
        with numerical_errors("AngularSimilarityFeatures.transform"):
            F = angular_similarity_matrix(R, self.representatives_)
        return check_finite_result(F, name="AngularSimilarityFeatures.transform")

    def get_feature_names_out(self, input_features=None):
        check_is_fitted(self, "representatives_")
        return np.array([f"angular_similarity{i}" for i in range(self.representatives_.shape[0])],
                        dtype=object)


def resampled_input(estimator, X, *, reset: bool, by: str) -> np.ndarray:
    """The featurisers' common input step: check ``n_points``, read the
    trajectories, record or check their dimension, resample to ``(n, n_points, d)``."""
    n_points = check_positive(estimator.n_points, name="n_points", integer=True)
    if n_points < 2:
        raise ValueError(f"n_points: expected an integer >= 2, got {estimator.n_points!r}")
    trajs, times = as_trajectories(X, name="X", with_time=True)
    if reset:
        estimator.n_features_in_ = trajs[0].shape[1]
    elif trajs[0].shape[1] != estimator.n_features_in_:
        raise ValueError(f"X: expected trajectories with {estimator.n_features_in_} dimensions, "
                         f"got {trajs[0].shape[1]}")
    return resample_many(trajs, times, int(n_points), by)


class FlatPCAMixin:
    """``fit`` and ``transform`` for featurisers that flatten (``_flat``) then
    optionally project with a PCA fitted in ``fit_transform``."""

    #: Cut a count of components larger than the data allows (else it is an error).
    _clip_components = False
    #: What the training trajectories have in common when PCA finds no variance (the error says it).
    _no_variance = "the same features (to float64 precision)"

    def fit(self, X, y=None):
        """Fit the PCA on the training trajectories."""
        self.fit_transform(X)
        return self

    def transform(self, X):
        """Features of shape ``(n_trajectories, n_components)``."""
        check_is_fitted(self, "n_features_in_")
        step = f"{type(self).__name__}.transform"
        with numerical_errors(step):
            F = self._flat(X, reset=False)
            F = F if self.pca_ is None else self.pca_.transform(F)
        return check_finite_result(F, name=step)

    def fit_transform(self, X, y=None):
        """Fit and return the features of ``X``, shape ``(n_trajectories, n_components)``."""
        step = f"{type(self).__name__}.fit_transform"
        with numerical_errors(step):
            F = self._flat(X, reset=True)
            if self.n_components is None:
                self.pca_ = None
                return check_finite_result(F, name=step)
            if F.shape[0] < 2:
                raise ValueError(f"X: expected at least 2 trajectories to fit the PCA, got {F.shape[0]}; "
                                 "pass n_components=None to skip it")
            n_comp = pca_components(self.n_components, F.shape, clip=self._clip_components)
            self._check_variance(F)
            self.pca_ = PCA(n_components=n_comp, random_state=self.random_state)
            F = self.pca_.fit_transform(F)
        return check_finite_result(F, name=step)

    def _check_variance(self, F):
        """Raise a ValueError when the flattened features leave PCA no variance to keep."""
        if not np.any(F != F[0]) or not F.var(axis=0).sum() > 0.0:  # differences too small to square
            raise ValueError(f"X: every trajectory has {self._no_variance}, so PCA has no variance to keep; "
                             "pass n_components=None")


def pca_components(value, shape, *, clip: bool):
    """Check ``n_components`` of the PCA step against the feature matrix ``shape``.

    A count (int >= 1; with ``clip`` cut to what the data allows, else at most
    ``min(n_samples, n_features)``) or a fraction of variance in (0, 1).
    """
    limit = min(shape)
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        if value < 1:
            raise ValueError(f"n_components: expected a count >= 1, a fraction in (0, 1) or None, "
                             f"got {value!r}")
        if value > limit and not clip:
            raise ValueError(f"n_components: expected at most min(n_trajectories, n_features) = {limit} "
                             f"components, got {value}")
        return min(int(value), limit)
    if isinstance(value, (float, np.floating)) and 0.0 < value < 1.0:
        return float(value)
    raise ValueError(f"n_components: expected a count >= 1, a fraction in (0, 1) or None, got {value!r}")


class TrajectoryFeatures(FlatPCAMixin, TransformerMixin, BaseEstimator):
    """Shape features for libraries without representatives: resample, align the start, PCA.

    Each trajectory (any length) is resampled to ``n_points`` evenly spaced
    along its path (or in time), its start is subtracted (so the features are
    invariant to where the motion starts), it is optionally scaled, flattened,
    and projected on principal components fitted on the training set.

    Parameters
    ----------
    n_points : int, default=32
        Samples per trajectory after resampling.
    by : {"arc_length", "time"}, default="arc_length"
        Spacing of the resampled points.
    scale : {"none", "path_length"}, default="none"
        ``"path_length"`` divides each trajectory by its path length, making
        the features invariant to size as well.
    n_components : int, float or None, default=0.99
        PCA components: a count, a fraction of variance to keep, or None for
        no PCA.
    random_state : int, RandomState instance or None, default=None
        Passed to :class:`sklearn.decomposition.PCA`.

    Attributes
    ----------
    pca_ : PCA or None
    n_features_in_ : int
        Dimensions of each trajectory.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 40)
    >>> trajs = [np.column_stack([t, a * t]) + 5.0 * a for a in (0.0, 0.5, 1.0, 2.0)]
    >>> TrajectoryFeatures(n_points=16, n_components=2).fit_transform(trajs).shape
    (4, 2)
    """

    _no_variance = "the same shape once resampled and moved to a common start"

    def __init__(self, *, n_points=32, by="arc_length", scale="none", n_components=0.99,
                 random_state=None):
        self.n_points = n_points
        self.by = by
        self.scale = scale
        self.n_components = n_components
        self.random_state = random_state

    def _flat(self, X, *, reset: bool) -> np.ndarray:
        if self.by not in ("arc_length", "time"):
            raise ValueError(f"by: expected 'arc_length' or 'time', got {self.by!r}")
        if self.scale not in ("none", "path_length"):
            raise ValueError(f"scale: expected 'none' or 'path_length', got {self.scale!r}")
        R = resampled_input(self, X, reset=reset, by=self.by)
        R -= R[:, :1, :]
        if self.scale == "path_length":
            length = np.linalg.norm(np.diff(R, axis=1), axis=2).sum(axis=1)
            R /= np.where(length > 0, length, 1.0)[:, None, None]
        return R.reshape(R.shape[0], -1)

