"""Shared input handling of the LfD representations.

Every representation learns from demonstrations with ``fit(demos)`` and
produces a new trajectory with ``reproduce(constraints=None, n_steps=None)``.
This module holds what they share: turning the user's demonstrations into
arrays on a uniform time grid, checking constraints against the learned
dimension, building the output :class:`~skillbank.Demonstration`, and the
obstacle post-editing step.

Obstacles
---------
Only :class:`~skillbank.representations.LaplacianEditor` avoids obstacles by
itself (``avoids_obstacles = True``). For the others, when the constraints
hold obstacles, :meth:`Representation._avoid_obstacles` hands the
reproduction to Laplacian trajectory editing (``skillbank.editing.lte``),
which deforms it around the obstacles while keeping its start, goal and
via-points; the outcome is in the reproduction's ``metadata["edit"]``.
"""

from __future__ import annotations

import warnings
from typing import ClassVar

import numpy as np

from ..core import Constraints, Demonstration, resample
from ..core._params import NotFittedError, Params
from ..core._validation import check_array, check_finite_result, check_positive, numerical_errors
from ..editing import lte

__all__ = ["Representation", "as_constraints", "edit_summary"]


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


class Representation(Params):
    """Base class: demonstration handling, time base, constraints and output.

    Subclasses implement ``_fit(Ys)`` on a list of arrays resampled to a
    uniform time grid and ``_reproduce(constraints, n_steps)`` returning an
    ``(n_steps, n_dims)`` array, and describe themselves with the class
    attributes below (read by selection and the command line through the
    registry, :data:`~skillbank.representations.REPRESENTATIONS`).

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

    # What selection, the pipeline and the command line need to know about a method; the
    # registry (``REPRESENTATIONS``) maps names to classes and these describe each class.
    #: Learns from exactly one demonstration (else from one or more).
    single_demo: ClassVar[bool] = False
    #: How many candidates reuse hands it by default.
    default_k: ClassVar[int] = 1
    #: Fewest samples a demonstration (and a reproduction) may have.
    min_samples: ClassVar[int] = 2
    #: Which constraints it meets itself; reuse follows the others through the edited candidates.
    supports_via: ClassVar[bool] = True
    supports_start_velocity: ClassVar[bool] = True
    supports_end_velocity: ClassVar[bool] = True
    #: True when the method avoids obstacles itself; otherwise its reproduction is post-edited
    #: with Laplacian trajectory editing (:meth:`_avoid_obstacles`).
    avoids_obstacles: ClassVar[bool] = False
    _stream = "position"

    @classmethod
    def unsupported(cls, constraints: Constraints) -> list[str]:
        """Names of the constraints given in ``constraints`` that this method cannot meet itself.

        Examples
        --------
        >>> from skillbank.representations import DMP
        >>> DMP.unsupported(Constraints(goal=[1.0], via=[(0.5, [0.2])]))
        ['via']
        """
        given = {"via": bool(constraints.via), "start_velocity": constraints.start_velocity is not None,
                 "end_velocity": constraints.end_velocity is not None}
        return [k for k, on in given.items() if on and not getattr(cls, f"supports_{k}")]

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
        if self.single_demo and len(demos) != 1:
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
            if Y.shape[0] < self.min_samples:
                raise ValueError(
                    f"{label}: {name} needs at least {self.min_samples} samples, got {Y.shape[0]}"
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
        step = f"{type(self).__name__}.fit"
        with numerical_errors(step):
            self.n_dims_ = int(pairs[0][1].shape[1])
            self.n_demos_ = len(pairs)
            n_ref = int(round(float(np.median([Y.shape[0] for _, Y in pairs]))))
            start = float(np.mean([t[0] for t, _ in pairs]))
            stop = float(np.mean([t[-1] for t, _ in pairs]))
            self.t_ = np.linspace(start, stop, n_ref)
            self._durations = [float(t[-1] - t[0]) for t, _ in pairs]
            self._fit([resample(Y, Y.shape[0], t=t) for t, Y in pairs])
        self._check_learned(step)
        return self

    def _check_learned(self, step: str) -> None:
        """Every learned float array or number (attributes ending in ``_``) must be finite."""
        for key, value in vars(self).items():
            if key.endswith("_") and not key.startswith("_") and isinstance(value, (float, np.ndarray)):
                if not isinstance(value, np.ndarray) or value.dtype.kind == "f":
                    check_finite_result(value, name=f"{step} ({key})")

    # ---------------------------------------------------------------- output
    def _check_fitted(self):
        if not hasattr(self, "t_"):
            raise NotFittedError(f"{type(self).__name__} is not fitted yet: call fit(demos) first")

    def _n_steps(self, n_steps) -> int:
        if n_steps is None:
            return int(self.t_.shape[0])
        n_steps = check_positive(n_steps, name="n_steps", integer=True)
        if n_steps < self.min_samples:
            raise ValueError(
                f"n_steps: {type(self).__name__} needs at least {self.min_samples} samples, got {n_steps}"
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
            outcome of the obstacle post-edit in ``"edit"``.

        Raises
        ------
        ValueError
            On invalid constraints (naming them), and, naming
            ``<Class>.reproduce``, when the computation overflows or its
            result is not finite.
        """
        self._check_fitted()
        n_steps = self._n_steps(n_steps)
        constraints = as_constraints(constraints)
        constraints.check_dims(self.n_dims_)
        step = f"{type(self).__name__}.reproduce"
        with numerical_errors(step):
            Y = check_finite_result(self._reproduce(constraints, n_steps), name=step)
            metadata = {"representation": type(self).__name__}
            t = self._time(n_steps)
        if constraints.obstacles and not self.avoids_obstacles:
            Y = self._avoid_obstacles(Y, t, constraints, metadata)
        return Demonstration(t, {"position": Y}, metadata)

    def _avoid_obstacles(self, Y: np.ndarray, t: np.ndarray, constraints: Constraints,
                         metadata: dict) -> np.ndarray:
        """Post-edit ``Y`` around obstacles with Laplacian trajectory editing.

        Calls ``skillbank.editing.lte(Y, constraints, t=t)`` (missing start and
        goal held at the reproduction's own), records the outcome in
        ``metadata["edit"]`` (see :func:`edit_summary`) and warns
        (``UserWarning``) when the edit did not succeed.
        """
        result = lte(Y, constraints.with_defaults(Y), t=t)
        metadata["edit"] = edit_summary(result)
        if not result.success:
            warnings.warn(
                f"{type(self).__name__}: obstacle editing did not succeed: {result.message}",
                UserWarning,
                stacklevel=3,
            )
        return np.asarray(result.Y, dtype=float)


def edit_summary(result) -> dict:
    """The JSON-able outcome of an LTE edit, as stored in a reproduction's ``metadata["edit"]``."""
    return {"success": bool(result.success), "message": str(result.message),
            "collision": bool(result.collision), "constraint_error": float(result.constraint_error),
            "velocity_error": float(result.velocity_error), "n_iter": int(result.n_iter)}
