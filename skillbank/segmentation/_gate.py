"""Kinematic gate: keep the jerk events where the motion stops or turns."""

from __future__ import annotations

import numpy as np

from ._changepoints import suppress_close
from ._profile import TYPICAL_PERCENTILE, speed_norm, windowed_mean

__all__ = ["gate_changepoints"]

#: The speed is smoothed by boxes of half-width ``window // SMOOTH_DIVISOR``.
#: Their two passes span about half a window: enough to even out sample-level
#: noise in the speed, and narrower than the jerk window, so they cannot merge
#: two valleys that the jerk profile tells apart.
SMOOTH_DIVISOR = 8

#: Two passes of a centred box make a triangle, which is symmetric: a
#: symmetric valley keeps its minimum exactly where it was. Each pass can shift
#: an asymmetric minimum by up to its half-width, so the raw minimum is looked
#: for within ``SMOOTH_PASSES`` half-widths of the smoothed one.
SMOOTH_PASSES = 2

#: A stream is at rest where its smoothed speed is below this fraction of its
#: typical speed (the ``TYPICAL_PERCENTILE`` of the smoothed speed): a stop
#: that deep is a stop whatever the speeds either side.
AT_REST_FRACTION = 0.05

#: The slow stretch around a stop is where the speed stays within this
#: fraction of the way from the valley's lowest speed up to the slower side's
#: peak: so close to the minimum that the speed there has no one slowest sample.
SLOW_FRACTION = 0.1

#: A rest of at least this fraction of a minimum segment is a real rest (the
#: robot waits, a gripper holds), where a pen turning at a corner stops for a
#: few samples only.
MIN_REST = 0.5


def _smooth(v: np.ndarray, half_width: int) -> np.ndarray:
    """``v`` smoothed by ``SMOOTH_PASSES`` centred boxes of ``2 * half_width + 1`` samples.

    Examples
    --------
    >>> v = np.array([3.0, 2.0, 1.0, 0.0, 1.0, 2.0, 3.0])
    >>> int(np.argmin(_smooth(v, 1)))  # a symmetric valley stays put
    3
    """
    width = 2 * half_width + 1
    for _ in range(SMOOTH_PASSES):
        v = windowed_mean(v, width)
    return v


def chord_angles(Y: np.ndarray, at, h: int) -> np.ndarray:
    """Angles (degrees) between the chords over the ``h`` samples before and after each index ``at``.

    A chord of zero length (no motion on one side) gives 0.

    Examples
    --------
    >>> Y = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    >>> chord_angles(Y, [1], 1).tolist()
    [90.0]
    """
    Y = np.asarray(Y, dtype=float).reshape(Y.shape[0], -1)
    at = np.asarray(at, dtype=int)
    n = Y.shape[0]
    a = Y[at] - Y[np.maximum(at - h, 0)]
    b = Y[np.minimum(at + h, n - 1)] - Y[at]
    na, nb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    ok = (na > 0) & (nb > 0)
    cos = np.ones(at.shape[0])
    cos[ok] = np.einsum("ij,ij->i", a[ok], b[ok]) / (na[ok] * nb[ok])
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _turn_degrees(Y: np.ndarray, c: int, h: int) -> float:
    """Angle between the chords over the ``h`` samples before and after ``c``."""
    return float(chord_angles(Y, [c], h)[0])


def _argmin_near(x: np.ndarray, centre: int) -> int:
    """Index of the minimum of ``x``; exact ties go to the one nearest ``centre``."""
    idx = np.flatnonzero(x == x.min())
    return int(idx[np.argmin(np.abs(idx - centre))])


