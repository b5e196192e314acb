"""Per-stream jerk profile: third derivative, norm, sliding-window mean, normalisation."""

from __future__ import annotations

import numpy as np

from ..core._validation import check_array, check_time

__all__ = ["jerk", "jerk_profile", "windowed_mean", "normalize_profile", "speed_norm"]

#: A profile scale at or below this is flat: a constant signal then gives no
#: changepoint, instead of round-off amplified to events of height 1.
FLAT_SCALE = 1e-12

#: A stream's typical speed is this percentile of its speed: its cruising speed,
#: which a few glitches (the top 5 %) cannot inflate and the rests cannot lower.
TYPICAL_PERCENTILE = 95.0

#: The relative scale divides the jerk by ``speed + TYPICAL_FRACTION * typical``:
#: the floor keeps the ratio finite where the motion stops, and caps how much a
#: stop's jerk is emphasised over a cruising one's at 1 / 0.05 = 20 times.
TYPICAL_FRACTION = 0.05

#: A typical speed below ``HELD_TOLERANCE * (1 + max|Y|)`` per sample period is
#: a held signal (e.g. a gripper that never moves), not motion: a billionth of
#: the signal's magnitude per sample is far below any sensor's resolution, yet
#: far above the round-off (~1e-16 relative) that differentiation leaves in it.
HELD_TOLERANCE = 1e-9

#: The robust scale is the median of this many highest peaks: one or two
#: spikes (a sensor glitch) then saturate at 1 instead of squashing every other
#: event, while five real events of similar height still set the scale.
ROBUST_PEAKS = 5

#: Peaks lower than this fraction of the highest are round-off ripples on a
#: noiseless line, not events, and take no part in the robust scale.
RIPPLE_RATIO = 1e-6


def jerk(t, Y) -> np.ndarray:
    """Third time derivative of ``Y``, correct for uneven sampling.

    Each of the three derivatives uses second-order accurate differences on
    the actual sample times (central inside, one-sided at the ends).

    Parameters
    ----------
    t : array-like of shape (n_steps,)
    Y : array-like of shape (n_steps, n_dims)

    Returns
    -------
    ndarray of shape (n_steps, n_dims)

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 1.0, 50)
    >>> np.allclose(jerk(t, t[:, None] ** 3)[3:-3], 6.0)  # one-sided ends are less exact
    True
    """
    t = check_time(t, min_samples=4)
    Y = check_array(Y, name="Y", ndim=(1, 2), as_2d=True, min_samples=4)
    if Y.shape[0] != t.shape[0]:
        raise ValueError(f"Y: expected {t.shape[0]} samples to match t, got {Y.shape[0]}")
    d = Y
    for _ in range(3):
        d = np.gradient(d, t, axis=0, edge_order=2)
    return d


