"""Unsupervised direction features in a heading-aligned frame (the default RAIL featuriser)."""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin

from ._features import FlatPCAMixin, resampled_input

__all__ = ["HeadingFeatures", "heading_directions", "unit_steps"]


def unit_steps(R: np.ndarray) -> np.ndarray:
    """Each step of trajectories ``R`` (n, n_steps, n_dims) divided by its length; a zero step stays zero.

    Examples
    --------
    >>> unit_steps(np.array([[[0.0, 0.0], [3.0, 4.0], [3.0, 4.0]]]))[0].tolist()
    [[0.6, 0.8], [0.0, 0.0]]
    """
    D = np.diff(R, axis=1)
    norm = np.linalg.norm(D, axis=2, keepdims=True)
    return D / np.where(norm > 0.0, norm, 1.0)


def heading_directions(R: np.ndarray, *, mirror: bool = True) -> np.ndarray:
    """Unit step directions of trajectories expressed in their own heading frame.

    Each trajectory of ``R`` (n, n_steps, n_dims) is rotated about the last
    axis (the vertical one for 3-D robot data) so that its horizontal
    start-to-end displacement, in the plane of the first two dimensions,
    points along +x; with ``mirror`` its second dimension is flipped so that
    the lateral excursion is positive. Each step is then divided by its
    length (a zero-length step stays zero). The result is invariant to where
    the motion starts, where it goes to, which way it faces and how large it
    is, but keeps how the direction changes in time: the quantity the paper's
    angular similarity compares, without representatives.

    Parameters
    ----------
    R : ndarray of shape (n_trajectories, n_steps, n_dims)
    mirror : bool, default=True

    Returns
    -------
    ndarray of shape (n_trajectories, n_steps - 1, n_dims)

    Examples
    --------
    >>> R = np.array([[[0.0, 0.0], [0.0, 1.0], [0.0, 2.0]]])
    >>> heading_directions(R)[0].round(6).tolist()
    [[1.0, 0.0], [1.0, 0.0]]
    """
    Q = R - R[:, :1, :]
    if Q.shape[2] >= 2:
        heading = np.arctan2(Q[:, -1, 1], Q[:, -1, 0])
        c, s = np.cos(heading)[:, None], np.sin(heading)[:, None]
        x, y = Q[:, :, 0].copy(), Q[:, :, 1].copy()
        Q[:, :, 0] = c * x + s * y
        Q[:, :, 1] = -s * x + c * y
        if mirror:
            Q[:, :, 1] *= np.where(Q[:, :, 1].sum(axis=1) < 0.0, -1.0, 1.0)[:, None]
    return unit_steps(Q)


class HeadingFeatures(FlatPCAMixin, TransformerMixin, BaseEstimator):
    """Direction-over-time features, invariant to start, goal, facing and size.

    Each trajectory is resampled to ``n_points`` samples evenly in time, put
    in its heading frame (see :func:`heading_directions`), reduced to its
    ``n_points - 1`` unit step directions, flattened and projected on
    ``n_components`` principal components fitted on the training set. Two
    demonstrations of one skill from different start and goal positions get
    close features; skills that move differently (reach down, push along the
    table, press down, write in a plane) get distant ones.

    Parameters
    ----------
    n_points : int, default=16
        Samples per trajectory after resampling in time.
    n_components : int, float or None, default=3
        PCA components (a count, a fraction of variance, or None for none).
        Three, like the paper's three features, also lets the features be
        plotted.
    mirror : bool, default=True
        Also make the features invariant to left-right mirroring.
    random_state : int, RandomState instance or None, default=None
        Passed to :class:`sklearn.decomposition.PCA`.

    Attributes
    ----------
    pca_ : PCA or None
    n_features_in_ : int
        Dimensions of each trajectory.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 50)
    >>> lines = [np.column_stack([a * t, t, 0 * t]) for a in (0.5, 1.0, 2.0)]
    >>> arcs = [np.column_stack([np.sin(3 * t), a * t, t ** 2]) for a in (0.5, 1.0, 2.0)]
    >>> HeadingFeatures(n_points=8, n_components=2).fit_transform(lines + arcs).shape
    (6, 2)
    """

    def __init__(self, *, n_points=16, n_components=3, mirror=True, random_state=None):
        self.n_points = n_points
        self.n_components = n_components
        self.mirror = mirror
        self.random_state = random_state

    def _flat(self, X, *, reset: bool) -> np.ndarray:
        R = resampled_input(self, X, reset=reset, by="time")
        U = heading_directions(R, mirror=bool(self.mirror))
        return U.reshape(U.shape[0], -1)

    # A count larger than the data allows is cut to it (min(n_trajectories, n_features)).
    _clip_components = True
