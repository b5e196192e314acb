"""A summary of how well a trajectory meets task constraints."""

from __future__ import annotations

import numpy as np

from ..core import Constraints, resample
from ..core._validation import check_array, check_finite_result, numerical_errors
from ._distances import dtw_distance, frechet_distance
from ._shape import angular_similarity, curvature_deviation, jerk_cost, path_length, swept_error_area

__all__ = ["constraint_report", "comparison_metrics"]


@numerical_errors("constraint_report")
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
        (:meth:`Constraints.collides`: a sample strictly inside an obstacle or
        a segment through one), ``n_colliding`` (samples strictly inside),
        ``min_signed_distance`` (per obstacle, negative when penetrated) and
        ``clearance`` (smallest of those, ``inf`` without obstacles).

    Examples
    --------
    >>> from skillbank.core import Constraints, Sphere
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
        "collision": constraints.collides(Y),
        "n_colliding": int(inside.sum()),
        "min_signed_distance": [float(v) for v in per_obstacle],
        "clearance": float(per_obstacle.min()) if per_obstacle.size else float("inf"),
    }


def comparison_metrics(Y, t, reference, constraints) -> dict:
    """Shape and quality of ``Y`` (times ``t``) against the ``reference`` demonstration's positions.

    ``frechet`` and ``dtw`` compare the curves as they are; ``angular_similarity``,
    ``swept_error_area`` and ``curvature_deviation`` compare them sample by
    sample (the reproduction resampled to the reference's length if needed).
    ``clearance`` (smallest signed distance to an obstacle) only with obstacles.
    Fréchet and DTW take time proportional to the product of the lengths
    (memory linear in them); everything else is linear.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Constraints
    >>> s = np.linspace(0.0, 1.0, 20)
    >>> m = comparison_metrics(np.c_[s, s], s, np.c_[s, s], Constraints())
    >>> m["frechet"], round(m["path_length"], 6)
    (0.0, 1.414214)
    """
    Y = check_array(Y, name="Y", ndim=(1, 2), as_2d=True)
    reference = check_array(reference, name="reference", ndim=(1, 2), as_2d=True)
    if not isinstance(constraints, Constraints):
        raise ValueError(f"constraints: expected a skillbank Constraints, got {type(constraints).__name__}")
    same = Y if Y.shape[0] == reference.shape[0] else resample(Y, reference.shape[0])
    metrics = {
        "frechet": frechet_distance(Y, reference),
        "dtw": dtw_distance(Y, reference),
        "swept_error_area": swept_error_area(same, reference),
        "angular_similarity": angular_similarity(same, reference),
        "curvature_deviation": curvature_deviation(same, reference),
        "path_length": path_length(Y),
        "demo_path_length": path_length(reference),
        "jerk_cost": jerk_cost(Y, t) if Y.shape[0] >= 4 else 0.0,
    }
    if constraints.obstacles:
        with numerical_errors("clearance"):
            metrics["clearance"] = check_finite_result(float(constraints.signed_distances(Y).min()),
                                                       name="clearance")
    return {k: float(v) for k, v in metrics.items()}
