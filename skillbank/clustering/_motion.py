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

    The direction of a step much slower than the motion's typical step is
    barely defined: a pen settling at the end of a stroke hooks one way or
    the other. With ``slow_steps="weighted"`` the time blocks' steps slower
    than the median step are shortened in proportion to their speed, so such
    hooks count little; ``"auto"`` does this for drawings (2-D) only, since
    a robot's slow phases (creeping along a table in contact) are part of
    the skill.

    Parameters
    ----------
    n_points : int, default=16
        Samples per trajectory and resampling.
    mirror : {"auto", True, False}, default="auto"
        ``"auto"``: fold mirror images for 3 or more dimensions only.
    slow_steps : {"auto", "weighted", "unit"}, default="auto"
        How the time blocks count steps slower than the median step:
        ``"weighted"`` in proportion to their speed, ``"unit"`` as much as
        any other; ``"auto"``: weighted for 2-D trajectories only.
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

    def __init__(self, *, n_points=16, mirror="auto", slow_steps="auto", n_components=None,
                 random_state=None):
        self.n_points = n_points
        self.mirror = mirror
        self.slow_steps = slow_steps
        self.n_components = n_components
        self.random_state = random_state

    def _flat(self, X, *, reset: bool) -> np.ndarray:
        if self.mirror not in ("auto", True, False):
            raise ValueError(f"mirror: expected 'auto', True or False, got {self.mirror!r}")
        if self.slow_steps not in ("auto", "weighted", "unit"):
            raise ValueError(f"slow_steps: expected 'auto', 'weighted' or 'unit', got {self.slow_steps!r}")
        by_time = resampled_input(self, X, reset=reset, by="time")
        by_path = resampled_input(self, X, reset=False, by="arc_length")
        mirror = by_time.shape[2] >= 3 if self.mirror == "auto" else bool(self.mirror)
        heading, steps = heading_directions(by_time, mirror=mirror), unit_steps(by_time)
        if self.slow_steps == "weighted" or (self.slow_steps == "auto" and by_time.shape[2] < 3):
            weight = _slow_step_weights(by_time)
            heading, steps = heading * weight, steps * weight
        blocks = (heading, steps, heading_directions(by_path, mirror=mirror))
        return np.concatenate([b.reshape(b.shape[0], -1) for b in blocks], axis=1)

    _clip_components = True


def _slow_step_weights(R: np.ndarray) -> np.ndarray:
    """``min(1, |step| / median |step|)`` per step of each trajectory of ``R`` (n, n_steps, n_dims).

    Examples
    --------
    >>> R = np.array([[[0.0], [1.0], [2.0], [3.0], [3.1]]])
    >>> _slow_step_weights(R)[0, :, 0].round(2).tolist()
    [1.0, 1.0, 1.0, 0.1]
    """
    length = np.linalg.norm(np.diff(R, axis=1), axis=2, keepdims=True)
    median = np.median(length, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        # a trajectory that never moves has no typical step: its (zero) steps keep weight 1
        return np.where(median > 0.0, np.minimum(1.0, length / np.where(median > 0.0, median, 1.0)), 1.0)

