"""Shape-and-direction features of whole motions (the default featuriser of a folder of trajectories)."""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin

from ._features import FlatPCAMixin, resampled_input
from ._heading import heading_directions, unit_steps

__all__ = ["MotionFeatures"]


class MotionFeatures(FlatPCAMixin, TransformerMixin, BaseEstimator):
    """Direction of motion over time and along the path, in the motion's own frame and the recording's.

    Each trajectory is resampled twice to ``n_points`` samples, evenly in
    time and evenly along its path, and described by three blocks of unit
    step directions:

    - over time, in its heading frame (:func:`heading_directions`): the shape
      of the motion whichever way it faces, with where it slows down (a
      push that creeps along the table is not a quick reach);
    - over time, in the recording frame: the direction it goes (a push is
      not a reach, even when both are straight lines);
    - along the path, in its heading frame: the geometric shape, whatever
      the speed profile of each demonstration (a C is not a trapezoid).

    Every block is a list of unit vectors, so each weighs the same and the
    features are invariant to where the motion starts and to its size.
    Mirror images (``mirror``) are folded together only for 3-D motions,
    where the horizontal plane is symmetric about the direction of motion
    (a push to the left is a push); a 2-D trajectory is a drawing, whose
    mirror image is a different figure (an S is not a Z).

    Parameters
    ----------
    n_points : int, default=16
        Samples per trajectory and resampling.
    mirror : {"auto", True, False}, default="auto"
        ``"auto"``: fold mirror images for 3 or more dimensions only.
    n_components : int, float or None, default=None
        Optional PCA step (a count, a fraction of variance, or None).
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
    >>> lines = [np.column_stack([t, a * t]) for a in (0.5, 1.0)]
    >>> MotionFeatures(n_points=8).fit_transform(lines).shape
    (2, 42)
    """

    def __init__(self, *, n_points=16, mirror="auto", n_components=None, random_state=None):
        self.n_points = n_points
        self.mirror = mirror
        self.n_components = n_components
        self.random_state = random_state

    def _flat(self, X, *, reset: bool) -> np.ndarray:
        if self.mirror not in ("auto", True, False):
            raise ValueError(f"mirror: expected 'auto', True or False, got {self.mirror!r}")
        by_time = resampled_input(self, X, reset=reset, by="time")
        by_path = resampled_input(self, X, reset=False, by="arc_length")
        mirror = by_time.shape[2] >= 3 if self.mirror == "auto" else bool(self.mirror)
        blocks = (heading_directions(by_time, mirror=mirror), unit_steps(by_time),
                  heading_directions(by_path, mirror=mirror))
        return np.concatenate([b.reshape(b.shape[0], -1) for b in blocks], axis=1)

    _clip_components = True
