"""Laplacian trajectory editing as a representation: adapt one demonstration as it is."""

from __future__ import annotations

from ..core import Demonstration, resample
from ..editing import lte
from ._base import Representation, edit_summary

__all__ = ["LaplacianEditor"]


class LaplacianEditor(Representation):
    """Adapt one demonstration to new constraints with Laplacian trajectory editing (LTE).

    Unlike the other representations it learns nothing: ``fit`` keeps the
    demonstration on its own time base, and ``reproduce`` deforms it to meet
    the constraints while keeping its Laplacian (local shape) coordinates,
    avoiding obstacles itself (:func:`skillbank.editing.lte`).

    Parameters
    ----------
    hard : bool, default=True
        Equality constraints, else weighted least-squares rows.
    weight : float, default=1e6
        Weight of soft constraint rows.
    anchor_ends : bool, default=True
        Keep the demonstration's own start / goal when the constraints give none.
    avoid_obstacles : bool, default=True
    margin : float, optional
        Clearance of the via-points added around obstacles (default 10 % of the
        obstacle's size).
    max_iter : int, default=50
        Obstacle-avoidance rounds.

    Attributes
    ----------
    Y_ : ndarray of shape (n_steps, n_dims)
        The demonstration's path.
    t_ : ndarray of shape (n_steps,)
        Its own time stamps (kept as they are, even when uneven).
    n_dims_, n_demos_ : int

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Constraints
    >>> t = np.linspace(0.0, 1.0, 100)
    >>> editor = LaplacianEditor().fit(Demonstration.from_array(np.column_stack([t, t**2]), t=t))
    >>> out = editor.reproduce(Constraints(goal=[1.0, 2.0]), n_steps=50)
    >>> out.n_steps, out["position"][-1].tolist(), out.metadata["edit"]["success"]
    (50, [1.0, 2.0], True)
    """

    single_demo = True
    min_samples = 2
    avoids_obstacles = True

    def __init__(self, *, hard=True, weight=1e6, anchor_ends=True, avoid_obstacles=True, margin=None,
                 max_iter=50):
        self.hard = hard
        self.weight = weight
        self.anchor_ends = anchor_ends
        self.avoid_obstacles = avoid_obstacles
        self.margin = margin
        self.max_iter = max_iter

    def fit(self, demos):
        """Keep the demonstration to edit (a Demonstration, an array or a one-item list).

        Returns
        -------
        self
        """
        (t, Y), = self._demos(demos)
        self.Y_, self.t_ = Y.copy(), t.copy()
        self.n_dims_, self.n_demos_ = int(Y.shape[1]), 1
        return self

    def _path(self, n_steps: int):
        if n_steps == self.Y_.shape[0]:
            return self.Y_, self.t_
        return resample(self.Y_, n_steps, t=self.t_), self._time(n_steps)

    def edit(self, constraints=None, n_steps=None):
        """The full :class:`~skillbank.editing.EditResult` of editing the (resampled) demonstration."""
        self._check_fitted()
        n_steps = self._n_steps(n_steps)
        Y, t = self._path(n_steps)
        return lte(Y, constraints, hard=self.hard, weight=self.weight, t=t, anchor_ends=self.anchor_ends,
                   avoid_obstacles=self.avoid_obstacles, margin=self.margin, max_iter=self.max_iter)

    def reproduce(self, constraints=None, n_steps=None) -> Demonstration:
        """The edited path; ``metadata["edit"]`` says whether the edit succeeded and why not.

        An edit that failed (a constraint inside an obstacle, no collision-free
        edit within ``max_iter`` rounds) is returned too, flagged there.
        """
        result = self.edit(constraints, n_steps)
        t = self._path(self._n_steps(n_steps))[1]
        return Demonstration(t, {"position": result.Y},
                             {"representation": type(self).__name__, "edit": edit_summary(result)})
