"""How much of a stream's jerk is round-off: the values' representable precision and its floor.

A third derivative on a fine grid divides the values' round-off by the cube
of the sample period: at 1 ms, a position written with 12 significant digits
(round-off ~5e-13 per value) carries ~5e-4 of round-off in its jerk, which at
10^6 samples is tens of times the jerk of the motion itself. The same motion
kept at full precision does not, so two copies of one trajectory were cut at
different places. This module estimates the round-off per value, from the
grid the values lie on, so that the segmenter can differentiate over a wider
stride where the round-off would otherwise dominate.

The estimate has a floor, shared by every copy of a stream: half a step of a
32-bit count over the stream's range. Otherwise the stride would follow the
digits a file happened to keep: a full-precision original (differentiated
over single samples) and its 12-digit copy (over a stride) measured the jerk
at different scales, which moved an event at the detection threshold by a few
per cent, enough to cut one and not the other.
"""

from __future__ import annotations

import numpy as np

__all__ = ["value_resolution", "roundoff_level", "empirical_level", "resolution_floor"]

#: The representation is read off this many values spread over the array (and
#: its largest one): a file's precision is the same throughout, and formatting
#: every value of a 10^6-sample stream would cost more than segmenting it.
PRECISION_SAMPLE = 256

#: float64 holds 53 significant bits. A value that needs more than 15
#: significant decimal digits to be written back exactly is at full
#: precision: its grid is the binary one (16 and 17 digits resolve the double).
FLOAT_BITS = 53
DECIMAL_DIGITS = 15

#: Third differences of white round-off errors of standard deviation s have
#: standard deviation sqrt(20) s (the stencil 1, -3, 3, -1); the median absolute
#: deviation of a normal variable is 0.6745 of its standard deviation; and an
#: error uniform over one grid step (width q) has s = q / sqrt(12), half a step
#: being sqrt(3) s.
THIRD_DIFFERENCE_GAIN = np.sqrt(20.0)
MAD_PER_SIGMA = 0.6745
HALF_STEP_PER_SIGMA = np.sqrt(3.0)

#: No recorded stream resolves its values, or its time stamps, more finely
#: than a count of this many bits over its range (encoders and converters
#: have at most 24; a controller clock jitters by microseconds, 2^-32 of an hour).
#: Digits beyond that are arithmetic, not measurement: a full-precision
#: original and a copy written with 12 significant digits then share one
#: level, and the jerk is measured at one scale, set by the motion and the
#: sampling rather than by how many digits a file happened to keep.
RANGE_BITS = 32

#: ... and a clock's floor is that of an hour at most (s): a clock counts time in absolute units (a
#: controller's microseconds, a bag's nanoseconds), so a longer recording is timed no less finely,
#: and the stride the jerk is taken over (with it where the cuts fall) must not grow with its length.
CLOCK_SPAN = 3600.0


def _sample(x: np.ndarray, biggest: int) -> np.ndarray:
    """Up to ``PRECISION_SAMPLE`` evenly spread values of ``x``, and its largest (at ``biggest``)."""
    idx = np.linspace(0, x.size - 1, min(x.size, PRECISION_SAMPLE)).astype(int)
    return np.append(x[idx], x[biggest])


def _significant_bits(values: np.ndarray) -> int:
    """Most significant binary digits any of ``values`` uses (53 for computed float64, 24 for float32)."""
    mantissa, _ = np.frexp(np.abs(values))
    ints = (mantissa * 2.0**FLOAT_BITS).astype(np.int64)  # exact: mantissa in [0.5, 1)
    lowest_bit = ints & -ints
    return FLOAT_BITS - int(np.log2(lowest_bit.astype(float)).min())


def _significant_digits(values: np.ndarray):
    """Fewest significant decimal digits that write every one of ``values`` back exactly; None beyond 15."""
    # full-precision data soon give a value that 15 digits miss, and ``all`` stops there
    if not all(float(f"{v:.{DECIMAL_DIGITS}g}") == v for v in values.tolist()):
        return None
    lo, hi = 1, DECIMAL_DIGITS
    # a value exact at p digits is exact at p + 1, so the digits can be bisected
    while lo < hi:
        mid = (lo + hi) // 2
        if all(float(f"{v:.{mid}g}") == v for v in values.tolist()):
            hi = mid
        else:
            lo = mid + 1
    return lo


