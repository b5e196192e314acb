"""Motion streams as evidence: their rests, the gate's turns, and segments without a movement of their own."""

from __future__ import annotations

import numpy as np

from ..core import Demonstration
from ._events import HALF_REST_RATIO, MAX_CONFIDENCE, REST_EXPONENT, rest_events
from ._gate import chord_angles
from ._profile import TYPICAL_PERCENTILE

__all__ = ["MIN_MOTION_SHARE", "TURN_CONFIDENCE", "motion_evidence", "moves", "turning", "merge_motionless"]

#: A segment whose motion streams travel less than this fraction of the median
#: segment's path holds no movement of its own (the rest before the first
#: movement, cut off by the operator's hand on the force sensor): it is merged
#: into its neighbour.
MIN_MOTION_SHARE = 0.05

#: A rest is a reversal where the motion leaves it at more than this angle to
#: the way it came (in degrees): the two chords' dot product is negative, so
#: the motion turns back along some direction, whichever axis "down" is.
REVERSAL_DEGREES = 90.0

#: A reversal displaces the pauses near it when it is a full stop: its speed
#: falls below a fiftieth of the movements', where by the rest rule every stop
#: is as good as a full one (``REST_EXPONENT``). A rest that only slows to a
#: twentieth (an orientation that turns back while the tool glides on) is no
#: goal reached, and whether it clears a lower bar is at the mercy of the
#: sensor's rate: a pose logged at 125 Hz moved two presses by 6 and 12 samples.
FULL_STOP_RATIO = 1.0 / 50.0
STOP_CONFIDENCE = MAX_CONFIDENCE / (1.0 + (FULL_STOP_RATIO / HALF_REST_RATIO) ** REST_EXPONENT)

#: Rests less confident than this take no part in the reversal rule: they are
#: below the segmenter's ``MIN_CONFIDENCE`` and left out of the evidence anyway.
MIN_DISPLACED = 0.1

#: With ``combine="evidence"``, a turn of the stop-or-turn gate (a corner
#: where the motion does not stop) is a boundary on its own, but a weaker
#: witness than a stop: more likely than not, and outweighed where a stop or
#: another kind of stream places the boundary elsewhere.
TURN_CONFIDENCE = 0.6


def turning(Y, events, *, window: int, min_turn: float) -> np.ndarray:
    """Which ``events`` turn by at least ``min_turn`` degrees somewhere within one window.

    The turn at a sample is the angle between the chords over the ``window``
    samples before and after it (the gate's measure); a jerk event sits up to
    a window from the corner it marks, so the largest turn within a window of
    the event is taken.
    """
    from scipy.ndimage import maximum_filter1d  # only the evidence rule needs it

    Y = np.asarray(Y, dtype=float).reshape(Y.shape[0], -1)
    n = Y.shape[0]
    angle = maximum_filter1d(chord_angles(Y, np.arange(n), window), 2 * window + 1, mode="nearest")
    return angle[np.asarray(events, dtype=int)] >= min_turn


def moves(t, Y, speed) -> bool:
    """Whether a motion stream moves at all: its path is more than round-off of its magnitude.

    A held stream's speed is round-off (1e-13 of its values, from differences
    of equal numbers on uneven time steps); its valleys and "turns" are noise.
    """
    path = float(np.sum(speed[:-1] * np.diff(t)))
    scale = float(np.max(np.abs(Y))) if Y.size else 0.0
    return path > np.sqrt(np.finfo(float).eps) * scale


def motion_evidence(speed, turns, *, window: int, Y=None, min_size=None) -> tuple[np.ndarray, np.ndarray]:
    """A motion stream's events and confidences: its rests, and the stop-or-turn gate's ``turns``.

    The gate's events are the turns of a stroke that never rests (a letter's
    corners). A turn marks one boundary, so it confirms one rest: the most
    confident within ``window`` of it (the nearest of equals), whose
    confidence becomes at least ``TURN_CONFIDENCE``; the rest finder's best
    candidate is where the boundary lies, the turn's own event being up to a
    window off. A turn far from every rest is an event of its own, a weaker
    witness than a stop.

    Confirming every rest within the window raised each ripple of the speed
    there (any valley of 2 % of the typical speed, however far from a stop) to
    a boundary, and a finely sampled speed has many more ripples per second:
    at 1 kHz ten times as many as at 100 Hz.

    Examples
    --------
    >>> t = np.linspace(0.0, 2.0, 401)  # two movements, a stop at 200, a dip of the speed at 100
    >>> v = np.abs(np.sin(np.pi * t)) - 0.2 * np.exp(-0.5 * ((t - 0.5) / 0.03) ** 2)
    >>> at, conf = motion_evidence(v, [150], window=60)  # a turn half-way, near both
    >>> at.tolist(), np.round(conf, 2).tolist()  # the stop is confirmed, the dip stays a dip
    ([100, 200], [0.0, 0.9])
    """
    rests, confidence, _ = rest_events(speed, typical=float(np.percentile(speed, TYPICAL_PERCENTILE)))
    if Y is not None:
        rests, confidence = _reversals_first(Y, rests, confidence, window=window,
                                             min_size=window if min_size is None else min_size)
    turns = np.asarray(turns, dtype=int)
    gap = np.abs(rests[:, None] - turns[None, :])
    near = gap <= window
    with_rest = near.any(axis=0)
    if with_rest.any():
        # per turn, its most confident rest within the window; of equals the nearest
        top = np.where(near, confidence[:, None], -np.inf).max(axis=0)
        pick = np.argmin(np.where(near & (confidence[:, None] == top), gap, np.inf), axis=0)[with_rest]
        confidence = confidence.copy()
        confidence[pick] = np.maximum(confidence[pick], TURN_CONFIDENCE)
    alone = turns[~with_rest]
    events = np.concatenate([rests, alone])
    confidence = np.concatenate([confidence, np.full(alone.size, TURN_CONFIDENCE)])
    order = np.argsort(events, kind="stable")
    return events[order], confidence[order]


