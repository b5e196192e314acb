"""Per-sample pure-Python-loop baseline of probabilistic multimodal segmentation.

This is the *same method* as :func:`skillbank.segmentation.segment` (deterministic
mode), written the straightforward way the method's authors wrote it: every
derivative, norm, window mean, Gaussian and product is an explicit loop over
samples, and the sliding-window mean sums the whole window at every sample
(O(n * window)). It exists for two reasons only:

* as the reference the benchmark compares the vectorised implementation with;
* as an independent check of that implementation (``tests/segmentation/test_loop_baseline.py``).

Four pieces are shared with skillbank: ``numpy.percentile`` (for the
typical speed), :func:`skillbank.segmentation.detect_changepoints`
(the find_peaks / peak_widths changepoint rule, which runs on the profile and
is not the hot path), :func:`skillbank.segmentation.gate_changepoints`
(the stop-or-turn gate, which loops over changepoints, not samples) and
``skillbank.segmentation._roundoff.roundoff_level`` (the values' round-off,
read off a sample of them and a median of their third differences).
Only ``mode="deterministic"`` is implemented.
"""

from __future__ import annotations

import inspect
import math

import numpy as np

from skillbank.segmentation import detect_changepoints, gate_changepoints
from skillbank.segmentation._roundoff import roundoff_level
from skillbank.segmentation._segmenter import to_samples

__all__ = ["loop_segment", "loop_gradient", "loop_strided_gradient", "loop_jerk_profile", "loop_stream_jerk",
           "LoopResult"]

# same values as skillbank.segmentation._profile.FLAT_SCALE, TYPICAL_FRACTION, ROUNDOFF_SHARE
# and ROUNDOFF_TARGET
_FLAT = 1e-12
_TYPICAL_FRACTION = 0.05  # relative scale: speed + 0.05 * (95th percentile of speed)
_ROUNDOFF_SHARE = 1e-2  # round-off allowed in the profile before the jerk is taken over a stride
_ROUNDOFF_TARGET = 1e-3  # ... and what the stride brings it down to


class LoopResult:
    """What :func:`loop_segment` found.

    Attributes
    ----------
    keypoints : list of int
    changepoints : dict of str to list of int
    profiles : dict of str to ndarray
        Normalised windowed jerk profile of each stream (typical events near 1).
    raw : dict of str to ndarray
        Jerk norm (relative or absolute) per sample, before the window.
    support : ndarray
        Number of agreeing streams per sample (log of the product, rescaled).
    params : dict of str to dict
        Resolved per-stream settings (window, min_size, grace, ...).
    steps : dict of str to int
        Stride, in samples, each stream's jerk was differentiated over.
    """

    def __init__(self, keypoints, changepoints, profiles, raw, support, params, steps):
        self.keypoints = keypoints
        self.changepoints = changepoints
        self.profiles = profiles
        self.raw = raw
        self.support = support
        self.params = params
        self.steps = steps


# --------------------------------------------------------------------------- derivatives


def loop_gradient(t: list, f: list, edge_order: int = 2) -> list:
    """First derivative of the samples ``f`` at times ``t``, one sample at a time.

    Same formulas as ``np.gradient(f, t, edge_order=edge_order)``: second-order
    central differences on the actual (uneven) spacing inside, one-sided
    differences at both ends (second order by default, first order with
    ``edge_order=1``). Like numpy, perfectly uniform spacing uses the simpler
    uniform formulas.
    """
    n = len(f)
    h = [t[i + 1] - t[i] for i in range(n - 1)]
    uniform = all(hi == h[0] for hi in h)
    out = [0.0] * n

    if uniform:
        dx = h[0]
        for i in range(1, n - 1):
            out[i] = (f[i + 1] - f[i - 1]) / (2.0 * dx)
        if edge_order == 1:
            out[0] = (f[1] - f[0]) / dx
            out[n - 1] = (f[n - 1] - f[n - 2]) / dx
            return out
        out[0] = (-1.5 / dx) * f[0] + (2.0 / dx) * f[1] + (-0.5 / dx) * f[2]
        out[n - 1] = (0.5 / dx) * f[n - 3] + (-2.0 / dx) * f[n - 2] + (1.5 / dx) * f[n - 1]
        return out

    for i in range(1, n - 1):
        dx1 = h[i - 1]
        dx2 = h[i]
        a = -dx2 / (dx1 * (dx1 + dx2))
        b = (dx2 - dx1) / (dx1 * dx2)
        c = dx1 / (dx2 * (dx1 + dx2))
        out[i] = a * f[i - 1] + b * f[i] + c * f[i + 1]

    if edge_order == 1:
        out[0] = (f[1] - f[0]) / h[0]
        out[n - 1] = (f[n - 1] - f[n - 2]) / h[n - 2]
        return out

    dx1, dx2 = h[0], h[1]
    a = -(2.0 * dx1 + dx2) / (dx1 * (dx1 + dx2))
    b = (dx1 + dx2) / (dx1 * dx2)
    c = -dx1 / (dx2 * (dx1 + dx2))
    out[0] = a * f[0] + b * f[1] + c * f[2]

    dx1, dx2 = h[n - 3], h[n - 2]
    a = dx2 / (dx1 * (dx1 + dx2))
    b = -(dx2 + dx1) / (dx1 * dx2)
    c = (2.0 * dx2 + dx1) / (dx2 * (dx1 + dx2))
    out[n - 1] = a * f[n - 3] + b * f[n - 2] + c * f[n - 1]
    return out


