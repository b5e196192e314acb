"""Shared input handling of the LfD representations.

Every representation learns from demonstrations with ``fit(demos)`` and
produces a new trajectory with ``reproduce(constraints=None, n_steps=None)``.
This module holds what they share: turning the user's demonstrations into
arrays on a uniform time grid, checking constraints against the learned
dimension, building the output :class:`~skillbank.Demonstration`, and the
obstacle post-editing step.

Obstacles
---------
None of the representations avoids obstacles by itself. When the constraints
hold obstacles, :meth:`Representation._avoid_obstacles` hands the reproduction
to Laplacian trajectory editing (``skillbank.editing.lte``), which deforms it
around the obstacles while keeping its start, goal and via-points. That is the
only coupling with :mod:`skillbank.editing`; when that module is not available
the request fails with an :class:`ImportError` instead of silently returning
a colliding trajectory.
"""

from __future__ import annotations

import importlib
import warnings

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.exceptions import NotFittedError

from .._constraints import Constraints
from .._demonstration import Demonstration
from .._validation import check_array, check_positive

__all__ = ["Representation", "resample", "as_constraints"]


def resample(Y: np.ndarray, n_steps: int) -> np.ndarray:
    """Linearly resample ``Y`` (n, n_dims) to ``n_steps`` samples evenly spaced in phase.

    Examples
    --------
    >>> resample(np.array([[0.0], [2.0]]), 3).ravel().tolist()
    [0.0, 1.0, 2.0]
    """
    n = Y.shape[0]
    if n == n_steps:
        return Y.copy()
    if n == 1:
        return np.repeat(Y, n_steps, axis=0)
    src = np.linspace(0.0, 1.0, n)
    dst = np.linspace(0.0, 1.0, n_steps)
    j = np.clip(np.searchsorted(src, dst, side="right") - 1, 0, n - 2)
    w = ((dst - src[j]) * (n - 1))[:, None]
    return (1.0 - w) * Y[j] + w * Y[j + 1]