def _reversals_first(Y, rests, confidence, *, window: int, min_size: int):
    """Drop the rests that a reversal closer than ``min_size`` displaces.

    A rest is a reversal where the motion leaves it back against the way it
    came: the chords over the ``window`` samples before and after it point
    more than ``REVERSAL_DEGREES`` apart (their dot product is negative), so
    that along some direction the motion turns back (a press, a place, a touch:
    down, then up again). Two rests closer than a minimum segment cannot both be
    boundaries; where one of them is a reversal that fully stops (a rest's
    confidence of at least ``STOP_CONFIDENCE``: its speed falls below a
    fiftieth), it is the boundary (the goal of the movement, reached), and a pause on the way there
    or back (a hesitation above the button) is dropped, however full a stop:
    every full stop is as confident as one stream gets. No axis is assumed:
    "down" is whichever way the motion came.

    Examples
    --------
    >>> t = np.linspace(0.0, 3.0, 301)
    >>> z = np.interp(t, [0.0, 0.8, 1.0, 1.5, 2.0, 3.0], [1.0, 0.5, 0.5, 0.0, 0.0, 1.0])  # pause, press
    >>> at, _ = _reversals_first(z[:, None], np.array([90, 175]), np.full(2, 0.9), window=40, min_size=100)
    >>> at.tolist()  # the pause at 0.9 s goes, the press at 1.75 s stays
    [175]
    """
    rests = np.asarray(rests, dtype=int)
    confidence = np.asarray(confidence, dtype=float)
    Y = np.asarray(Y, dtype=float).reshape(np.shape(Y)[0], -1)
    # only rests that can matter (the weakest are left out of the evidence anyway): few, real stops
    strong = np.flatnonzero(confidence >= MIN_DISPLACED)
    if strong.size < 2:
        return rests, confidence
    back = chord_angles(Y, rests[strong], window) > REVERSAL_DEGREES
    keep = np.ones(rests.size, dtype=bool)
    for i in strong[back & (confidence[strong] >= STOP_CONFIDENCE)]:
        near = strong[~back][np.abs(rests[strong[~back]] - rests[i]) < min_size]
        keep[near] = False
    return rests[keep], confidence[keep]


def merge_motionless(keypoints, prob, demo: Demonstration, speeds: dict) -> np.ndarray:
    """Drop keypoints that leave a segment without a movement of its own.

    A segment's motion is the path its motion streams travel, each stream
    measured against its own median segment; a segment below
    ``MIN_MOTION_SHARE`` of that in every motion stream is merged into a
    neighbour, by dropping its less probable bounding keypoint (its only one
    at either end of the demonstration).
    """
    keypoints = np.asarray(keypoints, dtype=int)
    dt = np.gradient(demo.t)
    # cumulative path length of each motion stream, so a segment's path is a difference
    paths = [np.concatenate(([0.0], np.cumsum(v * dt))) for v in speeds.values()]
    while keypoints.size:
        edges = np.concatenate(([0], keypoints, [demo.n_steps]))
        shares = []
        for c in paths:
            travel = c[edges[1:]] - c[edges[:-1]]
            typical = float(np.median(travel))
            shares.append(travel / typical if typical > 0 else np.full(travel.size, np.inf))
        share = np.max(shares, axis=0)
        k = int(np.argmin(share))
        if share[k] >= MIN_MOTION_SHARE:
            break
        # segment k lies between keypoints k - 1 and k
        candidates = [i for i in (k - 1, k) if 0 <= i < keypoints.size]
        drop = min(candidates, key=lambda i: prob[keypoints[i]])
        keypoints = np.delete(keypoints, drop)
    return keypoints