# --------------------------------------------------------------------------- profile


def loop_strided_gradient(t: list, f: list, step: int) -> list:
    """First derivative from the samples ``step`` either side, one sample at a time.

    Inside, the uneven-spacing formula on samples ``i - step``, ``i``, ``i + step``
    (the stride shrinks to fit near the ends); at the two end samples a
    one-sided difference over ``step`` samples.
    """
    n = len(f)
    out = [0.0] * n
    for i in range(1, n - 1):
        lo, hi = max(i - step, 0), min(i + step, n - 1)
        dx1, dx2 = t[i] - t[lo], t[hi] - t[i]
        a = -dx2 / (dx1 * (dx1 + dx2))
        b = (dx2 - dx1) / (dx1 * dx2)
        c = dx1 / (dx2 * (dx1 + dx2))
        out[i] = a * f[lo] + b * f[i] + c * f[hi]
    end = min(step, n - 1)
    out[0] = (f[end] - f[0]) / (t[end] - t[0])
    out[n - 1] = (f[n - 1] - f[n - 1 - end]) / (t[n - 1] - t[n - 1 - end])
    return out


def _window_mean(values: list, window: int) -> list:
    """Centred sliding-window mean, summing the whole window at every sample; shrinks at the ends."""
    n = len(values)
    mean = [0.0] * n
    half = window // 2
    for i in range(n):
        lo = max(0, i - half)
        hi = min(n, i - half + window)
        total = 0.0
        for k in range(lo, hi):
            total += values[k]
        mean[i] = total / (hi - lo)
    return mean


def _prominence(values: list, i: int, reach: int) -> float:
    """Height of ``values[i]`` above the higher of its two bases: the lowest point before
    higher ground, looked for at most ``reach`` samples away."""
    bases = []
    for direction in (-1, 1):
        k, low = i, values[i]
        while (0 <= k + direction < len(values) and abs(k + direction - i) <= reach
               and values[k + direction] <= values[i]):
            k += direction
            low = min(low, values[k])
        bases.append(low)
    return values[i] - max(bases)


