"""Sampling rate: a motion is cut at the same times at 100 Hz and at 1 kHz (a Franka's rate).

The generator is a seeded arm motion of its own: 3 to 5 minimum-jerk reaches of 15 to 30 cm in
random directions, each ending at rest, with dwells of 0.1 to 0.3 s between them. The same motion
is sampled at 100 Hz and at 1 kHz, each with its own white position noise of the same standard
deviation (micrometres, as an encoder-based pose reads). Before the rest finder's noise share bound
at every rate and a turn confirmed one rest, the 1 kHz copies were cut up to half a window from the
100 Hz ones, or once more.
"""

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.segmentation import segment
from skillbank.segmentation._motion import TURN_CONFIDENCE
from skillbank.segmentation._motion import motion_evidence as _motion_evidence
from skillbank.segmentation._segmenter import AUTO_WINDOW_FRACTION

#: Rests before the first and after the last reach (s).
LEAD = 0.3


def _reaches(seed):
    """``(position(t), duration, truth)``: the motion of ``seed``; truth = the dwells' middles (s)."""
    rng = np.random.default_rng(seed)
    n_moves = int(rng.integers(3, 6))
    points = [np.array([0.4, 0.0, 0.3])]
    for _ in range(n_moves):
        step = rng.normal(size=3)
        points.append(points[-1] + step * rng.uniform(0.15, 0.3) / np.linalg.norm(step))
    durations = rng.uniform(0.8, 1.5, n_moves)
    dwells = rng.uniform(0.1, 0.3, n_moves - 1)
    starts = LEAD + np.concatenate(([0.0], np.cumsum(durations[:-1] + dwells)))

    def position(t):
        y = np.repeat(points[0][None], t.size, axis=0)
        for k in range(n_moves):
            s = np.clip((t - starts[k]) / durations[k], 0.0, 1.0)
            y = y + (10 * s**3 - 15 * s**4 + 6 * s**5)[:, None] * (points[k + 1] - points[k])
        return y

    return position, starts[-1] + durations[-1] + LEAD, starts[1:] - dwells / 2


def _cut(seed, rate, noise):
    """``(cut times, truth, window)`` (s): the motion of ``seed`` at ``rate`` Hz with ``noise`` m of noise."""
    position, duration, truth = _reaches(seed)
    t = np.arange(int(duration * rate) + 1) / rate
    y = position(t) + np.random.default_rng([seed, int(rate)]).normal(0.0, noise, (t.size, 3))
    times = segment(Demonstration.from_array(y, t, name="position")).keypoint_times
    return times, truth, AUTO_WINDOW_FRACTION * duration


@pytest.mark.parametrize("noise", [10e-6, 20e-6])
@pytest.mark.parametrize("seed", range(4))
def test_the_same_motion_at_100_hz_and_1_khz_is_cut_at_the_same_times(seed, noise):
    coarse, truth, window = _cut(seed, 100.0, noise)
    fine, _, _ = _cut(seed, 1000.0, noise)
    # every dwell is a boundary at either rate, and nothing else is
    assert coarse.size == fine.size == truth.size
    assert np.abs(coarse - truth).max() <= window / 4
    # a quarter window is the refinement's reach; the copies were up to half a window apart
    assert np.abs(fine - coarse).max() <= window / 4


def test_a_turn_confirms_one_rest_the_most_confident_near_it():
    # two movements with a stop at sample 200 and a dip of the speed at 100; a turn at 150
    t = np.linspace(0.0, 2.0, 401)
    v = np.abs(np.sin(np.pi * t)) - 0.2 * np.exp(-0.5 * ((t - 0.5) / 0.03) ** 2)
    at, conf = _motion_evidence(v, [150], window=60)
    assert at.tolist() == [100, 200]
    assert conf[0] < 0.01  # the dip stays a dip (every rest near a turn was raised to 0.6)
    assert conf[1] == pytest.approx(0.9, abs=1e-3)
    # with the stop out of reach, the turn confirms the dip, the best candidate left near it
    at, conf = _motion_evidence(v, [120], window=60)
    assert conf[at.tolist().index(100)] == TURN_CONFIDENCE
