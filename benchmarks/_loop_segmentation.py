"""Per-sample pure-Python-loop baseline of probabilistic multimodal segmentation.

This is the *same method* as :func:`skillbank.segmentation.segment` (deterministic
mode), written the straightforward way the method's authors wrote it: every
derivative, norm, window mean, Gaussian and product is an explicit loop over
samples, and the sliding-window mean sums the whole window at every sample
(O(n * window)). It exists for two reasons only:

* as the reference the benchmark compares the vectorised implementation with;
* as an independent check of that implementation (``tests/segmentation/test_loop_baseline.py``).

Three pieces are shared with skillbank: ``numpy.percentile`` (for the
typical speed), :func:`skillbank.segmentation.detect_changepoints`
(the find_peaks / peak_widths changepoint rule, which runs on the profile and
is not the hot path) and :func:`skillbank.segmentation.gate_changepoints`
(the stop-or-turn gate, which loops over changepoints, not samples).
Only ``mode="deterministic"`` is implemented.
"""

from __future__ import annotations

import inspect
import math

import numpy as np

from skillbank.segmentation import detect_changepoints, gate_changepoints
from skillbank.segmentation._segmenter import to_samples

__all__ = ["loop_segment", "loop_gradient", "loop_jerk_profile", "LoopResult"]

# same values as skillbank.segmentation._profile.FLAT_SCALE and TYPICAL_FRACTION
_FLAT = 1e-12
_TYPICAL_FRACTION = 0.05  # relative scale: speed + 0.05 * (95th percentile of speed)


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
    """

    def __init__(self, keypoints, changepoints, profiles, raw, support, params):
        self.keypoints = keypoints
        self.changepoints = changepoints
        self.profiles = profiles
        self.raw = raw
        self.support = support
        self.params = params


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


def loop_jerk_profile(t, Y, *, window: int, scale: str = "relative", normalize: str = "robust",
                      grace: int = 0, jerk_norm=None):
    """Raw jerk norm and normalised windowed profile of one stream, with loops.

    ``jerk_norm`` is the absolute jerk norm if already computed (:func:`loop_jerk_norm`).
    Returns ``(raw, profile)`` as numpy arrays of shape (n_steps,).
    """
    t = [float(v) for v in np.asarray(t, dtype=float)]
    Y = np.asarray(Y, dtype=float)
    if Y.ndim == 1:
        Y = Y[:, None]
    n, dims = Y.shape

    # skillbank takes the speed from np.gradient's default edge_order=1, which
    # differs from the jerk's first derivative at the two end samples only
    velocity = [loop_gradient(t, [float(v) for v in Y[:, d]], edge_order=1) for d in range(dims)]
    raw = list(loop_jerk_norm(t, Y) if jerk_norm is None else jerk_norm)

    # relative scale: divide by the local speed plus 5 % of the typical speed
    if scale == "relative":
        speed = [0.0] * n
        for i in range(n):
            total = 0.0
            for d in range(dims):
                total += velocity[d][i] * velocity[d][i]
            speed[i] = math.sqrt(total)
        typical = float(np.percentile(speed, 95.0))
        # round-off level of the signal: a held signal is not motion
        steps = sorted(t[i + 1] - t[i] for i in range(n - 1))
        dt = steps[(n - 1) // 2] if (n - 1) % 2 else 0.5 * (steps[(n - 1) // 2 - 1] + steps[(n - 1) // 2])
        peak = max(abs(v) for row in Y for v in row)
        flat = 1e-9 * (1.0 + peak) / dt
        if typical <= flat:
            typical = max(speed)
        for i in range(n):
            if typical <= flat:
                raw[i] = 0.0
            else:
                raw[i] = raw[i] / (speed[i] + _TYPICAL_FRACTION * typical)
    elif scale != "absolute":
        raise ValueError(f"scale: expected 'relative' or 'absolute', got {scale!r}")

    # centred sliding-window mean; the window shrinks near the ends
    mean = [0.0] * n
    half = window // 2
    for i in range(n):
        lo = max(0, i - half)
        hi = min(n, i - half + window)
        total = 0.0
        for k in range(lo, hi):
            total += raw[k]
        mean[i] = total / (hi - lo)

    # normalisation: divide by the maximum ("max"), or by the median of the five
    # highest local maxima of the interior ("robust"); no clipping
    if normalize == "max":
        scale_value = max(mean)
    elif normalize == "robust":
        inner = mean[grace : n - grace] if n > 2 * grace + 1 else mean
        heights = []
        for i in range(1, len(inner) - 1):
            if inner[i] >= inner[i - 1] and inner[i] > inner[i + 1]:
                heights.append(inner[i])
        top = sorted(heights, reverse=True)[:5]
        if not top:
            scale_value = 0.0
        elif len(top) % 2 == 1:
            scale_value = top[len(top) // 2]
        else:
            scale_value = (top[len(top) // 2 - 1] + top[len(top) // 2]) / 2.0
        if scale_value <= _FLAT:
            scale_value = max(mean)
    else:
        raise ValueError(f"normalize: expected 'robust' or 'max', got {normalize!r}")
    profile = [0.0] * n
    if math.isfinite(scale_value) and scale_value > _FLAT:
        for i in range(n):
            profile[i] = mean[i] / scale_value
    return np.array(raw), np.array(profile)


# --------------------------------------------------------------------------- keypoints


def loop_jerk_norm(t, Y) -> list:
    """Absolute jerk norm per sample, with loops."""
    t = [float(v) for v in np.asarray(t, dtype=float)]
    Y = np.asarray(Y, dtype=float)
    if Y.ndim == 1:
        Y = Y[:, None]
    n, dims = Y.shape
    jerk = []
    for d in range(dims):
        column = [float(v) for v in Y[:, d]]
        jerk.append(loop_gradient(t, loop_gradient(t, loop_gradient(t, column))))
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

    profiles, raws, changepoints, curves, params = {}, {}, {}, {}, {}
    for name in names:
        p = _settings(n, t, window, min_size, threshold, grace, scale, normalize, stop_ratio, min_turn)
        jerk_norm = loop_jerk_norm(t, demo[name])
        raw, profile = loop_jerk_profile(t, demo[name], window=p["window"], scale=p["scale"],
                                         normalize=p["normalize"], grace=p["grace"], jerk_norm=jerk_norm)
        cps, strength = detect_changepoints(profile, threshold=p["threshold"], min_size=p["min_size"],
                                            grace=p["grace"], **_window_argument(p["window"]))
        cps = np.asarray(loop_refine(cps, jerk_norm, half_width=max(2, p["window"] // 4)), dtype=int)
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
    return LoopResult(keypoints, changepoints, profiles, raws, np.array(support), params)
