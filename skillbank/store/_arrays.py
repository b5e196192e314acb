"""How the store serialises values: arrays as ``.npy`` bytes (never pickles), the rest as JSON."""

from __future__ import annotations

import io
import json

import numpy as np

from ..io import to_jsonable

__all__ = ["to_npy", "from_npy", "to_json", "from_json"]


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
    return json.dumps(to_jsonable(obj), allow_nan=False, sort_keys=True)


def from_json(text):
    """Parse JSON text stored by :func:`to_json` (``None`` stays ``None``)."""
    return None if text is None else json.loads(text)
