"""Feature matrices of whole collections (a library, a folder of files) and nearest-centre assignment."""

from __future__ import annotations

import numpy as np
from sklearn.preprocessing import minmax_scale

from ..core import resample_many
from ..core._defaults import FEATURE_KINDS  # defined beside the store's check, which imports no scikit-learn
from ..core._validation import check_array, numerical_errors, summarise
from ._dtw import DTWFeatures
from ._em import assign
from ._features import AngularSimilarityFeatures
from ._heading import HeadingFeatures
from ._motion import MotionFeatures

__all__ = [
    "primitive_features", "nearest_centre", "trajectory_features", "FEATURE_KINDS", "TRAJECTORY_FEATURES",
]



def primitive_features(demos, *, kind: str = "default", n_points: int = 16) -> np.ndarray:
    """The library's per-primitive feature vectors before its PCA step, shape ``(n, n_features)``.

    ``kind="default"`` uses :class:`~skillbank.clustering.HeadingFeatures`'s
    direction-over-time description (start, goal, facing and size invariant);
    ``kind="position"`` the positions resampled to ``n_points`` samples evenly
    in time and flattened (keeps where the motion happens).

    Parameters
    ----------
    demos : list of Demonstration
        Each with a ``"position"`` stream of at least 2 samples, all with the
        same number of dimensions.
    kind : {"default", "position"}
    n_points : int, default=16

    Examples
    --------
    >>> from skillbank import Demonstration
    >>> t = np.linspace(0, 1, 20)
    >>> d = Demonstration.from_array(np.column_stack([t, t]), t)
    >>> primitive_features([d, d], n_points=8).shape
    (2, 14)
    """
    if kind not in FEATURE_KINDS:
        raise ValueError(f"features: expected one of {list(FEATURE_KINDS)}, got {kind!r}")
    short = [k for k, d in enumerate(demos) if d.n_steps < 2]
    if short:
        raise ValueError(f"primitives: expected at least 2 samples each to compute features, "
                         f"got {len(short)} shorter one(s)")
    dims = sorted({d["position"].shape[1] for d in demos})
    if len(dims) > 1:
        raise ValueError(f"primitives: expected positions with one number of dimensions, got "
                         f"{summarise(dims)}")
    if kind == "default":
        return HeadingFeatures(n_points=n_points, n_components=None).fit_transform(demos)
    R = resample_many([d["position"] for d in demos], [d.t for d in demos], n_points, "time")
    return R.reshape(R.shape[0], -1)



def nearest_centre(X, centers) -> np.ndarray:
    """Index of the nearest centre of each row of ``X`` (ties to the lowest index).

    The one nearest-centre rule, shared by :meth:`ElasticClustering.predict`
    and the pipeline's incremental assignment. Distances are computed about
    the centres' mean, which keeps the expanded form accurate far from the origin.

    Examples
    --------
    >>> nearest_centre(np.array([[0.9], [5.2]]), np.array([[0.0], [5.0]])).tolist()
    [0, 1]
    """
    X = check_array(X, name="X", ndim=2, min_samples=0)
    centers = check_array(centers, name="centers", ndim=2)
    if X.shape[1] != centers.shape[1]:
        raise ValueError(f"X: expected {centers.shape[1]} features like the centres, got {X.shape[1]}")
    with numerical_errors("nearest_centre"):
        shift = centers.mean(axis=0)
        return assign(X - shift, centers - shift)[0].astype(np.intp)


#: Featurisers of a folder of trajectories, by name (``skillbank cluster --features``).
TRAJECTORY_FEATURES = ("default", "heading", "angular", "dtw", "none")


def trajectory_features(demos, kind: str = "default", *, representatives=None, random_state=None):
    """Feature matrix of a list of trajectories for clustering, shape ``(n, n_features)``.

    Parameters
    ----------
    demos : list of Demonstration
        Each with a ``"position"`` stream.
    kind : {"default", "heading", "angular", "dtw", "none"}
        ``"default"``: :class:`MotionFeatures` (unit step directions over
        time in the heading and the recording frame, and along the path in
        the heading frame: shape and direction). ``"heading"``:
        :class:`HeadingFeatures` (direction over time in each trajectory's
        heading frame, 3 PCA components; the default before). ``"angular"``: angular similarity to the
        ``representatives`` (indices into ``demos``), min-max normalised per
        column as in the paper. ``"dtw"``: :class:`DTWFeatures`. ``"none"``:
        the positions flattened (equal lengths only).
    representatives : list of int, optional
        For ``kind="angular"``.
    random_state : int, optional

    Examples
    --------
    >>> from skillbank import Demonstration
    >>> t = np.linspace(0, 1, 30)
    >>> demos = [Demonstration.from_array(np.column_stack([t, a * t]), t) for a in (0.0, 1.0, 2.0)]
    >>> trajectory_features(demos, "none").shape
    (3, 60)
    """
    if kind not in TRAJECTORY_FEATURES:
        raise ValueError(f"features: expected one of {list(TRAJECTORY_FEATURES)}, got {kind!r}")
    if kind == "default":
        return MotionFeatures(random_state=random_state).fit_transform(demos)
    if kind == "heading":
        return HeadingFeatures(random_state=random_state).fit_transform(demos)
    if kind == "dtw":
        return DTWFeatures().fit_transform(demos)
    if kind == "angular":
        if not representatives:
            raise ValueError("representatives: angular features need the indices of some representatives, "
                             "e.g. [0, 5, 9]")
        bad = [i for i in representatives if not 0 <= i < len(demos)]
        if bad:
            raise ValueError(f"representatives: expected indices in 0..{len(demos) - 1}, got "
                             f"{summarise(bad)}")
        reps = [demos[i] for i in representatives]
        return minmax_scale(AngularSimilarityFeatures(representatives=reps).fit_transform(demos))
    lengths = sorted({d.n_steps for d in demos})
    if len(lengths) > 1:
        raise ValueError(f"features: 'none' flattens the positions and needs trajectories of equal length, "
                         f"got lengths {summarise(lengths)}; use --features default or dtw")
    return np.stack([d["position"].ravel() for d in demos])
