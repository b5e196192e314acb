"""Probabilistic keypoints: Gaussians at changepoints, their product, and keypoint extraction."""

from __future__ import annotations

import numpy as np
from scipy.signal import find_peaks

from ._changepoints import suppress_close

__all__ = [
    "changepoint_probability", "combine_probabilities", "keypoints_deterministic", "keypoints_sampling",
]

#: A mode counts when its support is within this of ``min_support``: the
#: support is a sum of logarithms, and a mode where exactly ``min_support``
#: streams agree can come out a round-off below it.
SUPPORT_TOLERANCE = 1e-9


def changepoint_probability(changepoints, n_steps: int, sigma: float, *, floor: float = 0.05):
    """One stream's keypoint curve: a unit Gaussian at each changepoint over a floor.

    The floor is the chance that a keypoint sits where this stream saw
    nothing; without it, the product would let any single stream veto every
    keypoint the others found.

    Returns
    -------
    ndarray of shape (n_steps,)
        Values in ``[floor, 1 + floor]``.

    Examples
    --------
    >>> p = changepoint_probability([50], 100, sigma=4.0)
    >>> int(np.argmax(p)), round(float(p.max()), 2)
    (50, 1.05)
    """
    idx = np.arange(n_steps, dtype=float)
    cps = np.asarray(changepoints, dtype=float)
    if cps.size == 0:
        return np.full(n_steps, floor)
    # each changepoint's own Gaussian, max-combined so neighbours do not stack
    z = (idx[None, :] - cps[:, None]) / sigma
    return floor + np.exp(-0.5 * z**2).max(axis=0)


