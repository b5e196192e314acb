"""Streams and columns that carry no information: constant, or constant to within their round-off.

A force sensor that reads zero throughout, a torque stream recorded as 0.5
everywhere, a quaternion component that never leaves 0: such a column has no
boundary to show, and every measure of its events divides by its spread (a
contact step's effect size by the level's jitter, the profile by its largest
peaks), which is zero. It is set aside before any of that: a stream whose
every column is constant takes no part in the segmentation (its evidence
would otherwise dilute the other streams of its kind, which are averaged), and
a constant column of an informative stream is left out of that stream (its
representation's grid would otherwise pass for round-off of the whole stream).
The other streams then segment exactly as they would without it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CONSTANT_ULPS", "constant_columns", "why_constant"]

#: A column is constant when its range is at most this many units in the last
#: place of its largest magnitude, in the precision its values are stored in
#: (float32 when every value is a float32, else float64): a few unit
#: conversions or sums leave a held value a few units off; a measured change
#: of a sensor, however small, spans many more (the coarsest, a 24-bit
#: converter, resolves 2^-24 of its range, about 10^6 float64 units at full scale).
CONSTANT_ULPS = 16


def _unit_in_last_place(Y: np.ndarray) -> np.ndarray:
    """Per column, the spacing of the stored precision at the column's largest magnitude."""
    big = np.abs(Y).max(axis=0)
    with np.errstate(over="ignore", invalid="ignore"):
        # a value outside float32's range is not a float32 (the cast gives inf, which differs)
        single = np.all(Y.astype(np.float32).astype(float) == Y, axis=0)
    unit = np.spacing(big)
    if single.any():
        unit[single] = np.spacing(big[single].astype(np.float32)).astype(float)
    return unit


def constant_columns(Y) -> np.ndarray:
    """Which columns of ``Y`` (n_steps, n_dims) are constant, to within :data:`CONSTANT_ULPS` of round-off.

    Examples
    --------
    >>> Y = np.column_stack([np.zeros(5), np.full(5, 0.5), np.linspace(0, 1, 5)])
    >>> constant_columns(Y).tolist()
    [True, True, False]
    >>> constant_columns(np.column_stack([0.1 + np.arange(5) * 1e-17, [0.0, 1.0, 0.0, 1.0, 0.0]])).tolist()
    [True, False]
    """
    Y = np.asarray(Y, dtype=float)
    Y = Y.reshape(Y.shape[0], -1)
    if Y.shape[0] == 0:
        return np.ones(Y.shape[1], dtype=bool)
    spread = Y.max(axis=0) - Y.min(axis=0)
    return spread <= CONSTANT_ULPS * _unit_in_last_place(Y)


def why_constant(Y) -> str:
    """A short reason for a stream whose every column is constant, for the note that sets it aside.

    Examples
    --------
    >>> why_constant(np.zeros((10, 3)))
    'constant: every value is 0'
    >>> why_constant(np.column_stack([np.zeros(4), np.full(4, 0.5)]))
    'constant: each column holds one value throughout'
    >>> why_constant(np.full((4, 1), 0.1) + np.array([[0.0], [1e-17], [0.0], [0.0]]))
    'constant to within round-off: its values vary by at most 1.4e-17 about 0.1'
    """
    Y = np.asarray(Y, dtype=float)
    Y = Y.reshape(Y.shape[0], -1)
    lo, hi = Y.min(axis=0), Y.max(axis=0)
    if np.all(lo == hi):
        if np.all(lo == lo[0]):
            return f"constant: every value is {float(lo[0]):g}"
        return "constant: each column holds one value throughout"
    spread = float(np.max(hi - lo))
    return (f"constant to within round-off: its values vary by at most {spread:.2g} "
            f"about {float(np.abs(Y).max()):.3g}")
