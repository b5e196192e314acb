"""Trajectory metrics: curve distances, shape and smoothness, and constraint reports.

Examples
--------
>>> import numpy as np
>>> from skillbank.metrics import frechet_distance, path_length
>>> P = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
>>> frechet_distance(P, P + [0.0, 0.5]), path_length(P)
(0.5, 2.0)
"""

from ._distances import dtw_distance, dtw_many, frechet_distance
from ._report import comparison_metrics, constraint_report
from ._shape import (
    angular_similarity,
    angular_similarity_matrix,
    curvature_deviation,
    jerk_cost,
    path_length,
    swept_error_area,
)

__all__ = [
    "frechet_distance", "dtw_distance", "dtw_many", "swept_error_area", "angular_similarity",
    "angular_similarity_matrix", "curvature_deviation", "jerk_cost", "path_length", "constraint_report",
    "comparison_metrics",
]