def _scale_value(mean: list, normalize: str, grace: int, ripple: float = 0.0, reach: int = 0) -> float:
    """Divisor of the profile: the maximum, or the median of the five highest interior
    local maxima, leaving out those that rise above their bases (within ``reach``
    samples) by more than 0 but no more than ``ripple``."""
    n = len(mean)
    if normalize == "max":
        return max(mean)
    if normalize != "robust":
        raise ValueError(f"normalize: expected 'robust' or 'max', got {normalize!r}")
    inner = mean[grace : n - grace] if n > 2 * grace + 1 else mean
    peaks = []
    for i in range(1, len(inner) - 1):
        if inner[i] >= inner[i - 1] and inner[i] > inner[i + 1]:
            peaks.append(i)
    peaks.sort(key=lambda i: -inner[i])  # stable: equal heights keep their order
    top = []
    for i in peaks:
        if len(top) == 5:
            break
        # a level piece of a plateau (prominence 0) counts; a rise of no more than ripple does not
        if ripple <= 0.0 or not 0.0 < _prominence(inner, i, reach) <= ripple:
            top.append(inner[i])
    if top:
        top = [h for h in top if h >= 1e-6 * top[0]]  # round-off ripples on a noiseless line
    if not top:
        scale_value = 0.0
    elif len(top) % 2 == 1:
        scale_value = top[len(top) // 2]
    else:
        scale_value = (top[len(top) // 2 - 1] + top[len(top) // 2]) / 2.0
    if scale_value <= _FLAT:
        scale_value = max(mean)
    return scale_value


def loop_stream_jerk(t, Y, *, window: int, scale: str = "relative", normalize: str = "robust",
                     grace: int = 0):
    """Jerk norm, raw (scaled) jerk, normalised windowed profile and stride of one stream, with loops.

    Same rule as skillbank: the jerk is taken over single samples unless the
    values' round-off (``skillbank.segmentation._roundoff``, shared) could add
    more than 1 % of a typical event to the profile, or pick which peaks set
    its scale; then over the smallest stride that brings it under 0.1 % (at
    most window // 16 samples), and the peaks the remaining round-off could
    have made are left out of the scale.

    Returns ``(jerk_norm, raw, profile, step)``, the arrays as numpy arrays of shape (n_steps,).
    """
    t = [float(v) for v in np.asarray(t, dtype=float)]
    Y = np.asarray(Y, dtype=float)
    if Y.ndim == 1:
        Y = Y[:, None]
    n, dims = Y.shape
    if scale not in ("relative", "absolute"):
        raise ValueError(f"scale: expected 'relative' or 'absolute', got {scale!r}")
    if normalize not in ("robust", "max"):
        raise ValueError(f"normalize: expected 'robust' or 'max', got {normalize!r}")

    # skillbank takes the speed from np.gradient's default edge_order=1, which
    # differs from the jerk's first derivative at the two end samples only
    velocity = [loop_gradient(t, [float(v) for v in Y[:, d]], edge_order=1) for d in range(dims)]
    speed = [0.0] * n
    for i in range(n):
        total = 0.0
        for d in range(dims):
            total += velocity[d][i] * velocity[d][i]
        speed[i] = math.sqrt(total)

    # relative scale: divide by the local speed plus 5 % of the typical speed
    divisor = None
    if scale == "relative":
        typical = float(np.percentile(speed, 95.0))
        # round-off level of the signal: a held signal is not motion
        steps = sorted(t[i + 1] - t[i] for i in range(n - 1))
        dt = steps[(n - 1) // 2] if (n - 1) % 2 else 0.5 * (steps[(n - 1) // 2 - 1] + steps[(n - 1) // 2])
        peak = max(abs(v) for row in Y for v in row)
        flat = 1e-9 * (1.0 + peak) / dt
        if typical <= flat:
            typical = max(speed)
        divisor = None if typical <= flat else [speed[i] + _TYPICAL_FRACTION * typical for i in range(n)]

    def scaled(values):
        if scale == "absolute":
            return list(values)
        if divisor is None:
            return [0.0] * n
        return [values[i] / divisor[i] for i in range(n)]

    lo_i, hi_i = (grace, n - grace) if n > 2 * grace + 1 else (0, n)

    def noise_of(levels, step):
        level_y = math.sqrt(sum(float(v) * float(v) for v in levels[0]))
        floor = [0.0] * n
        for i in range(n):
            lo, hi = max(i - step, 0), min(i + step, n - 1)
            span = step * (t[hi] - t[lo]) / (hi - lo)
            floor[i] = (level_y + speed[i] * float(levels[1])) / span / span / span
        return max(_window_mean(scaled(floor), window)[lo_i:hi_i])

    def ripple_of(noise, step):
        return 2.0 * noise * math.sqrt((6 * step + 1) / window)

    def share_of(noise, value):
        return noise / value if math.isfinite(value) and value > _FLAT else 0.0

    def matters(levels):
        # round-off could move the profile by 1 % of the scale, or pick the peaks that set it
        noise = noise_of(levels, 1)
        if share_of(noise, scale_value) > _ROUNDOFF_SHARE:
            return True
        if noise <= 0.0:
            return False
        return _scale_value(mean, normalize, grace, ripple_of(noise, 1), window) != scale_value

    step = 1
    jerk_norm = loop_jerk_norm(t, Y)
    raw = scaled(jerk_norm)
    mean = _window_mean(raw, window)
    scale_value = _scale_value(mean, normalize, grace)
    levels = (roundoff_level(Y), roundoff_level(np.array(t))[0])
    if matters(levels):
        levels = (roundoff_level(Y, empirical=True), roundoff_level(np.array(t), empirical=True)[0])
        if matters(levels):
            cap = max(1, min(window // 16, (n - 1) // 6))
            while True:
                noise = noise_of(levels, step)
                share = share_of(noise, scale_value)
                if share <= _ROUNDOFF_TARGET or step >= cap:
                    break
                step = min(cap, max(step + 1, math.ceil(step * (share / _ROUNDOFF_TARGET) ** (1.0 / 3.0))))
                jerk_norm = loop_jerk_norm(t, Y, step=step)
                raw = scaled(jerk_norm)
                mean = _window_mean(raw, window)
                scale_value = _scale_value(mean, normalize, grace)
            # then leave out the peaks the remaining round-off could have made
            scale_value = _scale_value(mean, normalize, grace, ripple_of(noise, step), window)

    # no clipping
    profile = [0.0] * n
    if math.isfinite(scale_value) and scale_value > _FLAT:
        for i in range(n):
            profile[i] = mean[i] / scale_value
    return np.array(jerk_norm), np.array(raw), np.array(profile), step


def loop_jerk_profile(t, Y, *, window: int, scale: str = "relative", normalize: str = "robust",
                      grace: int = 0):
    """Raw jerk norm and normalised windowed profile of one stream, with loops.

    Returns ``(raw, profile)`` as numpy arrays of shape (n_steps,).
    """
    _, raw, profile, _ = loop_stream_jerk(t, Y, window=window, scale=scale, normalize=normalize, grace=grace)
    return raw, profile


# --------------------------------------------------------------------------- keypoints


def loop_jerk_norm(t, Y, step: int = 1) -> list:
    """Absolute jerk norm per sample, with loops; differences over ``step`` samples."""
    t = [float(v) for v in np.asarray(t, dtype=float)]
    Y = np.asarray(Y, dtype=float)
    if Y.ndim == 1:
        Y = Y[:, None]
    n, dims = Y.shape
    jerk = []
    for d in range(dims):
        column = [float(v) for v in Y[:, d]]
        for _ in range(3):
            column = loop_gradient(t, column) if step == 1 else loop_strided_gradient(t, column, step)
        jerk.append(column)
    out = [0.0] * n
    for i in range(n):
        out[i] = math.sqrt(sum(jerk[d][i] * jerk[d][i] for d in range(dims)))
    return out


def loop_refine(changepoints, jerk_norm: list, *, half_width: int, n_iter: int = 2) -> list:
    """Centre of mass of the jerk within ``half_width`` of each changepoint, twice."""
    n = len(jerk_norm)
    out = []
    for c in changepoints:
        pos = float(c)
        for _ in range(n_iter):
            centre = int(np.round(pos))
            mass = moment = 0.0
            for i in range(max(0, centre - half_width), min(n, centre + half_width + 1)):
                mass += jerk_norm[i]
                moment += i * jerk_norm[i]
            if mass > 0:
                pos = moment / mass
        out.append(min(max(int(np.round(pos)), 0), n - 1))
    return out


def _gaussian_curve(changepoints, n: int, sigma: float, floor: float) -> list:
    """Floor plus, at each sample, the highest unit Gaussian of any changepoint."""
    curve = [floor] * n
    if len(changepoints) == 0:
        return curve
    for i in range(n):
        best = 0.0
        for c in changepoints:
            z = (i - c) / sigma
            best = max(best, math.exp(-0.5 * z * z))
        curve[i] = floor + best
    return curve


def _suppress_close(positions, scores, *, min_size: int, n: int) -> list:
    """Strongest positions first; drop those too close to an end or to a kept one."""
    candidates = [(p, s) for p, s in zip(positions, scores, strict=False) if min_size <= p <= n - min_size]
    order = sorted(range(len(candidates)), key=lambda k: -candidates[k][1])  # stable
    kept = []
    for k in order:
        p = candidates[k][0]
        if all(abs(p - q) >= min_size for q in kept):
            kept.append(p)
    return sorted(kept)


def _local_maxima(values: list, min_height: float):
    """Local maxima (flat tops at their middle sample) at least ``min_height`` high.

    The ends count as maxima when they are higher than their one neighbour,
    as if the signal were padded with -inf.
    """
    n = len(values)
    peaks, heights = [], []
    i = 0
    while i < n:
        left = values[i - 1] if i > 0 else -math.inf
        if values[i] > left:
            j = i  # walk to the end of a flat top
            while j + 1 < n and values[j + 1] == values[i]:
                j += 1
            right = values[j + 1] if j + 1 < n else -math.inf
            if values[i] > right:
                mid = (i + j) // 2
                if values[mid] >= min_height:
                    peaks.append(mid)
                    heights.append(values[mid])
            i = j + 1
        else:
            i += 1
    return peaks, heights


# --------------------------------------------------------------------------- driver


def _window_argument(window: int) -> dict:
    """Pass ``window`` to detect_changepoints when its signature takes it (newer skillbank)."""
    if "window" in inspect.signature(detect_changepoints).parameters:
        return {"window": window}
    return {}


def _settings(n: int, t: np.ndarray, window, min_size, threshold, grace, scale, normalize,
              stop_ratio=0.5, min_turn=45.0) -> dict:
    """Same 'auto' rules as MultimodalSegmenter.

    window: 4 % of n (at least 8); min_size: 2 x window; grace: window.
    """
    window = max(8, int(round(0.04 * n))) if window == "auto" else to_samples(window, t, name="window")
    min_size = 2 * window if min_size == "auto" else to_samples(min_size, t, name="min_size")
    grace = window if grace == "auto" else (0 if grace == 0 else to_samples(grace, t, name="grace"))
    return {"window": window, "min_size": min_size, "threshold": float(threshold), "grace": grace,
            "scale": scale, "normalize": normalize, "stop_ratio": stop_ratio, "min_turn": min_turn}


def loop_segment(demo, streams=None, *, window="auto", min_size="auto", threshold=0.4, grace="auto",
                 scale="relative", normalize="robust", stop_ratio=0.5, min_turn=45.0, floor=0.05,
                 min_support=None) -> LoopResult:
    """Segment ``demo`` with the loop baseline; parameters as :func:`skillbank.segmentation.segment`.

    Returns
    -------
    LoopResult
    """
    names = demo.stream_names if streams is None else ([streams] if isinstance(streams, str)
                                                       else list(streams))
    t = np.asarray(demo.t, dtype=float)
    n = demo.n_steps

    profiles, raws, changepoints, curves, params, steps = {}, {}, {}, {}, {}, {}
    for name in names:
        p = _settings(n, t, window, min_size, threshold, grace, scale, normalize, stop_ratio, min_turn)
        jerk_norm, raw, profile, steps[name] = loop_stream_jerk(
            t, demo[name], window=p["window"], scale=p["scale"], normalize=p["normalize"], grace=p["grace"])
        cps, strength = detect_changepoints(profile, threshold=p["threshold"], min_size=p["min_size"],
                                            grace=p["grace"], **_window_argument(p["window"]))
        cps = np.asarray(loop_refine(cps, list(jerk_norm), half_width=max(2, p["window"] // 4)), dtype=int)
        if stop_ratio is not None:
            cps, strength = gate_changepoints(cps, strength, t, demo[name], window=p["window"],
                                              min_size=p["min_size"], grace=p["grace"],
                                              stop_ratio=stop_ratio, min_turn=min_turn)
        profiles[name], raws[name], changepoints[name], params[name] = profile, raw, cps, p
        curves[name] = _gaussian_curve(cps, n, sigma=p["window"] / 2.0, floor=floor)

    # product of the curves, as a log, rescaled so a floor counts 0 and a Gaussian peak counts 1
    unit = math.log1p(floor) - math.log(floor)
    support = [0.0] * n
    for i in range(n):
        log_product = 0.0
        for name in names:
            log_product += math.log(curves[name][i])
        support[i] = (log_product - len(names) * math.log(floor)) / unit

    need = max(1.0, len(names) / 2.0) if min_support is None else float(min_support)
    peaks, heights = _local_maxima(support, min_height=need - 0.25 - 1e-9)
    shortest = min(p["min_size"] for p in params.values())
    keypoints = _suppress_close(peaks, heights, min_size=shortest, n=n)
    return LoopResult(keypoints, changepoints, profiles, raws, np.array(support), params, steps)
