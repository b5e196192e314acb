"""An estimator-like front end to Laplacian trajectory editing."""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.utils.validation import check_is_fitted

from .._demonstration import Demonstration
from .._validation import check_array, check_positive
from ._lte import EditResult, lte

__all__ = ["LaplacianEditor"]


class LaplacianEditor(BaseEstimator):
    """Adapt one demonstration to new constraints with Laplacian trajectory editing.

    It has the interface of the LfD representations: ``fit`` on a
    demonstration, then ``reproduce(constraints, n_steps=None)``.

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
    stream : str, default="position"
        The demonstration stream to edit.

    Attributes
    ----------
    Y_ : ndarray of shape (n_steps, n_dims)
        The fitted path.
    t_ : ndarray of shape (n_steps,)
    n_dims_ : int
    n_steps_ : int

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Demonstration
    >>> from skillbank._constraints import Constraints
    >>> t = np.linspace(0.0, 1.0, 100)
    >>> editor = LaplacianEditor().fit(Demonstration.from_array(np.column_stack([t, t**2]), t=t))
    >>> out = editor.reproduce(Constraints(goal=[1.0, 2.0]), n_steps=50)
    >>> out.n_steps, out["position"][-1].tolist(), out.metadata["edit"]["success"]
    (50, [1.0, 2.0], True)
    """

    def __init__(self, *, hard=True, weight=1e6, anchor_ends=True, avoid_obstacles=True, margin=None,
                 max_iter=50, stream="position"):
        self.hard = hard
        self.weight = weight
        self.anchor_ends = anchor_ends
        self.avoid_obstacles = avoid_obstacles
        self.margin = margin
        self.max_iter = max_iter
        self.stream = stream

    def fit(self, demos, y=None):
        """Store the path to edit.

        Parameters
        ----------
        demos : Demonstration, array-like (n_steps, n_dims), or a list holding exactly one of them
            LTE edits a single demonstration.
        y : ignored

        Returns
        -------
        self
        """
        if isinstance(demos, (list, tuple)):
            if len(demos) != 1:
                raise ValueError(
                    f"demos: LaplacianEditor edits one demonstration, got {len(demos)}; pick one "
                    "(e.g. the shortest candidate) and fit on it"
                )
            demos = demos[0]
        if isinstance(demos, Demonstration):
            if self.stream not in demos.streams:
                raise ValueError(
                    f"demos: expected a Demonstration with a {self.stream!r} stream, got streams "
                    f"{demos.stream_names}"
                )
            Y, t = demos[self.stream], demos.t
        else:
            Y = check_array(demos, name="demos", ndim=2)
            t = np.arange(Y.shape[0], dtype=float)
        if Y.shape[0] < 2:
            raise ValueError(f"demos: expected at least 2 samples, got {Y.shape[0]}")
        self.Y_ = np.array(Y, dtype=float)
        self.t_ = np.array(t, dtype=float)
        self.n_steps_, self.n_dims_ = self.Y_.shape
        return self

    def _resampled(self, n_steps):
        if n_steps is None or n_steps == self.n_steps_:
            return self.Y_, self.t_
        n_steps = check_positive(n_steps, name="n_steps", integer=True)
        if n_steps < 2:
            raise ValueError(f"n_steps: expected at least 2, got {n_steps}")
        t = np.linspace(self.t_[0], self.t_[-1], n_steps)
        return np.column_stack([np.interp(t, self.t_, col) for col in self.Y_.T]), t

    def edit(self, constraints=None, n_steps=None) -> EditResult:
        """Edit the fitted path (resampled to ``n_steps`` evenly in time); full :class:`EditResult`."""
        check_is_fitted(self, "Y_")
        Y, t = self._resampled(n_steps)
        return lte(Y, constraints, hard=self.hard, weight=self.weight, t=t, anchor_ends=self.anchor_ends,
                   avoid_obstacles=self.avoid_obstacles, margin=self.margin, max_iter=self.max_iter)

    def reproduce(self, constraints=None, n_steps=None) -> Demonstration:
        """The edited path as a Demonstration.

        ``metadata["edit"]`` holds ``success``, ``message``, ``constraint_error``,
        ``velocity_error``, ``collision`` and ``n_iter``; an edit that failed is
        returned too, flagged there.
        """
        result = self.edit(constraints, n_steps)
        _, t = self._resampled(n_steps)
        info = {key: getattr(result, key) for key in
                ("success", "message", "constraint_error", "velocity_error", "collision", "n_iter")}
        return Demonstration(t, {self.stream: result.Y}, {"source": "LaplacianEditor", "edit": info})
