"""Changepoints of one stream from its normalised jerk profile."""

from __future__ import annotations

import bisect

import numpy as np
from scipy.signal import find_peaks, peak_widths

__all__ = ["detect_changepoints", "suppress_close", "refine_to_jerk_centre"]

#: A changepoint is where its event's profile rises through this fraction of
#: the event's prominence: the half-height crossing marks where the transition
#: begins, and unlike the foot of the rise it does not wander with small noise.
ONSET_HEIGHT = 0.5


def suppress_close(positions, scores, *, min_size: int, n_steps: int) -> np.ndarray:
    """Keep the strongest positions that leave segments of at least ``min_size``.

    Positions closer than ``min_size`` to either end are dropped; among
    positions closer than ``min_size`` to each other the higher score wins.
    The loop runs over candidate events, never over samples, and checks each
    against its two nearest kept neighbours only (a sorted list, bisected), so
    an hour's thousands of events cost ``O(k log k)``, not ``O(k^2)``.

    Examples
    --------
    >>> suppress_close([10, 15, 40], [1.0, 2.0, 0.5], min_size=10, n_steps=60).tolist()
    [15, 40]
    """
    positions = np.asarray(positions, dtype=int)
    scores = np.asarray(scores, dtype=float)
    inside = (positions >= min_size) & (positions <= n_steps - min_size)
    positions, scores = positions[inside], scores[inside]
    kept: list[int] = []  # sorted
    for k in np.argsort(-scores, kind="stable"):
        p = int(positions[k])
        i = bisect.bisect_left(kept, p)
        # the kept positions are at least min_size apart, so only the neighbours either side can be close
        if (i < len(kept) and kept[i] - p < min_size) or (i > 0 and p - kept[i - 1] < min_size):
            continue
        kept.insert(i, p)
    return np.array(kept, dtype=int)


def refine_to_jerk_centre(changepoints, jerk_norm, *, half_width: int, n_iter: int = 2) -> np.ndarray:
    """Move each changepoint to the centre of mass of the jerk around it.

    The windowed profile places an event only to within a sample or two (its
    half-height crossing depends on the window and on the speeds either
    side); the raw jerk of a kink is symmetric about the kink, so its centre
    of mass recovers the kink exactly on noiseless data. Cumulative sums make
    this O(n + k).

    Examples
    --------
    >>> j = np.zeros(50); j[[19, 21]] = 1.0
    >>> refine_to_jerk_centre([18], j, half_width=4).tolist()
    [20]
    """
    cps = np.asarray(changepoints, dtype=int)
    if cps.size == 0 or half_width < 1:
        return cps
    w = np.asarray(jerk_norm, dtype=float)
    n = w.shape[0]
    idx = np.arange(n, dtype=float)
    s0 = np.concatenate(([0.0], np.cumsum(w)))
    s1 = np.concatenate(([0.0], np.cumsum(idx * w)))
    out = cps.astype(float)
    for _ in range(n_iter):
        c = np.round(out).astype(int)
        lo = np.clip(c - half_width, 0, n)
        hi = np.clip(c + half_width + 1, 0, n)
        mass = s0[hi] - s0[lo]
        ok = mass > 0
        out = np.where(ok, (s1[hi] - s1[lo]) / np.where(ok, mass, 1.0), out)
    return np.clip(np.round(out).astype(int), 0, n - 1)


def detect_changepoints(profile, *, threshold: float, min_size: int, grace: int, window: int = 1):
    """Changepoints of a normalised jerk profile.

    A jerk *event* is a peak of the profile whose prominence (its height above
    the surrounding valleys) reaches ``threshold``. Its changepoint is the
    event's onset: the sample where the profile rises through half of the
    prominence, i.e. where the transition between two primitives begins.
    Events inside the first or last ``grace`` samples are start-up and
    differentiation edge effects and are ignored; events that would leave a
    segment shorter than ``min_size`` lose to stronger neighbours.

    Parameters
    ----------
    profile : ndarray of shape (n_steps,)
        Normalised windowed jerk, in [0, 1].
    threshold : float
        Minimum prominence of an event.
    min_size : int
        Minimum segment length in samples.
    grace : int
        Samples ignored at each end.

    Returns
    -------
    changepoints : ndarray of int
        Sorted sample indices.
    strength : ndarray of float
        The prominence of each changepoint's event.

    Examples
    --------
    >>> p = np.zeros(200); p[90:100] = np.linspace(0.1, 1.0, 10); p[100:110] = 1.0
    >>> detect_changepoints(p, threshold=0.5, min_size=20, grace=5)[0].tolist()  # rises through 0.5
    [94]
    """
    profile = np.asarray(profile, dtype=float)
    n = profile.shape[0]
    # pad with zeros so an event running into an end still has a valley there
    padded = np.concatenate(([0.0], profile, [0.0]))
    # Computing prominences is what costs: each scans outward to a higher
    # sample. On a non-negative profile padded with zeros a peak's prominence
    # never exceeds its height, so the height test is exact; and the windowed
    # mean cannot hold two separate events within one window, so ripples closer
    # than a window to a higher peak are dropped before prominences are computed.
    peaks, props = find_peaks(padded, height=threshold, distance=max(1, int(window)), prominence=threshold)
    if peaks.size == 0:
        return np.array([], dtype=int), np.array([], dtype=float)
    prom = props["prominences"]
    left = peak_widths(
        padded, peaks, rel_height=ONSET_HEIGHT,
        prominence_data=(prom, props["left_bases"], props["right_bases"]),
    )[2]
    peaks = peaks - 1
    # the window spreads an event over ``window`` samples before its centre,
    # so the half-height crossing sits half a window early
    onset = np.round(left - 1.0 + (window - 1) / 2.0).astype(int)
    inner = (peaks >= grace) & (peaks < n - grace) & (onset >= grace)
    onset, prom = onset[inner], prom[inner]
    kept = suppress_close(onset, prom, min_size=min_size, n_steps=n)
    strength = np.array([prom[onset == k].max() for k in kept], dtype=float)
    return kept, strength
