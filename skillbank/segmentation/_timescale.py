"""The motion's own time scale: how long the speed stays correlated with itself.

``window="auto"`` is set from it, so that the window (and with it the
minimum segment and the grace period) is a property of the movements, not of
the recording's length: an hour of the same motions gets the same window as
five minutes of them, costs the same per sample, and is cut as densely.
"""

from __future__ import annotations

import numpy as np

__all__ = ["speed_correlation_time", "motion_time_scale"]

#: The autocorrelation is summed over chunks of this many samples (each
#: transformed once at twice its length): memory stays bounded on a recording
#: of any length, and the time is linear in it (times log of the chunk).
CHUNK = 1 << 16


def _autocorrelation(x: np.ndarray, max_lag: int, chunk: int) -> np.ndarray:
    """Unnormalised autocorrelation of ``x`` at lags ``0 .. max_lag - 1``, summed chunk by chunk.

    Within one chunk the sum is exact (zero-padded to twice its length, so the
    transform is a linear, not circular, correlation); across chunks, the pairs
    that straddle a chunk's end are left out, a share of at most
    ``max_lag / chunk`` of the pairs at each lag.
    """
    n = x.shape[0]
    size = 1 << int(np.ceil(np.log2(2 * min(n, chunk))))
    out = np.zeros(max_lag)
    for start in range(0, n, chunk):
        part = x[start:start + chunk]
        f = np.fft.rfft(part, size)
        ac = np.fft.irfft(f.real**2 + f.imag**2, size)
        m = min(max_lag, part.shape[0])
        out[:m] += ac[:m]
    return out


def speed_correlation_time(speeds) -> float:
    """Lag, in samples, at which the speed first stops being correlated with itself.

    Each speed (one per stream, on one clock) has its mean removed and its
    autocorrelation normalised to 1 at lag 0; the streams' curves are
    averaged, and the time scale is the first lag where the average reaches
    zero. A movement from rest to rest of ``D`` samples has its speed
    correlated over about a third of ``D`` (a minimum-jerk movement repeated
    with rests: 0.3 to 0.45 of ``D``); white sensor noise only lowers the curve
    at the first lags, so it does not move the zero. The cost is linear in the
    samples: the sums run over chunks of :data:`CHUNK` samples, and over twice
    as long chunks only when the motion is slower than a chunk can show.

    Parameters
    ----------
    speeds : list of ndarray of shape (n_steps,)
        Speeds of the motion streams, on the demonstration's samples.

    Returns
    -------
    float
        The time scale in samples; ``n_steps`` when the speed never decorrelates
        (one movement, or none).

    Examples
    --------
    >>> t = np.arange(2000) / 100.0
    >>> v = np.sin(np.pi * t / 2.0) ** 2  # one bell every 2 s (200 samples): a quarter is 50
    >>> round(speed_correlation_time([v]))  # the sums end inside a bell
    49
    """
    speeds = [np.asarray(v, dtype=float) for v in speeds]
    n = speeds[0].shape[0]
    centred = [v - v.mean() for v in speeds]
    centred = [x for x in centred if np.any(x)]
    if not centred or n < 2:
        return float(n)
    chunk = CHUNK
    while True:
        max_lag = min(n, chunk // 2)
        curve = np.zeros(max_lag)
        for x in centred:
            ac = _autocorrelation(x, max_lag, chunk)
            curve += ac / ac[0]
        below = np.flatnonzero(curve <= 0.0)
        if below.size:
            k = int(below[0])
            # linear interpolation between the last positive lag and the first non-positive one
            before, after = curve[k - 1], curve[k]
            return float(k - 1 + before / (before - after)) if before != after else float(k)
        if max_lag >= n:
            return float(n)
        chunk *= 2


#: :func:`motion_time_scale` measures the correlation time over stretches of this many
#: whole-recording correlation times: long enough for each stretch to hold several movements,
#: short enough that a few slow ones do not set the scale of all the others.
STRETCH = 8


def motion_time_scale(speeds) -> float:
    """The motion's time scale, in samples: the median of its stretches' speed correlation times.

    :func:`speed_correlation_time` over the whole recording weighs each movement
    by its duration and its speed squared, so in an hour of quick movements a
    few slow, wide ones would set the scale. The recording is therefore cut
    into stretches of :data:`STRETCH` of its correlation times, and the median
    of theirs is the scale; a recording shorter than two stretches is one.
    The cost stays linear in the samples.

    Examples
    --------
    >>> t = np.arange(20000) / 100.0
    >>> v = np.sin(np.pi * t / 2.0) ** 2
    >>> round(motion_time_scale([v]))  # stretches of 392 samples, each ending inside a bell
    47
    """
    speeds = [np.asarray(v, dtype=float) for v in speeds]
    n = speeds[0].shape[0]
    whole = speed_correlation_time(speeds)
    stretch = int(np.ceil(STRETCH * whole))
    if n < 2 * stretch:
        return whole
    scales = [speed_correlation_time([v[i:i + stretch] for v in speeds])
              for i in range(0, n - stretch + 1, stretch)]
    return float(np.median(scales))
