"""The motion's own time scale, and the default window it bounds (#27: linear in the recording)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skillbank import Demonstration
from skillbank.segmentation import (
    MultimodalSegmenter,
    _timescale,
    motion_time_scale,
    segment,
    speed_correlation_time,
)
from skillbank.segmentation._changepoints import suppress_close
from skillbank.segmentation._segmenter import AUTO_WINDOW_FRACTION


def _moves(seconds, *, rate=200.0, seed=0, noise=0.0):
    """Minimum-jerk point-to-point moves of 0.8-2 s, each followed by a rest of 0.2-0.8 s."""
    rng = np.random.default_rng(seed)
    n = int(seconds * rate)
    x = np.zeros((n, 3))
    here, i, ends = np.zeros(3), 0, []
    while i < n:
        d, r = int(rng.uniform(0.8, 2.0) * rate), int(rng.uniform(0.2, 0.8) * rate)
        there = here + rng.uniform(-0.2, 0.2, 3)
        s = np.linspace(0.0, 1.0, d)
        b = 10 * s**3 - 15 * s**4 + 6 * s**5
        j = min(n, i + d)
        x[i:j] = (here + b[:, None] * (there - here))[: j - i]
        x[j:min(n, j + r)] = there
        ends.append(j / rate)
        here, i = there, j + r
    x += rng.normal(0.0, noise, x.shape)
    return Demonstration(np.arange(n) / rate, {"position": x}), np.array(ends[:-1])


def _direct(v, max_lag):
    """Straightforward normalised autocorrelation of the mean-removed speed."""
    x = v - v.mean()
    return np.array([np.dot(x[: x.size - k], x[k:]) for k in range(max_lag)]) / np.dot(x, x)


def test_correlation_time_of_a_known_curve():
    t = np.arange(4000) / 100.0
    v = np.sin(np.pi * t / 2.0) ** 2  # mean removed: half a cosine of period 2 s, zero at 0.5 s
    assert speed_correlation_time([v]) == pytest.approx(50.0, abs=0.5)


def test_chunked_sums_match_the_direct_autocorrelation(monkeypatch):
    demo, _ = _moves(60.0, seed=3)
    from skillbank.segmentation._profile import speed_norm

    v = speed_norm(demo.t, demo["position"])
    direct = _direct(v, 800)
    zero = np.flatnonzero(direct <= 0)[0]
    exact = zero - 1 + direct[zero - 1] / (direct[zero - 1] - direct[zero])
    assert speed_correlation_time([v]) == pytest.approx(exact, abs=1e-6)  # one chunk: exact
    monkeypatch.setattr(_timescale, "CHUNK", 2048)  # 6 chunks: the pairs across their ends are left out
    assert speed_correlation_time([v]) == pytest.approx(exact, rel=0.05)


def test_white_noise_does_not_move_the_time_scale():
    clean, _ = _moves(120.0, seed=1)
    noisy, _ = _moves(120.0, seed=1, noise=2e-5)
    from skillbank.segmentation._profile import speed_norm

    a = motion_time_scale([speed_norm(clean.t, clean["position"])])
    b = motion_time_scale([speed_norm(noisy.t, noisy["position"])])
    assert b == pytest.approx(a, rel=0.1)


def test_no_motion_has_no_time_scale_shorter_than_the_recording():
    assert speed_correlation_time([np.ones(100)]) == 100.0


def test_a_short_demonstration_keeps_four_percent_of_its_length():
    demo, _ = _moves(12.0, seed=2)  # a handful of movements
    window = MultimodalSegmenter().fit(demo).result_.streams["position"].params["window"]
    assert window == round(AUTO_WINDOW_FRACTION * demo.n_steps)


@pytest.mark.parametrize("seed", [0, 5])
def test_the_window_and_the_cuts_per_minute_do_not_grow_with_the_recording(seed):
    whole, ends = _moves(1200.0, seed=seed)  # 20 minutes
    part = whole.slice(0, 300 * 200)
    full = segment(whole)
    excerpt = segment(part)
    w_full = full.streams["position"].params["window"]
    w_part = excerpt.streams["position"].params["window"]
    assert w_full < 0.005 * whole.n_steps  # set by the motion, not 4 % of 20 minutes
    assert abs(w_full - w_part) <= 0.1 * w_part
    # the same cuts in the first five minutes, to one window
    inside = full.keypoint_times[full.keypoint_times < 300.0 - w_full / 200.0]
    mine = excerpt.keypoint_times[excerpt.keypoint_times < 300.0 - w_full / 200.0]
    assert inside.size == mine.size
    np.testing.assert_allclose(inside, mine, atol=w_full / 200.0)
    # ... and as many per minute as the movements: every rest found, nothing else
    truth = ends[ends < 1190.0]
    found = full.keypoint_times
    matched = np.abs(found[:, None] - truth[None, :]).min(axis=0) < 0.5
    assert matched.mean() > 0.95
    assert found.size <= 1.05 * truth.size + 2


def _suppress_straightforward(positions, scores, *, min_size, n_steps):
    kept = []
    for k in np.argsort(-np.asarray(scores, dtype=float), kind="stable"):
        p = int(positions[k])
        if min_size <= p <= n_steps - min_size and all(abs(p - q) >= min_size for q in kept):
            kept.append(p)
    return sorted(kept)


@given(st.lists(st.tuples(st.integers(0, 500), st.integers(0, 5)), max_size=60), st.integers(1, 40))
def test_suppress_close_matches_the_straightforward_loop(events, min_size):
    positions = [p for p, _ in events]
    scores = [float(s) for _, s in events]  # ties broken by order, as the loop does
    got = suppress_close(positions, scores, min_size=min_size, n_steps=500).tolist()
    assert got == _suppress_straightforward(positions, scores, min_size=min_size, n_steps=500)


def _rest_events_straightforward(v, typical):
    """The rule of :func:`rest_events` as first written: every valley against every deeper one."""
    from scipy.signal import find_peaks

    from skillbank.segmentation._events import HALF_REST_RATIO, MAX_CONFIDENCE, MOVEMENT_FRACTION, REST_BAND

    n = v.shape[0]
    valleys, _ = find_peaks(-v, prominence=0.02 * typical)
    order = np.argsort(v[valleys], kind="stable")
    out = []
    for rank, k in enumerate(order):
        c = int(valleys[k])
        deeper = valleys[order[:rank]]
        left, right = deeper[deeper < c], deeper[deeper > c]
        lo = int(left.max()) if left.size else 0
        hi = int(right.min()) if right.size else n - 1
        side = min(float(v[lo:c + 1].max()), float(v[c:hi + 1].max()))
        if side < MOVEMENT_FRACTION * typical:
            continue
        mask = v[lo:hi + 1] <= v[c] + REST_BAND * (side - v[c])
        a = b = c - lo
        while a > 0 and mask[a - 1]:
            a -= 1
        while b < mask.size - 1 and mask[b + 1]:
            b += 1
        ratio = float(v[c]) / side
        out.append((lo + (a + b) // 2, MAX_CONFIDENCE / (1.0 + (ratio / HALF_REST_RATIO) ** 4), ratio))
    return sorted(out)


@given(st.integers(0, 10**6), st.integers(20, 400), st.sampled_from([0.0, 0.05, 0.3]))
def test_rest_events_match_the_straightforward_rule(seed, n, noise):
    from skillbank.segmentation._events import rest_events

    rng = np.random.default_rng(seed)
    v = np.abs(np.sin(np.cumsum(rng.uniform(0.0, 0.3, n)))) + noise * rng.random(n)
    v = np.round(v, 2)  # ties between valleys, and flat bottoms
    at, conf, ratio = rest_events(v, typical=1.0)
    want = _rest_events_straightforward(v, 1.0)
    assert at.tolist() == [w[0] for w in want]
    np.testing.assert_allclose(conf, [w[1] for w in want])
    np.testing.assert_allclose(ratio, [w[2] for w in want])


def test_a_clock_is_timed_as_finely_after_an_hour():
    from skillbank.segmentation._roundoff import CLOCK_SPAN, roundoff_level

    # stamps at full precision (no decimal grid), so the floor is what sets their level
    hour = np.linspace(0.0, 3600.0, 10**5) * np.pi / 3
    day = np.linspace(0.0, 86400.0, 10**5) * np.pi / 3
    # a value's floor follows its range; a clock's stops at an hour's, so the jerk's stride (and the cuts)
    # do not depend on how long the recording ran
    assert roundoff_level(day)[0] > roundoff_level(hour)[0]
    assert roundoff_level(day, span=CLOCK_SPAN)[0] == roundoff_level(hour, span=CLOCK_SPAN)[0]
