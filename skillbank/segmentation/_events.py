"""Boundary evidence from contact and discrete streams, and the kind of each stream.

A kinematic stream (positions, joint angles, orientations) shows a boundary
where the motion stops or turns; the jerk profile and the stop-or-turn gate
find those. A **contact** stream (force, torque) shows one where its level
steps: a contact begins or ends, whatever the arm's speed. A **discrete**
stream (a gripper) shows one where it switches between its held levels. Each
kind here returns its events with a confidence in (0, 1], which
:func:`~skillbank.segmentation._keypoints.combine_evidence` turns into the
keypoint probability.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import find_peaks

from ._profile import TYPICAL_PERCENTILE, speed_norm

__all__ = ["KINDS", "stream_kind", "discrete_events", "contact_events", "rest_events", "rest_speed"]

#: No single stream is certain of a boundary (a sensor glitches, an operator
#: pauses): its confidence is at most this, so that where two streams disagree
#: on where a boundary lies, the place that more kinds of evidence support wins.
MAX_CONFIDENCE = 0.9

#: The kinds of stream and what their evidence is. A stream's kind comes from
#: its name (``DEFAULT_KINDS``) unless ``stream_kinds`` names it.
KINDS = ("motion", "contact", "discrete")

#: Names that skillbank's readers give contact and discrete streams; any other
#: stream is motion (positions, joints, orientations, or a user's own name).
DEFAULT_KINDS = {"force": "contact", "torque": "contact", "wrench": "contact", "gripper": "discrete"}

#: A discrete stream switches state when it moves, between two rests, by at least this fraction of its
#: whole range (a reversal of less is noise about one level, or a drift within it). Relative to where it
#: rested, not to fixed levels: fingers closing on a thin can stop half-way (37-50 % of their range in a
#: PickPlace demonstration whose milk and cereal grasps set the range), and that grasp is a switch too.
SWITCH = 0.25
#: Within one move, the switch is placed half-way between the last sample in its first quarter and the
#: first in its last quarter (the middle of a gripper's closing), the quarters of the way from where it
#: rested before to the level it rests at after.
SWITCH_LOW, SWITCH_HIGH = 0.25, 0.75

#: A discrete stream whose range is below this fraction of its magnitude
#: (``1 + max|y|``) never switches: it is held.
HELD_RANGE = 1e-9

#: A contact step's effect size (the change of level over the pooled spread
#: within the windows either side) at which it is as likely a contact as not:
#: the level moves by six times its own jitter.
HALF_EFFECT = 6.0

#: An impact's distance from the running median, in robust standard
#: deviations, counts as a step's effect size of one ``IMPULSE_SCALE``-th of
#: it: a step's effect compares two means of a window, an impact is one sample.
IMPULSE_SCALE = 2.0

#: The running medians that impacts are measured from are taken on every
#: ``window // IMPULSE_STRIDE_DIVISOR``-th sample (see ``_running_median``).
IMPULSE_STRIDE_DIVISOR = 8

#: Steps of smaller effect are not reported (their confidence is below 0.16).
MIN_EFFECT = 3.0


def stream_kind(name: str, kinds=None) -> str:
    """The kind of the stream ``name``: ``kinds[name]`` if given, else by its name.

    Examples
    --------
    >>> stream_kind("gripper"), stream_kind("force"), stream_kind("joints")
    ('discrete', 'contact', 'motion')
    >>> stream_kind("suction", {"suction": "discrete"})
    'discrete'
    """
    kind = (kinds or {}).get(name, DEFAULT_KINDS.get(name, "motion"))
    if kind not in KINDS:
        raise ValueError(f"stream_kinds[{name!r}]: expected one of {list(KINDS)}, got {kind!r}")
    return kind


def _pivots(u: np.ndarray, height: float) -> list[int]:
    """The samples where ``u`` turns after a move of at least ``height`` (a zig-zag of its extremes).

    The first pivot is the extreme the first such move starts from, each next one the extreme a move of
    at least ``height`` the other way starts from, the last the end of the last move; of equal samples
    the latest (a gripper starts closing at the end of its rest).
    """
    # only where u changes can an extreme begin or end: a held gripper is a few such samples
    moving = np.flatnonzero(np.diff(u) != 0)
    points = np.unique(np.r_[0, moving, moving + 1, u.size - 1]).astype(int)
    pivots, lo, hi, rising = [], 0, 0, None
    for i in points:
        if rising is None:
            hi = i if u[i] >= u[hi] else hi
            lo = i if u[i] <= u[lo] else lo
            if u[hi] - u[lo] >= height:
                rising = bool(hi > lo)
                pivots.append(lo if rising else hi)
        elif rising:
            if u[i] >= u[hi]:
                hi = i
            elif u[hi] - u[i] >= height:
                pivots.append(hi)
                rising, lo = False, i
        else:
            if u[i] <= u[lo]:
                lo = i
            elif u[i] - u[lo] >= height:
                pivots.append(lo)
                rising, hi = True, i
    if rising is not None:
        pivots.append(hi if rising else lo)
    return pivots


def discrete_events(Y) -> tuple[np.ndarray, np.ndarray]:
    """Where a discrete stream switches between its levels, each with confidence 1.

    The stream is one device (a gripper's finger joints move together), so its state is one coordinate:
    the position along the line its samples spread along most (:func:`_main_axis`); a joint that only
    gives when something presses on the fingers (a linkage's passive knuckle, jolted as a carried box
    touches down) moves off that line and does not switch it. That coordinate is scaled to [0, 1] over
    its range; it switches at every move between two rests of at least :data:`SWITCH` of that range,
    whatever level it starts and ends at (one grasp closes the fingers fully on a small object, another
    half-way on a large one). The switch is placed half-way
    through the move's crossing (from its first quarter to its last: the middle of a gripper's closing),
    the quarters of the way to the level it rests at after it (not the end of a slow squeeze that may
    follow, as fingers shut on a soft carton go on closing while it gives).
    A switch is a definite event, hence confidence 1.

    Examples
    --------
    >>> y = np.r_[np.zeros(50), np.linspace(0, 1, 11), np.ones(50), np.zeros(40)]
    >>> discrete_events(y[:, None])[0].tolist()
    [55, 110]
    >>> half = np.r_[np.ones(50), np.full(50, 0.45), np.ones(50), np.zeros(50), np.ones(50)]
    >>> discrete_events(half[:, None])[0].tolist()  # closing half-way on one object, fully on another
    [49, 99, 149, 199]
    """
    Y = np.asarray(Y, dtype=float)
    Y = Y.reshape(Y.shape[0], -1)
    events = []
    for y in _main_axis(Y).T:
        lo, hi = float(y.min()), float(y.max())
        if hi - lo <= HELD_RANGE * (1.0 + float(np.max(np.abs(Y), initial=0.0))):
            continue
        u = (y - lo) / (hi - lo)
        pivots = _pivots(u, SWITCH)
        for a, b in zip(pivots[:-1], pivots[1:], strict=True):
            leg = u[a:b + 1] if u[b] > u[a] else 1.0 - u[a:b + 1]
            first = float(leg[0])
            # the level it comes to rest at: the median after it passes half-way, not its extreme (fingers
            # shut on something soft, a carton, go on closing slowly for seconds as it gives; the closing
            # is the switch, not the squeeze)
            half = int(np.flatnonzero(leg >= (first + leg[-1]) / 2)[0])
            last = float(np.median(leg[half:]))
            low, high = first + SWITCH_LOW * (last - first), first + SWITCH_HIGH * (last - first)
            # the crossing runs from the last sample in the move's first quarter to the first in its last
            start = int(np.flatnonzero(leg[:half + 1] <= low)[-1]) if np.any(leg[:half + 1] <= low) else 0
            above = np.flatnonzero(leg[start:] >= high)
            end = start + (int(above[0]) if above.size else leg.size - 1)
            events.append(a + (start + end) // 2)
    events = np.unique(np.asarray(events, dtype=int))
    return events, np.full(events.size, MAX_CONFIDENCE)


def _main_axis(Y: np.ndarray) -> np.ndarray:
    """``Y`` as one column: each sample's coordinate along the direction its samples spread along most.

    A gripper reports each finger joint (robosuite's Robotiq 85: six, two of them passive knuckles with
    a third of the others' travel); they open and close together, so the opening is the first principal
    direction of the samples. One column is returned as it is.

    Examples
    --------
    >>> t = np.r_[np.zeros(3), np.ones(3)]
    >>> np.abs(_main_axis(np.c_[t, -t])).ravel().round(3).tolist()  # two mirrored fingers: one coordinate
    [0.707, 0.707, 0.707, 0.707, 0.707, 0.707]
    """
    if Y.shape[1] == 1:
        return Y
    centred = Y - Y.mean(axis=0)
    # the right singular vector of the largest singular value: the line of greatest spread
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    return centred @ vt[:1].T


def _noise_sigma(Y: np.ndarray) -> np.ndarray:
    """Per-dimension noise standard deviation, from the median absolute first difference.

    The first difference of white noise has a standard deviation of
    ``sqrt(2) * sigma``; the median ignores the few large differences that
    steps and impacts make.
    """
    d = np.abs(np.diff(Y, axis=0))
    return 1.4826 * np.median(d, axis=0) / np.sqrt(2.0)


def _resolution(Y: np.ndarray) -> np.ndarray:
    """Per-dimension smallest meaningful deviation, a floor for the noise estimate.

    A noiseless stream (a simulated or held signal) has no noise to divide
    by; ``sqrt(eps)`` of its range keeps effect sizes finite (at most about
    10^8) while any real step still stands far above the event threshold.
    """
    return np.sqrt(np.finfo(float).eps) * np.ptp(Y, axis=0) + np.finfo(float).tiny


def _step_effect(Y: np.ndarray, w: int) -> np.ndarray:
    """Effect size of a level step at each sample: the change of the window means over their spread."""
    n = Y.shape[0]
    zero = np.zeros((1, Y.shape[1]))
    c1 = np.vstack([zero, np.cumsum(Y, axis=0)])
    c2 = np.vstack([zero, np.cumsum(Y * Y, axis=0)])
    i = np.arange(w, n - w + 1)
    m_b, m_a = (c1[i] - c1[i - w]) / w, (c1[i + w] - c1[i]) / w
    # variances summed over the dimensions: the spread of the vector about its mean
    v_b = np.maximum(((c2[i] - c2[i - w]) / w - m_b**2).sum(axis=1), 0.0)
    v_a = np.maximum(((c2[i + w] - c2[i]) / w - m_a**2).sum(axis=1), 0.0)
    # a floor at the sensor's noise, so two noiseless plateaus do not divide by zero
    floor = float(np.sum(np.maximum(_noise_sigma(Y), _resolution(Y)) ** 2))
    d = np.zeros(n)
    d[i] = np.linalg.norm(m_a - m_b, axis=1) / np.sqrt(0.5 * (v_a + v_b) + floor)
    return d


def _running_median(X: np.ndarray, w: int) -> np.ndarray:
    """Running median of each column over ``2 w + 1`` samples, taken on every ``w // 8``-th sample.

    The median of a window that wide changes little from one sample to the
    next: taking it on a sub-sampled copy and interpolating back costs a
    fraction of the full filter (whose cost grows with the window) and moves
    the baseline by a small part of what an impact rises above it.
    """
    from scipy.ndimage import median_filter  # only contact streams need running medians

    q = max(1, w // IMPULSE_STRIDE_DIVISOR)
    idx = np.arange(0, X.shape[0], q)
    if idx[-1] != X.shape[0] - 1:
        idx = np.r_[idx, X.shape[0] - 1]
    med = median_filter(X[idx], size=(2 * (w // q) + 1, 1), mode="nearest")
    at = np.arange(X.shape[0])
    return np.column_stack([np.interp(at, idx, med[:, k]) for k in range(X.shape[1])])


def _impulse_effect(Y: np.ndarray, w: int) -> np.ndarray:
    """Effect size of an impulse at each sample: its distance from the running median over the running MAD."""
    dev = np.abs(Y - _running_median(Y, w))
    spread = 1.4826 * _running_median(dev, w)
    floor = np.maximum(_noise_sigma(Y), _resolution(Y))
    return np.linalg.norm(dev / np.maximum(spread, floor), axis=1) / np.sqrt(Y.shape[1])


def contact_events(Y, *, window: int) -> tuple[np.ndarray, np.ndarray]:
    """Where a contact begins or ends: a step of the level, or an impact.

    **Steps.** At each sample the means of the ``window`` samples before and
    after are compared with how much the stream varies within them: the
    effect size ``d = |mean_after - mean_before| / pooled_std``. A contact
    that begins or ends moves the level by many times its jitter; the force
    of a hand guiding the arm wanders about as much within a window as
    between two (``d`` near 1). **Impacts** (a button hit, a tool touching
    down) are brief: their effect size is the distance from the running
    median over the running median absolute deviation, in robust standard
    deviations, halved (``IMPULSE_SCALE``). An event is a peak of either of at least ``MIN_EFFECT``; its
    confidence is ``1 - 2**(-(d / HALF_EFFECT)**2)``, one half at
    ``HALF_EFFECT``, capped (see :data:`MAX_CONFIDENCE`).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> f = np.r_[np.zeros(200), np.full(200, 10.0), np.zeros(200)] + rng.normal(0, 0.5, 600)
    >>> at, conf = contact_events(f[:, None], window=20)
    >>> [abs(int(a) - b) <= 2 for a, b in zip(at, (200, 400))], bool(conf.min() > 0.8)
    ([True, True], True)
    """
    Y = np.asarray(Y, dtype=float)
    Y = Y.reshape(Y.shape[0], -1)
    n = Y.shape[0]
    w = int(window)
    if n < 2 * w + 1 or w < 2:
        return np.array([], dtype=int), np.array([], dtype=float)
    spread = float(np.max(Y.max(axis=0) - Y.min(axis=0)))
    if 0.0 < spread < np.inf:
        # effect sizes do not depend on the unit: a power of two (exact) brings the spread to about
        # one, so that the variance floor of a stream of tiny values does not underflow to 0 / 0
        Y = np.ldexp(Y, -int(np.frexp(spread)[1]))
    # a single sample of white noise is 3 robust deviations out once in a few hundred,
    # 6 once in 10^9: an impact counts on the steps' scale at half its size
    d = np.maximum(_step_effect(Y, w), _impulse_effect(Y, w) / IMPULSE_SCALE)
    peaks, props = find_peaks(d, height=MIN_EFFECT, distance=w)
    conf = MAX_CONFIDENCE * (1.0 - 2.0 ** (-((props["peak_heights"] / HALF_EFFECT) ** 2)))
    return peaks.astype(int), conf


#: A rest is as likely a boundary as not where the speed at the bottom of its
#: valley is this fraction of the slower of the two movements either side
#: (their peak speeds): a twentieth is a stop (the arm waits, a button is
#: pressed); a pen slowing for a corner keeps a tenth or more of its speed.
HALF_REST_RATIO = 0.05

#: How sharply the confidence of a rest falls about ``HALF_REST_RATIO``: below
#: a fiftieth every stop is as good as a full one (a press and the pause above
#: the button differ in ratio by sensor noise, not by being more of a stop),
#: above a tenth the pen is only slowing.
REST_EXPONENT = 4

#: Valleys shallower than this fraction of the typical speed are ripples of
#: one movement, not candidates.
VALLEY_PROMINENCE = 0.02

#: The bottom of a valley is where the speed is within this fraction of the
#: way from the valley's lowest speed to the slower side's peak: a dwell's
#: whole flat stretch, whose middle is the boundary.
REST_BAND = 0.02

#: A movement either side of a rest must reach this fraction of the typical
#: speed: slower wanderings are the sensor drifting while the arm is held.
MOVEMENT_FRACTION = 0.2


def _run_around(v: np.ndarray, c: int, lo: int, hi: int, level: float) -> tuple[int, int]:
    """``(start, end)``: the run of ``v`` at or below ``level`` that holds ``c``, within ``[lo, hi]``.

    Scans outward from ``c`` in blocks that double (compiled code per block),
    so the cost is about the run's length, however wide ``[lo, hi]`` is: the
    deepest valleys of an hour-long recording span all of it.
    """
    start, step = c, 16
    while start > lo:
        a = max(lo, start - step)
        above = np.flatnonzero(v[a:start] > level)
        if above.size:
            start = a + int(above[-1]) + 1
            break
        start, step = a, 2 * step
    end, step = c, 16
    while end < hi:
        b = min(hi, end + step)
        above = np.flatnonzero(v[end + 1:b + 1] > level)
        if above.size:
            end = end + int(above[0])
            break
        end, step = b, 2 * step
    return start, end


def _nearest_deeper(rank: np.ndarray, gap_max: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each valley (in position order): the nearest deeper one before it and the highest speed between.

    ``rank`` orders the valleys by depth (0 the deepest); ``gap_max[i]`` is the
    highest speed from valley ``i - 1`` (or the start) to valley ``i``. Returns
    the index of the nearest earlier valley of lower rank (-1 for none) and the
    highest speed from it (or the start) to the valley. One pass with a stack:
    the stretches of the valleys it pops tile the way back to the deeper one,
    so their maxima combine into this one's, and each valley is popped once.
    """
    m = rank.shape[0]
    left = np.full(m, -1, dtype=np.int64)
    peak = np.empty(m)
    stack: list[int] = []
    for i in range(m):
        top = float(gap_max[i])
        r = rank[i]
        while stack and rank[stack[-1]] > r:
            j = stack.pop()
            if peak[j] > top:
                top = peak[j]
        left[i] = stack[-1] if stack else -1
        peak[i] = top
        stack.append(i)
    return left, peak


def rest_events(speed, *, typical: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the motion comes to rest between two movements.

    Every valley of ``speed`` is compared with the movements either side of
    it: each side's peak speed, up to the next valley that is at least as
    deep. Its stop ratio is the valley's lowest speed over the slower side's
    peak, and its confidence ``1 / (1 + (ratio / HALF_REST_RATIO)**4)``: one
    for a full stop (at least 0.97 below a fiftieth of the speed), one half
    at a twentieth, 0.06 for a pen slowing to a tenth of its speed at a
    corner (then scaled by :data:`MAX_CONFIDENCE`). The event sits in
    the middle of the valley's bottom (``REST_BAND``), i.e. the middle of a
    dwell, or the slowest sample of a brief stop. Valleys at either end have
    a movement on one side only and are no boundary.

    Returns
    -------
    events : ndarray of int
    confidence : ndarray of float
    ratio : ndarray of float
        Each event's stop ratio.

    Examples
    --------
    >>> t = np.linspace(0.0, 2.0, 401)
    >>> v = np.abs(np.sin(np.pi * t))  # two movements, a full stop between them at t = 1
    >>> at, conf, ratio = rest_events(v, typical=1.0)
    >>> at.tolist(), round(float(conf[0]), 3)  # a full stop, as confident as one stream gets
    ([200], 0.9)
    """
    v = np.asarray(speed, dtype=float)
    n = v.shape[0]
    valleys, _ = find_peaks(-v, prominence=VALLEY_PROMINENCE * typical)
    if valleys.size == 0:
        return np.array([], dtype=int), np.array([], dtype=float), np.array([], dtype=float)
    m = valleys.size
    rank = np.empty(m, dtype=np.int64)
    rank[np.argsort(v[valleys], kind="stable")] = np.arange(m)  # ties: the earlier valley is deeper
    # the highest speed between consecutive valleys (and from each end to its nearest valley)
    gaps = np.maximum.reduceat(v, np.r_[0, valleys])  # the last runs to the end
    gaps[:m] = np.maximum(gaps[:m], v[valleys])  # reduceat stops short of each stretch's end valley
    left, peak_l = _nearest_deeper(rank, gaps[:m])
    right_rev, peak_r_rev = _nearest_deeper(rank[::-1], gaps[1:][::-1])
    right = np.where(right_rev[::-1] >= 0, m - 1 - right_rev[::-1], -1)
    peak_r = peak_r_rev[::-1]
    events, conf, ratios = [], [], []
    for k in range(m):
        c = int(valleys[k])
        lo = int(valleys[left[k]]) if left[k] >= 0 else 0
        hi = int(valleys[right[k]]) if right[k] >= 0 else n - 1
        side = min(float(peak_l[k]), float(peak_r[k]))
        if side < MOVEMENT_FRACTION * typical:
            # no movement on one side: the valley is the rest before the first or after the last
            continue
        ratio = float(v[c]) / side
        # the run of the valley's bottom that holds c, within the valley
        a, b = _run_around(v, c, lo, hi, float(v[c]) + REST_BAND * (side - float(v[c])))
        events.append((a + b) // 2)
        ratios.append(ratio)
        conf.append(MAX_CONFIDENCE / (1.0 + (ratio / HALF_REST_RATIO) ** REST_EXPONENT))
    order = np.argsort(events, kind="stable")
    return (np.asarray(events, dtype=int)[order], np.asarray(conf)[order], np.asarray(ratios)[order])


#: The speed that rests are found on is smoothed until the sensor's noise adds
#: at most this fraction of the typical speed: the bottom band of a rest between
#: the slowest movements that count (``REST_BAND`` of ``MOVEMENT_FRACTION``,
#: 0.4 %), so that the noise neither breaks a dwell's bottom into pieces (the rest
#: would go to whichever noise minimum is deepest, anywhere in the dwell and its
#: slow approach) nor deepens a slow passage into a stop. The share must bind at
#: every rate: one sample being the least smoothing there is, 20 µm of noise at
#: 100 Hz met the former share of 1 % with room to spare (0.5 %), at 1 kHz
#: exactly, and the same motion then left twice the noise in the speed at 1 kHz,
#: with ten times as many valleys per second.
SPEED_NOISE_SHARE = REST_BAND * MOVEMENT_FRACTION


def rest_speed(t, Y, speed=None, *, max_sigma: float) -> np.ndarray:
    """Speed of ``Y`` smoothed just enough for its noise to hide no stop.

    The noise of each dimension is estimated from its third differences
    (``sigma = 1.4826 * median|diff3| / sqrt(20)``: white noise has a
    variance of ``20 sigma**2`` there, smooth motion sampled finely almost
    none). ``Y`` is smoothed by a Gaussian of the fewest samples that bring
    the noise of the differentiated speed under ``SPEED_NOISE_SHARE`` of the
    typical speed (at most ``max_sigma``), then differentiated on the real
    time stamps. ``speed`` is ``Y``'s unsmoothed :func:`speed_norm`, when
    the caller has it already.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 201)
    >>> v = rest_speed(t, np.column_stack([t, 2 * t]), max_sigma=8)
    >>> bool(np.allclose(v[10:-10], np.sqrt(5.0)))
    True
    """
    from scipy.ndimage import gaussian_filter1d  # only the segmenter's rest finder needs it

    t = np.asarray(t, dtype=float)
    Y = np.asarray(Y, dtype=float).reshape(t.shape[0], -1)
    v = speed_norm(t, Y) if speed is None else np.asarray(speed, dtype=float)
    if Y.shape[0] < 8:
        return v
    mad3 = np.median(np.abs(np.diff(Y, n=3, axis=0)), axis=0)
    sigma_n = float(np.linalg.norm(1.4826 * mad3 / np.sqrt(20.0)))
    typical = float(np.percentile(v, TYPICAL_PERCENTILE))
    dt = float(np.median(np.diff(t)))
    if sigma_n <= 0.0 or typical <= 0.0 or dt <= 0.0:
        return v
    # noise of the derivative of a Gaussian-smoothed white noise: sigma_n / dt / sqrt(4 sqrt(pi) s**3)
    s = ((sigma_n / (dt * SPEED_NOISE_SHARE * typical)) ** 2 / (4.0 * np.sqrt(np.pi))) ** (1.0 / 3.0)
    s = float(np.clip(s, 1.0, max(1.0, max_sigma)))
    return speed_norm(t, gaussian_filter1d(Y, s, axis=0, mode="nearest"))
