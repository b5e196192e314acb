"""Per-stream jerk profile: third derivative, norm, sliding-window mean, normalisation."""

from __future__ import annotations

import warnings

import numpy as np
from scipy.signal import peak_prominences

from ..core._validation import check_array, check_positive, check_time
from ._roundoff import CLOCK_SPAN, roundoff_level

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

#: A stream's jerk is differentiated over single samples unless the values'
#: round-off could add more than this fraction of a typical event to the
#: profile (a fortieth of the default threshold, 0.4: it can neither make nor
#: hide an event), or could pick the peaks that set the robust scale. The seed
#: data stay below it: 0.02-0.08 % for the R demos (their round-off is the
#: floor, a 32-bit step of each range), 0.4 % for the three-button joints, two
#: of which are stored as float32.
ROUNDOFF_SHARE = 1e-2

#: Once the round-off matters, the stride grows until the round-off adds at
#: most this fraction, a tenth of ``ROUNDOFF_SHARE``: a copy of a motion just
#: over the share then ends with less round-off than any copy left as it is,
#: and a stride no wider than that needs (a wider one smooths the motion too).
ROUNDOFF_TARGET = 1e-3

#: Where the round-off would exceed its share, the jerk is differentiated over
#: a stride of samples instead of one, at most ``window // MAX_STEP_DIVISOR``:
#: a stride-h jerk spreads a kink over 3h samples either side, which stays
#: inside the refinement's reach (a quarter window) and far inside the window
#: that smears every event anyway.
MAX_STEP_DIVISOR = 16

#: The jerk at a sample draws on ``STENCIL_REACH * step + 1`` samples around it
#: (three nested central differences, 3 strides either side): the stride must
#: leave room for them, and the round-off of samples further apart is independent.
STENCIL_REACH = 6

#: Prominences of the highest maxima are computed this many at a time (twice
#: as many each further time), until ``ROBUST_PEAKS`` real ones are found: a
#: noisy profile has thousands of maxima.
PROMINENCE_BATCH = 64


def _three_point(f_lo, f_i, f_hi, h1, h2):
    """First derivative (second-order accurate) at the middle of three samples ``h1``, ``h2`` apart."""
    h1, h2 = h1[:, None], h2[:, None]
    return -h2 / (h1 * (h1 + h2)) * f_lo + (h2 - h1) / (h1 * h2) * f_i + h1 / (h2 * (h1 + h2)) * f_hi


def _strided_gradient(f: np.ndarray, t: np.ndarray, step: int) -> np.ndarray:
    """First derivative of ``f`` (n_steps, n_dims) from the samples ``step`` either side.

    Inside, the second-order formula for uneven spacing on samples ``i - step``,
    ``i``, ``i + step`` (fewer near the ends, where the stride shrinks to fit);
    at the two end samples a one-sided difference over ``step``.
    """
    n = f.shape[0]
    out = np.empty_like(f)
    if n > 2 * step:
        # the bulk, where the stride fits, from slices: no gathering of rows
        lo, mid, hi = slice(0, n - 2 * step), slice(step, n - step), slice(2 * step, n)
        out[mid] = _three_point(f[lo], f[mid], f[hi], t[mid] - t[lo], t[hi] - t[mid])
        edge = np.r_[1:step, n - step:n - 1]
    else:
        edge = np.arange(1, n - 1)
    lo, hi = np.maximum(edge - step, 0), np.minimum(edge + step, n - 1)
    out[edge] = _three_point(f[lo], f[edge], f[hi], t[edge] - t[lo], t[hi] - t[edge])
    end = min(step, n - 1)
    out[0] = (f[end] - f[0]) / (t[end] - t[0])
    out[-1] = (f[-1] - f[-1 - end]) / (t[-1] - t[-1 - end])
    return out