def _nearest_run(mask: np.ndarray, c: int):
    """``(start, end)`` of the run of True in ``mask`` nearest index ``c``, or None."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return None
    starts = np.r_[0, np.flatnonzero(np.diff(idx) > 1) + 1]
    ends = np.r_[starts[1:], idx.size] - 1
    dist = np.maximum(idx[starts] - c, 0) + np.maximum(c - idx[ends], 0)
    r = int(np.argmin(dist))
    return int(idx[starts[r]]), int(idx[ends[r]])


def _stop_position(v, v_raw, span: tuple, c: int, *, low: float, side: float, at_rest: float,
                   min_size: int, s: int) -> int:
    """Where the stop that changepoint ``c`` belongs to should be cut.

    A rest of at least half a minimum segment (the robot waits, a gripper
    holds), or a slow stretch as long as a minimum segment, has no single
    slowest sample, and the jerk event already marks where the motion ends or
    starts: the cut stays. A brief stop (a pen turning at a corner) is cut at
    its slowest sample, found on the smoothed speed and refined on the raw one.
    """
    lo, hi = span
    rest = _nearest_run(v[lo:hi + 1] <= at_rest, c - lo)
    if rest is not None and rest[1] - rest[0] + 1 >= MIN_REST * min_size:
        return c
    a, b = _nearest_run(v[lo:hi + 1] <= low + SLOW_FRACTION * (side - low), c - lo)
    if b - a + 1 >= min_size:
        return c
    pos = lo + a + _argmin_near(v[lo + a:lo + b + 1], c - lo - a)
    # each box pass of half-width s can shift an asymmetric minimum by up to s
    a, b = max(pos - SMOOTH_PASSES * s, 0), min(pos + SMOOTH_PASSES * s, v_raw.shape[0] - 1)
    return a + _argmin_near(v_raw[a:b + 1], pos - a)


def gate_changepoints(changepoints, strength, t, Y, *, window: int, min_size: int, grace: int,
                      stop_ratio: float, min_turn: float):
    """Keep the changepoints where the motion stops or turns, and pin stops to the stop.

    A jerk event marks a primitive boundary when the motion either comes
    (nearly) to rest between two movements, or changes direction. Jerk events
    in the middle of a smooth movement (speed fluctuations, a curve that
    tightens) are neither, and are dropped. For each changepoint ``c``:

    * **stop**: the lowest (lightly smoothed) speed within ``min_size`` of
      ``c``, and no nearer to a neighbour than to ``c``, is a valley (not
      the edge of that range) and at most
      ``stop_ratio`` times the peak speed of the movement on either side (or
      below 5 % of the stream's typical speed: it was at rest). A brief stop
      moves the changepoint to its slowest sample; a long rest keeps it where
      the jerk put it, where the motion ends or starts (see
      ``_stop_position``).
    * **turn**: the chords over one ``window`` before and after ``c`` differ
      in direction by at least ``min_turn`` degrees. The changepoint stays.

    Failing changepoints are dropped worst first (the worst of each run of
    neighbours per round) and the rest re-examined, because dropping one
    merges two movements and raises the peak speeds the others are compared
    with. The loop runs over changepoints, never over samples.

    Parameters
    ----------
    changepoints, strength : ndarray
        Sorted changepoints and their event strengths.
    t : ndarray of shape (n_steps,)
    Y : ndarray of shape (n_steps, n_dims)
    window, min_size, grace : int
        The stream's settings, in samples.
    stop_ratio : float
        Largest speed at the boundary, as a fraction of the slower side's peak.
    min_turn : float
        Smallest change of direction, in degrees, that makes a boundary.

    Returns
    -------
    changepoints, strength : ndarray
        At least ``min_size`` apart and from either end.

    Examples
    --------
    >>> t = np.linspace(0.0, 2.0, 401)
    >>> x = np.where(t < 1.0, np.sin(np.pi * t) ** 2, 0.0)  # out and back, then rest
    >>> cps, _ = gate_changepoints(np.array([100, 150]), np.ones(2), t, x[:, None], window=16,
    ...                            min_size=40, grace=16, stop_ratio=0.5, min_turn=45.0)
    >>> cps.tolist()  # 100 is the reversal; 150 is mid-way back, so it goes
    [100]
    """
    Y = np.asarray(Y, dtype=float).reshape(len(t), -1)
    return _gate_changepoints(changepoints, strength, Y, speed_norm(t, Y), window=window,
                              min_size=min_size, grace=grace, stop_ratio=stop_ratio, min_turn=min_turn)


def _gate_changepoints(changepoints, strength, Y, speed, *, window: int, min_size: int, grace: int,
                       stop_ratio: float, min_turn: float):
    """:func:`gate_changepoints` given ``Y`` as (n_steps, n_dims) and its :func:`speed_norm`.

    The segmenter computes the speed once per stream, for the relative jerk
    scale and for this gate.
    """
    cps = np.asarray(changepoints, dtype=int)
    strength = np.asarray(strength, dtype=float)
    if cps.size == 0:
        return cps, strength
    v_raw = np.asarray(speed, dtype=float)
    Y = np.asarray(Y, dtype=float).reshape(v_raw.shape[0], -1)
    n = Y.shape[0]
    s = max(1, window // SMOOTH_DIVISOR)
    v = _smooth(v_raw, s)
    at_rest = AT_REST_FRACTION * float(np.percentile(v, TYPICAL_PERCENTILE))
    keep = np.ones(cps.size, dtype=bool)
    while True:
        idx = np.flatnonzero(keep)
        if idx.size == 0:
            break
        c = cps[idx]
        bounds = np.concatenate(([0], c, [n - 1]))
        moved = c.copy()
        ratio = np.zeros(c.size)
        for k, ck in enumerate(c):
            lo = max(ck - min_size, (bounds[k] + ck) // 2, grace, 0)
            hi = min(ck + min_size, (ck + bounds[k + 2]) // 2, n - 1 - grace)
            if hi < lo:
                lo, hi = ck, ck
            valley = lo + int(np.argmin(v[lo:hi + 1]))
            side = min(v[bounds[k]:valley + 1].max(), v[valley:bounds[k + 2] + 1].max())
            low = v[valley]
            if low <= at_rest:
                ratio[k] = 0.0
            elif valley in (lo, hi):
                # still slowing down at the edge: the stop belongs to a neighbour or an end
                ratio[k] = np.inf
            else:
                # side >= low > at_rest >= 0 here; the guard is for subnormal speeds only
                ratio[k] = low / max(side, 1e-300)
            if ratio[k] <= stop_ratio:
                moved[k] = _stop_position(v, v_raw, (bounds[k], bounds[k + 2]), int(ck), low=low,
                                          side=side, at_rest=at_rest, min_size=min_size, s=s)
            elif _turn_degrees(Y, int(ck), window) >= min_turn:
                ratio[k] = 0.0
        failing = ratio > stop_ratio
        ratio = np.where(np.isinf(ratio), np.finfo(float).max, ratio)
        cps[idx] = np.where(failing, cps[idx], moved)
        if not failing.any():
            break
        # drop each failing changepoint that is the worst among its neighbours
        # (one per merge), so that a long run of them costs few rounds
        r = np.where(failing, ratio, -np.inf)
        worst = failing & (r >= np.r_[-np.inf, r[:-1]]) & (r >= np.r_[r[1:], -np.inf])
        keep[idx[worst]] = False
    # two stops moved onto the shared edge of their ranges: keep the first; a
    # moved stop may also have come closer than min_size to a neighbour or an end
    cps, strength = cps[keep], strength[keep]
    first = np.diff(cps, prepend=-1) > 0
    cps, strength = cps[first], strength[first]
    kept = suppress_close(cps, strength, min_size=min_size, n_steps=n)
    return kept, strength[np.isin(cps, kept)]
