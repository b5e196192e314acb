"""Arrays as ``.npy`` bytes, JSON helpers and the library's trajectory featurisers."""

from __future__ import annotations

import io
import json

import numpy as np

__all__ = ["to_npy", "from_npy", "to_json", "from_json", "flat_features", "FEATURE_KINDS"]

FEATURE_KINDS = ("default", "position")


def to_npy(array) -> bytes:
    """Serialise a numeric array as ``.npy`` bytes (never a pickle).

    Examples
    --------
    >>> from_npy(to_npy(np.arange(3.0))).tolist()
    [0.0, 1.0, 2.0]
    """
    arr = np.asarray(array)
    if arr.dtype == object:
        raise ValueError(f"array: expected a numeric array, got dtype {arr.dtype}")
    buf = io.BytesIO()
    np.save(buf, arr, allow_pickle=False)
    return buf.getvalue()


def from_npy(blob) -> np.ndarray:
    """Load ``.npy`` bytes written by :func:`to_npy`, refusing pickles.

    Examples
    --------
    >>> from_npy(to_npy(np.eye(2))).shape
    (2, 2)
    """
    if blob is None:
        raise ValueError("array: expected .npy bytes, got NULL")
    try:
        return np.load(io.BytesIO(bytes(blob)), allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise ValueError(f"array: stored bytes are not a numeric .npy array ({exc})") from None


def to_json(obj) -> str:
    """JSON text of ``obj`` with numpy values and paths converted.

    Examples
    --------
    >>> to_json({"a": np.int64(2)})
    '{"a": 2}'
    """
    from ..io import to_jsonable

    return json.dumps(to_jsonable(obj), allow_nan=False, sort_keys=True)


def from_json(text):
    """Parse JSON text stored by :func:`to_json` (``None`` stays ``None``)."""
    return None if text is None else json.loads(text)


def flat_features(demos, *, kind: str = "default", n_points: int = 16) -> np.ndarray:
    """Per-primitive feature vectors before the PCA step, shape ``(n, n_features)``.

    ``kind="default"`` uses :class:`skillbank.clustering.HeadingFeatures`'s
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
    >>> flat_features([d, d], n_points=8).shape
    (2, 14)
    """
    from ..clustering import HeadingFeatures, resample_trajectories

    if kind not in FEATURE_KINDS:
        raise ValueError(f"features: expected one of {list(FEATURE_KINDS)}, got {kind!r}")
    short = [k for k, d in enumerate(demos) if d.n_steps < 2]
    if short:
        raise ValueError(f"primitives: expected at least 2 samples each to compute features, "
                         f"got {len(short)} shorter one(s)")
    dims = sorted({d["position"].shape[1] for d in demos})
    if len(dims) > 1:
        raise ValueError(f"primitives: expected positions with one number of dimensions, got {dims}")
    if kind == "default":
        return HeadingFeatures(n_points=n_points, n_components=None).fit_transform(demos)
    R = resample_trajectories([d["position"] for d in demos], [d.t for d in demos], n_points, "time")
    return R.reshape(R.shape[0], -1)