def windowed_mean(x, window: int) -> np.ndarray:
    """Centred sliding-window mean; near the ends the window shrinks.

    A cumulative sum makes it O(n) whatever the window.

    Examples
    --------
    >>> windowed_mean(np.array([0.0, 0.0, 3.0, 0.0, 0.0]), 3).tolist()
    [0.0, 1.0, 1.0, 1.0, 0.0]
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    c = np.concatenate(([0.0], np.cumsum(x)))
    idx = np.arange(n)
    lo = np.clip(idx - window // 2, 0, n)
    hi = np.clip(idx - window // 2 + window, 0, n)
    return (c[hi] - c[lo]) / (hi - lo)


def normalize_profile(m, *, method: str = "robust", grace: int = 0) -> np.ndarray:
    """Scale a non-negative profile so that typical jerk events reach about 1.

    ``"max"`` divides by the maximum (the paper's choice): one spike anywhere
    then shrinks every other event. ``"robust"`` divides by the median of the
    ``ROBUST_PEAKS`` (5) highest peaks of the interior (``grace`` samples
    excluded at each end, where start-up transients and differentiation edge
    effects live), so that a single spike rises above 1 instead of hiding the
    other changepoints.

    Examples
    --------
    >>> normalize_profile(np.array([0.0, 1.0, 2.0]), method="max").tolist()
    [0.0, 0.5, 1.0]
    """
    m = np.asarray(m, dtype=float)
    if method == "max":
        scale = m.max()
    elif method == "robust":
        inner = m[grace : m.shape[0] - grace] if m.shape[0] > 2 * grace + 1 else m
        # a plateau counts once, at its last sample
        is_peak = np.r_[False, (inner[1:-1] >= inner[:-2]) & (inner[1:-1] > inner[2:]), False]
        heights = np.sort(inner[is_peak])[::-1][:ROBUST_PEAKS]
        heights = heights[heights >= RIPPLE_RATIO * heights[0]] if heights.size else heights
        scale = float(np.median(heights)) if heights.size else 0.0
        if scale <= FLAT_SCALE:
            # no interior peak (a monotone profile): fall back to the maximum
            scale = m.max()
    else:
        raise ValueError(f"normalize: expected 'robust' or 'max', got {method!r}")
    if not np.isfinite(scale) or scale <= FLAT_SCALE:
        return np.zeros_like(m)
    # no clipping: a flattened top would move the half-height onset of an event
    return m / scale


def speed_norm(t, Y) -> np.ndarray:
    """Speed per sample: norm of the first derivative on the real time stamps.

    Returns
    -------
    ndarray of shape (n_steps,)

    Examples
    --------
    >>> speed_norm(np.arange(4.0), np.array([[0.0, 0.0], [3.0, 4.0], [6.0, 8.0], [9.0, 12.0]])).tolist()
    [5.0, 5.0, 5.0, 5.0]
    """
    Y = np.asarray(Y, dtype=float).reshape(len(t), -1)
    return np.linalg.norm(np.gradient(Y, np.asarray(t, dtype=float), axis=0), axis=1)


def jerk_profile(t, Y, *, window: int, scale: str = "relative", normalize: str = "robust",
                 grace: int = 0):
    """Normalised sliding-window mean of the jerk norm of one stream.

    Parameters
    ----------
    t : array-like of shape (n_steps,)
    Y : array-like of shape (n_steps, n_dims)
    window : int
        Sliding-window width in samples.
    scale : {"relative", "absolute"}, default="relative"
        ``"absolute"`` is the paper's plain jerk norm. ``"relative"`` divides it
        by the local speed (plus 5 % of the stream's typical speed, its 95th
        percentile), which makes the profile independent of the stream's units
        and emphasises stops and reversals, where one primitive hands over to
        the next.
    normalize : {"robust", "max"}, default="robust"
        ``"max"`` divides the windowed mean by its maximum (the paper's);
        ``"robust"`` by the median of its five highest interior peaks, so
        that one spike rises above 1 instead of shrinking every other event.
    grace : int, default=0
        Samples at each end left out of the normalisation.

    Returns
    -------
    raw : ndarray of shape (n_steps,)
        Jerk norm (relative or absolute) per sample.
    profile : ndarray of shape (n_steps,)
        Windowed, normalised profile; typical events reach about 1.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 100)
    >>> raw, prof = jerk_profile(t, np.zeros((100, 2)), window=8)
    >>> float(prof.max())
    0.0
    """
    jerk_norm = np.linalg.norm(jerk(t, Y), axis=1)
    speed = speed_norm(t, Y) if scale == "relative" else None
    return _jerk_profile(t, Y, jerk_norm, speed, window=window, scale=scale, normalize=normalize,
                         grace=grace)


def _jerk_profile(t, Y, jerk_norm, speed, *, window: int, scale: str, normalize: str, grace: int):
    """:func:`jerk_profile` from the stream's jerk norm and :func:`speed_norm`, computed once.

    The segmenter computes both once per stream: the jerk norm also refines
    the changepoints and the speed also feeds the gate. ``speed`` may be None
    when ``scale="absolute"``.
    """
    j = np.asarray(jerk_norm, dtype=float)
    if scale == "relative":
        Yc = np.asarray(Y, dtype=float).reshape(len(j), -1)
        speed = np.asarray(speed, dtype=float)
        typical = np.percentile(speed, TYPICAL_PERCENTILE)
        dt = float(np.median(np.diff(np.asarray(t, dtype=float))))
        flat = HELD_TOLERANCE * (1.0 + float(np.abs(Yc).max())) / dt
        if typical <= flat:
            # mostly held, moving now and then: the moves set the scale
            typical = speed.max()
        if typical <= flat:
            j = np.zeros_like(j)
        else:
            j = j / (speed + TYPICAL_FRACTION * typical)
    elif scale != "absolute":
        raise ValueError(f"scale: expected 'relative' or 'absolute', got {scale!r}")
    m = windowed_mean(j, window)
    return j, normalize_profile(m, method=normalize, grace=grace)