def value_resolution(x) -> float:
    """Half the spacing of the grid ``x``'s values lie on, at its largest magnitude.

    Values read from a file written with ``p`` significant decimal digits lie
    on a decimal grid; values stored as float32 on a binary grid of 24 bits;
    computed float64 values on the full 53-bit grid. Whichever grid is coarser
    is the values' round-off: each may be off the value it stands for by up to
    half a step. The step is taken at the largest magnitude (where it is
    widest for a relative grid, and the same as anywhere for a fixed one).

    Parameters
    ----------
    x : array-like
        Finite values.

    Returns
    -------
    float
        0.0 when every value is zero.

    Examples
    --------
    >>> value_resolution([0.25, 1.5, -3.0])  # short decimals: 3.0 sits on a grid of step 1
    0.5
    >>> value_resolution([float(f"{v:.12g}") for v in np.linspace(1, 2, 50) ** 0.5])  # 12 digits
    5e-12
    >>> bool(value_resolution(np.linspace(1, 2, 50) ** 0.5) == np.spacing(2.0 ** 0.5) / 2)  # full float64
    True
    """
    x = np.asarray(x, dtype=float).ravel()
    x = x[x != 0.0]  # zero lies on every grid
    if x.size == 0:
        return 0.0
    biggest = int(np.argmax(np.abs(x)))
    big = abs(float(x[biggest]))
    values = _sample(x, biggest)
    binary = 2.0 ** (np.frexp(big)[1] - _significant_bits(values) - 1)
    digits = _significant_digits(values)
    if digits is None:
        return float(binary)
    decimal = 0.5 * 10.0 ** (np.floor(np.log10(big)) - digits + 1)
    return float(max(binary, decimal))


def empirical_level(x) -> np.ndarray:
    """Round-off of each column of ``x`` as seen in its third differences, as a half grid step.

    On a finely sampled smooth signal the third differences are round-off
    (or noise); on a coarse one they are the signal's, and the estimate is
    large. A signal held at exact values (a gripper at 0 or 1) has third
    differences of zero most of the time, and an estimate of zero: its values
    are exact, whatever grid they lie on.

    Examples
    --------
    >>> empirical_level(np.repeat([0.0, 1.0], 50)[:, None]).tolist()
    [0.0]
    """
    x = np.asarray(x, dtype=float)
    x = x.reshape(x.shape[0], -1)
    if x.shape[0] < 4:
        return np.zeros(x.shape[1])
    d3 = np.diff(x, 3, axis=0)
    mad = np.median(np.abs(d3 - np.median(d3, axis=0)), axis=0)
    return HALF_STEP_PER_SIGMA * mad / (MAD_PER_SIGMA * THIRD_DIFFERENCE_GAIN)


def resolution_floor(x, *, span=None) -> np.ndarray:
    """Per-column least round-off of ``x``: half a step of a ``RANGE_BITS``-bit count over the column's range.

    ``span``: the largest range that counts (:data:`CLOCK_SPAN` for time stamps).

    Examples
    --------
    >>> resolution_floor(np.column_stack([np.linspace(0.0, 2.0**33, 5), np.ones(5)])).tolist()
    [1.0, 0.0]
    """
    x = np.asarray(x, dtype=float)
    x = x.reshape(x.shape[0], -1)
    if x.shape[0] == 0:
        return np.zeros(x.shape[1])
    # column by column: a reduction over the rows of a narrow array is ten times slower
    spans = np.array([x[:, k].max() - x[:, k].min() for k in range(x.shape[1])])
    if span is not None:
        spans = np.minimum(spans, span)
    return spans * 2.0 ** -(RANGE_BITS + 1)


def roundoff_level(x, *, empirical: bool = False, span=None) -> np.ndarray:
    """Per-column round-off of ``x``: :func:`value_resolution`, less where the data show less, above a floor.

    With ``empirical=True``, each column's level is the smaller of its grid's
    half step and :func:`empirical_level`: exact values on a coarse grid (a
    held signal) then count as exact, to within the floor. The floor is
    :func:`resolution_floor`, half a ``RANGE_BITS``-bit step of the column's
    range: a value known more finely than that was computed, not measured, and
    a copy that keeps fewer digits but still more than that is the same data.
    ``span`` caps the range the floor is taken over (:func:`resolution_floor`).

    Examples
    --------
    >>> roundoff_level(np.column_stack([np.repeat([0.0, 1.0], 50), np.zeros(100)])).tolist()
    [0.5, 0.0]
    >>> roundoff_level(np.repeat([0.0, 1.0], 50), empirical=True).tolist() == [2.0**-33]  # the floor
    True
    >>> bool(roundoff_level(np.linspace(1, 2, 50) ** 0.5)[0] == (2**0.5 - 1) * 2.0**-33)  # float64: the floor
    True
    """
    x = np.asarray(x, dtype=float)
    x = x.reshape(x.shape[0], -1)
    level = np.array([value_resolution(x[:, k]) for k in range(x.shape[1])])
    floor = resolution_floor(x, span=span)
    # the data can show a grid too coarse only where it is coarser than the floor (which
    # spares the median of every third difference of a full-precision stream)
    coarse = level > floor
    if empirical and coarse.any():
        level[coarse] = np.minimum(level[coarse], empirical_level(x[:, coarse]))
    return np.maximum(level, floor)
