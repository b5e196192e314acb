"""A summary of how well a trajectory meets task constraints."""

from __future__ import annotations

import numpy as np

from .._constraints import Constraints
from .._validation import check_array

__all__ = ["constraint_report"]


def constraint_report(Y, constraints, t=None) -> dict:
    """How well ``Y`` meets ``constraints``.

    Parameters
    ----------
    Y : array-like of shape (n_steps, n_dims)
    constraints : Constraints
    t : array-like of shape (n_steps,), optional
        Time stamps for velocities (default unit spacing).

    Returns
    -------
    dict
        ``position_error`` (largest distance to a positional target),
        ``velocity_error`` (largest boundary-velocity error), ``collision``
        (a sample strictly inside an obstacle), ``n_colliding`` (such samples),
        ``min_signed_distance`` (per obstacle, negative when penetrated) and
        ``clearance`` (smallest of those, ``inf`` without obstacles).

    Examples
    --------
    >>> from skillbank._constraints import Constraints, Sphere
    >>> c = Constraints(goal=[1.0, 0.0], obstacles=[Sphere([0.5, 0.0], 0.25)])
    >>> r = constraint_report([[0.0, 0.0], [0.5, 0.1], [1.0, 0.0]], c)
    >>> r["collision"], r["n_colliding"], round(r["clearance"], 3)
    (True, 1, -0.15)
    """
    if not isinstance(constraints, Constraints):
        raise ValueError(f"constraints: expected a skillbank Constraints, got {type(constraints).__name__}")
    Y = check_array(Y, name="Y", ndim=2)
    constraints.check_dims(Y.shape[1])
    sd = constraints.signed_distances(Y)
    per_obstacle = sd.min(axis=1) if sd.size else np.empty(0)
    inside = (sd < 0).any(axis=0)
    return {
        "position_error": constraints.position_error(Y),
        "velocity_error": constraints.velocity_error(Y, t) if constraints.has_velocity else 0.0,
        "collision": bool(inside.any()),
        "n_colliding": int(inside.sum()),
        "min_signed_distance": [float(v) for v in per_obstacle],
        "clearance": float(per_obstacle.min()) if per_obstacle.size else float("inf"),
    }