def jerk(t, Y, *, step: int = 1) -> np.ndarray:
    """Third time derivative of ``Y``, correct for uneven sampling.

    Each of the three derivatives uses second-order accurate differences on
    the actual sample times (central inside, one-sided at the ends).

    Parameters
    ----------
    t : array-like of shape (n_steps,)
    Y : array-like of shape (n_steps, n_dims)
    step : int, default=1
        Stride of the differences, in samples. A stride of ``h`` divides the
        round-off of the values (the noise of a file written with few digits)
        by ``h**3`` in the jerk, and smooths the jerk over ``3 * h`` samples
        either side; the segmenter chooses it (see :func:`jerk_profile`).

    Returns
    -------
    ndarray of shape (n_steps, n_dims)

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 1.0, 50)
    >>> np.allclose(jerk(t, t[:, None] ** 3)[3:-3], 6.0)  # one-sided ends are less exact
    True
    >>> np.allclose(jerk(t, t[:, None] ** 3, step=4)[12:-12], 6.0)
    True
    """
    t = check_time(t, min_samples=4)
    Y = check_array(Y, name="Y", ndim=(1, 2), as_2d=True, min_samples=4)
    if Y.shape[0] != t.shape[0]:
        raise ValueError(f"Y: expected {t.shape[0]} samples to match t, got {Y.shape[0]}")
    step = check_positive(step, name="step", integer=True)
    d = Y
    for _ in range(3):
        d = np.gradient(d, t, axis=0, edge_order=2) if step == 1 else _strided_gradient(d, t, step)
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


def _peak_heights(inner: np.ndarray, ripple: float, reach: int | None = None) -> np.ndarray:
    """Heights of the local maxima of ``inner``, the highest first; with ``ripple``, only real ones.

    Round-off ripple on a flat-topped event makes several local maxima of
    almost the same height; counted apart, they fill the robust scale's five
    places with one event. A maximum whose prominence (its rise above the
    higher of the two valleys that part it from higher ground) is above 0 but
    at most ``ripple`` cannot be told from the data's round-off and is left
    out. A prominence of exactly 0 is a plateau that the window mean's own
    arithmetic broke into level pieces, not the data's round-off: it counts
    as it always has. Only the ``ROBUST_PEAKS`` highest maxima that count are
    looked for, highest first, and each one's valleys only within ``reach``
    samples (a window: a windowed mean falls from an event within about a
    window), so that a noisy profile's thousands of maxima cost little.
    """
    # a plateau counts once, at its last sample
    is_peak = np.r_[False, (inner[1:-1] >= inner[:-2]) & (inner[1:-1] > inner[2:]), False]
    at = np.flatnonzero(is_peak)
    at = at[np.argsort(-inner[at], kind="stable")]
    if ripple <= 0.0 or at.size == 0:
        return inner[at]
    # a maximum rises no more than ``ripple`` only if a neighbour is within ``ripple`` of it
    # (the valley on that side is no higher than the neighbour): only those need a prominence
    low = inner[at] - ripple
    close = np.flatnonzero((inner[at - 1] >= low) | (inner[at + 1] >= low))
    keep = np.ones(at.size, dtype=bool)
    start, size = 0, PROMINENCE_BATCH
    wlen = None if reach is None else 2 * reach + 1
    with warnings.catch_warnings():
        # a level piece of a plateau has prominence 0, which scipy warns of (as a
        # RuntimeWarning): here that is an answer, not a fault
        warnings.simplefilter("ignore", RuntimeWarning)
        # the highest maxima that count are settled once enough of them precede the next to check
        while start < close.size and np.count_nonzero(keep[:close[start]]) < ROBUST_PEAKS:
            batch = close[start:start + size]
            prominence = peak_prominences(inner, at[batch], wlen=wlen)[0]
            keep[batch] = (prominence > ripple) | (prominence == 0.0)
            # where most maxima are ripple, look at twice as many next time
            start, size = start + size, 2 * size
    return inner[at[keep]]


def _profile_scale(m: np.ndarray, *, method: str, grace: int, ripple: float = 0.0,
                   reach: int | None = None) -> float:
    """The divisor of :func:`normalize_profile`; ``ripple`` and ``reach`` as in :func:`_peak_heights`."""
    if method == "max":
        return float(m.max())
    if method != "robust":
        raise ValueError(f"normalize: expected 'robust' or 'max', got {method!r}")
    inner = m[grace : m.shape[0] - grace] if m.shape[0] > 2 * grace + 1 else m
    heights = np.sort(_peak_heights(inner, ripple, reach))[::-1][:ROBUST_PEAKS]
    heights = heights[heights >= RIPPLE_RATIO * heights[0]] if heights.size else heights
    scale = float(np.median(heights)) if heights.size else 0.0
    if scale <= FLAT_SCALE:
        # no interior peak (a monotone profile): fall back to the maximum
        scale = float(m.max())
    return scale