def _uniform(t: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """``Y`` sampled at ``t`` re-interpolated onto an even grid with the same end points."""
    if t.shape[0] < 3:
        return Y.copy()
    grid = np.linspace(t[0], t[-1], t.shape[0])
    if np.allclose(t, grid, rtol=0.0, atol=1e-9 * max(t[-1] - t[0], 1e-300)):
        return Y.copy()
    return np.column_stack([np.interp(grid, t, col) for col in Y.T])


def as_constraints(constraints) -> Constraints:
    """Accept ``None`` (no constraint) or a :class:`~skillbank.Constraints`.

    Examples
    --------
    >>> as_constraints(None).is_empty
    True
    """
    if constraints is None:
        return Constraints()
    if not isinstance(constraints, Constraints):
        raise ValueError(
            f"constraints: expected a skillbank.Constraints or None, got {type(constraints).__name__}"
        )
    return constraints


class Representation(BaseEstimator):
    """Base class: demonstration handling, time base, constraints and output.

    Subclasses set ``_single_demo`` (True when the method learns from exactly
    one demonstration), ``_min_samples``, implement ``_fit(Ys)`` on a list of
    arrays resampled to a uniform time grid, and ``_reproduce(constraints,
    n_steps)`` returning an ``(n_steps, n_dims)`` array.

    Attributes
    ----------
    n_dims_ : int
        Number of position dimensions.
    n_demos_ : int
        Number of demonstrations learned from.
    t_ : ndarray of shape (n_steps,)
        Reference time base (set by :meth:`fit`): evenly spaced from the
        demonstrations' mean start time to their mean end time, with their
        median number of samples.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank.representations import ProMP
    >>> model = ProMP(n_basis=5).fit([np.c_[np.arange(10.0), np.ones(10)]] * 2)
    >>> model.t_.shape, model.reproduce(n_steps=4)["position"].shape
    ((10,), (4, 2))
    """

    _single_demo = False
    _min_samples = 2
    _stream = "position"

    # ----------------------------------------------------------------- input
    def _demos(self, demos):
        """Validate ``demos``; return (list of (t, Y) pairs)."""
        if isinstance(demos, (Demonstration, np.ndarray)):
            demos = [demos]
        elif not isinstance(demos, (list, tuple)):
            raise ValueError(
                "demos: expected a Demonstration, an array (n_steps, n_dims) or a list of them, "
                f"got {type(demos).__name__}"
            )
        if len(demos) == 0:
            raise ValueError("demos: expected at least one demonstration, got an empty list")
        name = type(self).__name__
        if self._single_demo and len(demos) != 1:
            raise ValueError(f"demos: {name} learns from exactly one demonstration, got {len(demos)}")
        pairs = []
        for k, demo in enumerate(demos):
            label = f"demos[{k}]"
            if isinstance(demo, Demonstration):
                if self._stream not in demo:
                    raise ValueError(
                        f"{label}: expected a {self._stream!r} stream, got streams {demo.stream_names}"
                    )
                Y, t = demo[self._stream], demo.t
            else:
                Y = check_array(demo, name=label, ndim=2)
                t = np.arange(Y.shape[0], dtype=float)
            if Y.shape[0] < self._min_samples:
                raise ValueError(
                    f"{label}: {name} needs at least {self._min_samples} samples, got {Y.shape[0]}"
                )
            if pairs and Y.shape[1] != pairs[0][1].shape[1]:
                raise ValueError(
                    f"{label}: expected {pairs[0][1].shape[1]} dimensions like demos[0], got {Y.shape[1]}"
                )
            pairs.append((np.asarray(t, dtype=float), np.asarray(Y, dtype=float)))
        return pairs

    def fit(self, demos):
        """Learn the representation from demonstrations.

        Parameters
        ----------
        demos : Demonstration, array of shape (n_steps, n_dims), or list of them
            Stream ``"position"`` of each Demonstration is used; a plain array
            gets the time base ``0, 1, 2, ...``. Demonstrations with uneven
            time steps are interpolated onto an even grid.

        Returns
        -------
        self
        """
        pairs = self._demos(demos)
        self.n_dims_ = int(pairs[0][1].shape[1])
        self.n_demos_ = len(pairs)
        n_ref = int(round(float(np.median([Y.shape[0] for _, Y in pairs]))))
        start = float(np.mean([t[0] for t, _ in pairs]))
        stop = float(np.mean([t[-1] for t, _ in pairs]))
        self.t_ = np.linspace(start, stop, n_ref)
        self._durations = [float(t[-1] - t[0]) for t, _ in pairs]
        self._fit([_uniform(t, Y) for t, Y in pairs])
        return self

    # ---------------------------------------------------------------- output
    def _check_fitted(self):
        if not hasattr(self, "t_"):
            raise NotFittedError(f"{type(self).__name__} is not fitted yet: call fit(demos) first")

    def _n_steps(self, n_steps) -> int:
        if n_steps is None:
            return int(self.t_.shape[0])
        n_steps = check_positive(n_steps, name="n_steps", integer=True)
        if n_steps < self._min_samples:
            raise ValueError(
                f"n_steps: {type(self).__name__} needs at least {self._min_samples} samples, got {n_steps}"
            )
        return n_steps

    def _time(self, n_steps: int) -> np.ndarray:
        if n_steps == self.t_.shape[0]:
            return self.t_.copy()
        return np.linspace(self.t_[0], self.t_[-1], n_steps)

    @property
    def duration_(self) -> float:
        """Duration of the reference time base (seconds, or samples for plain arrays)."""
        self._check_fitted()
        return float(self.t_[-1] - self.t_[0])

    def _constraints(self, constraints, nominal: np.ndarray) -> Constraints:
        """Check ``constraints``; missing start / goal come from the ``nominal`` trajectory."""
        constraints = as_constraints(constraints)
        constraints.check_dims(self.n_dims_)
        return constraints.with_defaults(nominal)

    def reproduce(self, constraints=None, n_steps=None) -> Demonstration:
        """Generate a trajectory meeting ``constraints``.

        Parameters
        ----------
        constraints : Constraints, optional
            Start, goal, via-points (by phase or sample index), boundary
            velocities (where the method supports them) and obstacles. A
            missing start or goal is the model's own (the demonstration's for
            one-demo methods, the mean otherwise).
        n_steps : int, optional
            Number of samples; default the reference length. The time base
            spans the demonstrations' mean duration either way.

        Returns
        -------
        Demonstration
            Stream ``"position"`` of shape (n_steps, n_dims); metadata holds
            ``"representation"`` and, when obstacles were given, the
            ``"obstacle_editing"`` outcome.
        """
        self._check_fitted()
        n_steps = self._n_steps(n_steps)
        constraints = as_constraints(constraints)
        constraints.check_dims(self.n_dims_)
        Y = self._reproduce(constraints, n_steps)
        metadata = {"representation": type(self).__name__}
        t = self._time(n_steps)
        Y = self._avoid_obstacles(Y, t, constraints, metadata)
        return Demonstration(t, {"position": Y}, metadata)

    def _avoid_obstacles(self, Y: np.ndarray, t: np.ndarray, constraints: Constraints,
                         metadata: dict) -> np.ndarray:
        """Post-edit ``Y`` around obstacles with Laplacian trajectory editing.

        Does nothing without obstacles. Otherwise calls
        ``skillbank.editing.lte(Y, constraints, t=t)``, stores its ``success``,
        ``collision`` and ``message`` in ``metadata["obstacle_editing"]`` and
        warns (``UserWarning``) when the edit did not succeed.
        """
        if not constraints.obstacles:
            return Y
        try:
            editing = importlib.import_module("skillbank.editing")
            lte = editing.lte
        except (ImportError, AttributeError) as exc:
            raise ImportError(
                f"constraints: {type(self).__name__} does not avoid obstacles itself; it post-edits the "
                f"reproduction with skillbank.editing.lte, which is not available ({exc})"
            ) from None
        full = constraints.with_defaults(Y)
        result = lte(Y, full, t=t)
        metadata["obstacle_editing"] = {
            "success": bool(result.success),
            "collision": bool(result.collision),
            "message": str(result.message),
        }
        if not result.success:
            warnings.warn(
                f"{type(self).__name__}: obstacle editing did not succeed: {result.message}",
                UserWarning,
                stacklevel=3,
            )
        return np.asarray(result.Y, dtype=float)