def combine_probabilities(curves: dict, *, floor: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """Product of the per-stream curves, returned as a probability and a support count.

    Returns
    -------
    probability : ndarray of shape (n_steps,)
        The product, normalised to sum to one.
    support : ndarray of shape (n_steps,)
        How many streams agree at each sample: the log of the product on a
        scale where a floor contributes 0 and a Gaussian peak contributes 1.

    Examples
    --------
    >>> a = changepoint_probability([30], 60, 3.0)
    >>> b = changepoint_probability([30], 60, 3.0)
    >>> round(float(combine_probabilities({"a": a, "b": b})[1][30]), 3)
    2.0
    """
    logs = np.sum([np.log(c) for c in curves.values()], axis=0)
    n_streams = len(curves)
    unit = np.log1p(floor) - np.log(floor)
    support = (logs - n_streams * np.log(floor)) / unit
    prob = np.exp(logs - logs.max())
    return prob / prob.sum(), support


def keypoints_deterministic(support, *, min_support: float, min_size: int):
    """Keypoints as the significant modes of the combined curve.

    A mode is significant when at least ``min_support`` streams agree there.

    Examples
    --------
    >>> s = np.zeros(100); s[40] = 2.0; s[41] = 1.9
    >>> keypoints_deterministic(s, min_support=1.5, min_size=10).tolist()
    [40]
    """
    support = np.asarray(support, dtype=float)
    # -inf at both ends lets a mode at the first or last sample count
    padded = np.concatenate(([-np.inf], support, [-np.inf]))
    peaks, props = find_peaks(padded, height=min_support - SUPPORT_TOLERANCE)
    peaks = peaks - 1
    return suppress_close(peaks, props["peak_heights"], min_size=min_size, n_steps=support.shape[0])


def keypoints_sampling(
    probability, *, n_samples: int, min_hits: int, window: int, min_size: int, rng: np.random.Generator,
    max_rounds: int = 50,
):
    """The paper's keypoints: sample the combined curve until the samples agree.

    Each round draws ``n_samples`` sample indices from ``probability``; sorted
    draws closer than ``window`` form a group; a group with at least
    ``min_hits`` draws gives a keypoint at its median. Rounds repeat until two
    successive rounds give the same number of keypoints (at most
    ``max_rounds``), and the last round's keypoints are returned.

    Examples
    --------
    >>> p = np.zeros(100); p[20] = p[70] = 0.5
    >>> keypoints_sampling(p, n_samples=20, min_hits=3, window=5, min_size=10,
    ...                    rng=np.random.default_rng(0)).tolist()
    [20, 70]
    """
    n = probability.shape[0]
    previous = None
    keypoints = np.array([], dtype=int)
    for _ in range(max_rounds):
        draws = np.sort(rng.choice(n, size=n_samples, p=probability))
        breaks = np.flatnonzero(np.diff(draws) >= window) + 1
        groups = np.split(draws, breaks)
        sizes = np.array([g.size for g in groups])
        centres = np.array([int(np.median(g)) for g in groups])
        good = sizes >= min_hits
        keypoints = suppress_close(centres[good], sizes[good], min_size=min_size, n_steps=n)
        if previous is not None and previous == keypoints.size:
            break
        previous = keypoints.size
    return keypoints


#: Sigmas either side of an event beyond which its Gaussian is taken as 0 (exp(-32) = 1.3e-14).
GAUSSIAN_REACH = 8.0


def evidence_curve(events, confidence, n_steps: int, sigma: float) -> np.ndarray:
    """One stream's evidence of a boundary at each sample, in [0, 1].

    Each event contributes a Gaussian of height its confidence; where two
    overlap the larger counts (evidence of one boundary does not add up
    because a stream saw it twice).

    Examples
    --------
    >>> c = evidence_curve([50], [0.8], 100, sigma=4.0)
    >>> int(np.argmax(c)), round(float(c.max()), 2), round(float(c[0]), 2)
    (50, 0.8, 0.0)
    """
    at = np.asarray(events, dtype=float)
    out = np.zeros(n_steps)
    if at.size == 0:
        return out
    # each Gaussian only within 8 sigma of its event (beyond, below 1.3e-14 of its height):
    # the cost grows with the events times their width, not times the whole stream
    reach = min(int(np.ceil(GAUSSIAN_REACH * sigma)), n_steps)  # never wider than the stream
    offsets = np.arange(-reach, reach + 1)
    pos = np.rint(at).astype(int)[:, None] + offsets[None, :]
    inside = (pos >= 0) & (pos < n_steps)
    value = np.asarray(confidence, dtype=float)[:, None] * np.exp(-0.5 * ((pos - at[:, None]) / sigma) ** 2)
    np.maximum.at(out, pos[inside], value[inside])
    return out


def combine_evidence(curves: dict, kinds: dict) -> tuple[np.ndarray, dict]:
    """Probability of a boundary at each sample, from the streams' evidence curves.

    Streams of one kind (``"motion"``, ``"contact"``, ``"discrete"``) see the
    same physical events (the joints, the flange position and its orientation
    all stop together), so their curves are averaged: one noisy stream's
    false event is diluted by the others that saw nothing. The kinds are
    independent witnesses, so they combine by the noisy-OR rule,
    ``1 - prod(1 - p_kind)``: one confident kind (a gripper that closed, a
    contact that began) carries a keypoint on its own, and two weak ones
    reinforce each other.

    Returns
    -------
    probability : ndarray of shape (n_steps,)
        In [0, 1].
    per_kind : dict of str to ndarray
        Each kind's averaged curve.

    Examples
    --------
    >>> a = evidence_curve([30], [0.9], 60, 3.0)
    >>> b = evidence_curve([], [], 60, 3.0)
    >>> p, _ = combine_evidence({"gripper": a, "position": b}, {"gripper": "discrete", "position": "motion"})
    >>> round(float(p[30]), 2)  # the gripper alone carries it
    0.9
    """
    groups: dict = {}
    for name, curve in curves.items():
        groups.setdefault(kinds[name], []).append(curve)
    per_kind = {k: np.mean(v, axis=0) for k, v in groups.items()}
    miss = np.ones_like(next(iter(per_kind.values())))
    for curve in per_kind.values():
        miss = miss * (1.0 - curve)
    return 1.0 - miss, per_kind