def normalize_profile(m, *, method: str = "robust", grace: int = 0, ripple: float = 0.0) -> np.ndarray:
    """Scale a non-negative profile so that typical jerk events reach about 1.

    ``"max"`` divides by the maximum (the paper's choice): one spike anywhere
    then shrinks every other event. ``"robust"`` divides by the median of the
    ``ROBUST_PEAKS`` (5) highest peaks of the interior (``grace`` samples
    excluded at each end, where start-up transients and differentiation edge
    effects live), so that a single spike rises above 1 instead of hiding the
    other changepoints. A peak that rises above its valleys by more than 0
    but at most ``ripple`` (the profile's round-off) does not count: it may
    be round-off on the flat top of another.

    Examples
    --------
    >>> normalize_profile(np.array([0.0, 1.0, 2.0]), method="max").tolist()
    [0.0, 0.5, 1.0]
    >>> m = np.array([0.0, 5.0, 4.998, 4.999, 0.0, 2.0, 0.0, 1.0, 0.0])  # the 5 has a round-off twin
    >>> [round(float(normalize_profile(m, ripple=r).max()), 3) for r in (0.0, 0.01)]  # scale 3.5, then 2
    [1.429, 2.5]
    """
    m = np.asarray(m, dtype=float)
    scale = _profile_scale(m, method=method, grace=grace, ripple=ripple)
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

    The jerk is differentiated over single samples, unless the values'
    round-off could then add more than ``ROUNDOFF_SHARE`` (1 %) of a typical
    event to the profile, or pick which peaks set its robust scale: the third
    derivative divides the round-off of each value by the cube of the sample
    period, so that at 10^6 samples of 1 ms a file written with 12 significant
    digits carries tens of times more round-off than motion in its jerk. The
    jerk is then differentiated over the smallest stride of samples (at most a
    sixteenth of the window) that brings the round-off under
    ``ROUNDOFF_TARGET`` (0.1 %), and peaks no higher than its ripple are left
    out of the robust scale. The round-off is the half step of the grid the
    values and the time stamps lie on (a time stamp off by ``e`` acts as a
    value off by ``speed * e``), or less where the values' third differences
    show less (exact values on a coarse grid, such as a gripper at 0 or 1),
    but never less than half a 32-bit step of the stream's (or the clock's)
    range: digits finer than that are arithmetic, not measurement, so that a
    full-precision original and its copy written with 12 significant digits
    are differentiated over the same stride and cut at the same places. Data
    sampled coarsely enough for the jerk (all the seed data) are left exactly
    as they were; a slow motion sampled at 1 kHz is not.

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
        Peaks parted only by round-off ripple count once.
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
    _, j, profile, _ = _stream_jerk(t, Y, None, window=window, scale=scale, normalize=normalize,
                                    grace=grace)
    return j, profile


def _relative_divisor(t: np.ndarray, Y: np.ndarray, speed: np.ndarray):
    """``speed + TYPICAL_FRACTION * typical`` for the relative scale; None for a held stream."""
    typical = np.percentile(speed, TYPICAL_PERCENTILE)
    dt = float(np.median(np.diff(t)))
    flat = HELD_TOLERANCE * (1.0 + float(np.abs(Y).max())) / dt
    if typical <= flat:
        # mostly held, moving now and then: the moves set the scale
        typical = speed.max()
    if typical <= flat:
        return None
    return speed + TYPICAL_FRACTION * typical


def _jerk_floor(t: np.ndarray, speed: np.ndarray, level_y: float, level_t: float, step: int) -> np.ndarray:
    """Bound on the round-off in the jerk norm at stride ``step``, per sample.

    A value off by ``e`` moves a central difference over ``step`` samples
    either side by at most ``e / (step * dt)``, and three nested ones by
    ``e / (step * dt) ** 3``; a time stamp off by ``e_t`` acts as a value off
    by ``speed * e_t``. ``level_y`` is the norm of the per-dimension levels.
    """
    n = t.shape[0]
    i = np.arange(n)
    lo, hi = np.maximum(i - step, 0), np.minimum(i + step, n - 1)
    span = step * (t[hi] - t[lo]) / (hi - lo)
    # one division at a time: span**3 itself would underflow on a clock of ~1e-110 s
    return (level_y + speed * level_t) / span / span / span


