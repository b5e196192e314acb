"""Clustering of motion primitives: elastic clustering and trajectory featurisers.

Examples
--------
>>> import numpy as np
>>> from skillbank.clustering import ElasticClustering, TrajectoryFeatures
>>> t = np.linspace(0.0, 1.0, 50)
>>> trajs = [np.column_stack([t, s * t]) for s in (0.0, 0.02, 0.04, 1.0, 1.02, 1.04)]
>>> features = TrajectoryFeatures(n_points=16, n_components=2).fit_transform(trajs)
>>> ElasticClustering(random_state=0).fit(features).n_clusters_
2
"""

from ._dtw import DTWFeatures
from ._elastic import ElasticClustering
from ._features import AngularSimilarityFeatures, TrajectoryFeatures
from ._heading import HeadingFeatures, heading_directions
from ._motion import MotionFeatures
from ._primitive import (
    FEATURE_KINDS,
    TRAJECTORY_FEATURES,
    nearest_centre,
    primitive_features,
    trajectory_features,
)

__all__ = [
    "ElasticClustering", "AngularSimilarityFeatures", "HeadingFeatures", "MotionFeatures",
    "TrajectoryFeatures", "DTWFeatures",
    "heading_directions", "primitive_features", "trajectory_features", "nearest_centre", "FEATURE_KINDS",
    "TRAJECTORY_FEATURES",
]