def _stream_jerk(t, Y, speed, *, window: int, scale: str, normalize: str, grace: int):
    """The jerk norm, :func:`jerk_profile`'s two arrays, and the stride the jerk was taken over.

    ``speed`` is the stream's :func:`speed_norm` (computed here when None):
    the segmenter computes it once, for the relative scale, the round-off of
    the time stamps and the gate. The absolute jerk norm also refines the
    changepoints.

    Returns
    -------
    jerk_norm, raw, profile : ndarray of shape (n_steps,)
    step : int
    """
    jerk_norm = np.linalg.norm(jerk(t, Y), axis=1)
    t = np.asarray(t, dtype=float)
    Y = np.asarray(Y, dtype=float).reshape(t.shape[0], -1)
    if scale not in ("relative", "absolute"):
        raise ValueError(f"scale: expected 'relative' or 'absolute', got {scale!r}")
    if normalize not in ("robust", "max"):
        raise ValueError(f"normalize: expected 'robust' or 'max', got {normalize!r}")
    speed = speed_norm(t, Y) if speed is None else np.asarray(speed, dtype=float)
    divisor = _relative_divisor(t, Y, speed) if scale == "relative" else None

    def scaled(x):
        if scale == "absolute":
            return x
        return np.zeros_like(x) if divisor is None else x / divisor

    n = t.shape[0]
    inner = slice(grace, n - grace) if n > 2 * grace + 1 else slice(None)

    def noise_of(levels, step: int) -> float:
        """Bound on the round-off in the windowed profile (before normalisation)."""
        floor = scaled(_jerk_floor(t, speed, float(np.linalg.norm(levels[0])), float(levels[1]), step))
        return float(windowed_mean(floor, window)[inner].max())

    def ripple_of(noise: float, step: int) -> float:
        # the window averages the round-off of (6 step + 1)-sample stencils: what is left
        # ripples by about this much, and a peak that rises no more is not told from it
        return 2.0 * noise * np.sqrt((STENCIL_REACH * step + 1) / window)

    def share_of(noise: float, divide: float) -> float:
        return noise / divide if np.isfinite(divide) and divide > FLAT_SCALE else 0.0

    def matters(levels) -> bool:
        """Whether round-off could move the profile by ``ROUNDOFF_SHARE``, or pick the peaks that scale it."""
        noise = noise_of(levels, 1)
        if share_of(noise, divide) > ROUNDOFF_SHARE:
            return True
        return noise > 0.0 and _profile_scale(m, method=normalize, grace=grace, ripple=ripple_of(noise, 1),
                                              reach=window) != divide

    step = 1
    j = scaled(jerk_norm)
    m = windowed_mean(j, window)
    divide = _profile_scale(m, method=normalize, grace=grace)
    levels = (roundoff_level(Y), roundoff_level(t, span=CLOCK_SPAN)[0])
    if matters(levels):
        # the grid's half step bounds the round-off; exact values on a coarse grid have none
        # (above the floor: a full-precision stream's levels are the floor either way)
        grid, levels = levels, (roundoff_level(Y, empirical=True),
                                roundoff_level(t, empirical=True, span=CLOCK_SPAN)[0])
        # levels the data left as they were still matter, as just found: no second profile scale
        unchanged = np.array_equal(grid[0], levels[0]) and grid[1] == levels[1]
        if unchanged or matters(levels):
            cap = max(1, min(window // MAX_STEP_DIVISOR, (n - 1) // STENCIL_REACH))
            while True:
                noise = noise_of(levels, step)
                share = share_of(noise, divide)
                if share <= ROUNDOFF_TARGET or step >= cap:
                    break
                # the round-off falls as the cube of the stride; the scale settles as the noise goes
                step = min(cap, max(step + 1, int(np.ceil(step * (share / ROUNDOFF_TARGET) ** (1.0 / 3.0)))))
                jerk_norm = np.linalg.norm(jerk(t, Y, step=step), axis=1)
                j = scaled(jerk_norm)
                m = windowed_mean(j, window)
                divide = _profile_scale(m, method=normalize, grace=grace)
            # leave out of the scale the peaks that the round-off still left could have made
            # (only now: on a profile swamped by round-off, nearly every maximum is one)
            divide = _profile_scale(m, method=normalize, grace=grace, ripple=ripple_of(noise, step),
                                    reach=window)
    if not np.isfinite(divide) or divide <= FLAT_SCALE:
        return jerk_norm, j, np.zeros_like(m), step
    # no clipping: a flattened top would move the half-height onset of an event
    return jerk_norm, j, m / divide, step
