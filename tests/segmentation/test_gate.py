import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank import Demonstration
from skillbank.segmentation import gate_changepoints, segment

GATE = {"window": 16, "min_size": 40, "grace": 16, "stop_ratio": 0.5, "min_turn": 45.0}


def _gate(cps, t, Y, **kw):
    cps = np.asarray(cps, dtype=int)
    return gate_changepoints(cps, np.ones(cps.size), t, Y, **{**GATE, **kw})[0].tolist()


def _min_jerk(s):
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def test_reversal_kept_mid_motion_dropped():
    t = np.linspace(0.0, 2.0, 401)
    x = np.where(t < 1.0, np.sin(np.pi * t) ** 2, 0.0)[:, None]
    assert _gate([100, 150], t, x) == [100]


def test_constant_speed_corner_is_kept_in_place_by_its_turn():
    # no slowdown at all: only the change of direction marks the boundary
    n, k = 400, 173
    Y = np.zeros((n, 2))
    Y[:k + 1, 0] = np.arange(k + 1)
    Y[k:, 0] = k
    Y[k:, 1] = np.arange(n - k)
    t = np.arange(n, dtype=float)
    assert _gate([k], t, Y) == [k]
    # the same corner turned by only 20 degrees is a mid-motion event
    shallow = np.column_stack([np.arange(n), np.where(np.arange(n) > k, np.tan(np.radians(20)), 0.0)
                               * (np.arange(n) - k)])
    assert _gate([k], t, shallow) == []


def test_brief_stop_moves_the_changepoint_to_the_slowest_sample():
    # a pen that slows to almost nothing at sample 250 and turns there; the
    # jerk event was placed 25 samples late
    n, k = 500, 250
    t = np.arange(n, dtype=float)
    speed = 0.02 + np.minimum(np.abs(t - k) / 20.0, 1.0)
    s = np.concatenate(([0.0], np.cumsum(speed[1:])))
    Y = np.where((t <= k)[:, None], np.column_stack([s, 0 * s]),
                 np.column_stack([s[k] + 0 * s, s - s[k]]))
    assert int(np.argmin(np.linalg.norm(np.gradient(Y, t, axis=0), axis=1))) == k
    assert _gate([k + 25], t, Y) == [k]


def test_rest_keeps_the_event_where_the_motion_ends():
    # a reach, a long rest, another reach: the cut stays where the jerk put it
    n = 900
    t = np.linspace(0.0, 9.0, n)
    x = np.zeros(n)
    x[:300] = _min_jerk(np.linspace(0, 1, 300))
    x[300:600] = 1.0
    x[600:] = 1.0 + _min_jerk(np.linspace(0, 1, 300))
    Y = np.column_stack([x, 0.5 * x])
    assert _gate([310, 590], t, Y, window=30, min_size=100, grace=30) == [310, 590]


def test_held_step_stays_exact():
    n = 600
    t = np.linspace(0.0, 6.0, n)
    g = (np.arange(n) >= 300).astype(float)[:, None]
    assert _gate([300], t, g) == [300]


def test_mid_reach_events_of_a_minimum_jerk_reach_are_dropped():
    n = 600
    t = np.linspace(0.0, 6.0, n)
    s = np.concatenate([_min_jerk(np.linspace(0, 1, 300)), 1.0 + _min_jerk(np.linspace(0, 1, 300))])
    Y = np.column_stack([s, np.where(np.arange(n) < 300, 0.0, s - 1.0)])
    # 150 and 450 are the speed peaks of the two reaches; 300 is the stop between them
    assert _gate([150, 299, 450], t, Y) == [299]


def test_dropping_a_failing_neighbour_rescues_a_boundary():
    # two reaches with a shallow mid-reach slowdown in the first: comparing
    # the real stop only with the slowdown's side would fail it
    n = 800
    t = np.linspace(0.0, 8.0, n)
    first = _min_jerk(np.linspace(0, 1, 400))
    first = first + 0.01 * np.sin(np.linspace(0, 2 * np.pi, 400))
    s = np.concatenate([first, first[-1] + _min_jerk(np.linspace(0, 1, 400))])
    Y = s[:, None]
    assert _gate([200, 399], t, Y, min_size=80) == [400]


def test_gate_turns_the_r_bowl_events_off_but_not_the_corners(data_dir):
    import skillbank.io as sio

    demo = sio.read_handwriting_h5(data_dir / "seed" / "r_shape.h5", group="normalized", index=3)
    # the gate's own changepoints, as the paper's product rule uses them
    gated = segment(demo, window=16, min_size=64, threshold=0.16, combine="product")
    raw = segment(demo, window=16, min_size=64, threshold=0.16, stop_ratio=None, combine="product")
    assert gated.changepoints["position"].size == 2 < raw.changepoints["position"].size
    # both cuts sit at the letter's corners, its two deepest interior speed minima
    assert np.abs(gated.changepoints["position"] - [211, 629]).max() <= 2


def test_empty_input_and_stop_ratio_one():
    t = np.linspace(0.0, 1.0, 100)
    cps, strength = gate_changepoints(np.array([], dtype=int), np.array([]), t, np.zeros((100, 1)), **GATE)
    assert cps.size == 0 and strength.size == 0
    x = np.sin(np.linspace(0, 3, 100))[:, None]
    # with stop_ratio 1 both events pass as stops; both belong to the one stop,
    # the sine's turning point, so they become one cut there
    turning = int(np.argmin(np.abs(np.cos(np.linspace(0, 3, 100)))))
    assert _gate([30, 70], t, x, stop_ratio=1.0, min_size=20) == [turning] == [52]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"stop_ratio": 1.5}, r"stop_ratio: expected a number in \[0.0, 1.0\], got 1.5"),
        ({"stop_ratio": "x"}, r"stop_ratio: expected a number in \[0.0, 1.0\], got str"),
        ({"min_turn": 200.0}, r"min_turn: expected a number in \[0.0, 180.0\], got 200.0"),
        ({"stream_params": {"position": {"stop_ratio": -0.1}}}, r"stop_ratio: expected a number"),
    ],
)
def test_bad_gate_parameters(kwargs, match):
    demo = Demonstration.from_array(np.sin(np.linspace(0, 6, 600))[:, None], np.linspace(0, 1, 600))
    with pytest.raises(ValueError, match=match):
        segment(demo, **kwargs)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10**6), st.lists(st.integers(20, 580), min_size=1, max_size=8, unique=True))
def test_property_gate_only_keeps_or_moves_to_a_speed_minimum(seed, candidates):
    rng = np.random.default_rng(seed)
    n = 600
    t = np.linspace(0.0, 6.0, n)
    # a smooth random path: a few random sinusoids per dimension
    f = rng.uniform(0.2, 2.0, (3, 2))
    Y = np.column_stack([np.sin(f[k, 0] * t + f[k, 1]) for k in range(3)])
    cps = np.array(sorted(candidates))
    kept, strength = gate_changepoints(cps, np.arange(cps.size, dtype=float), t, Y, **GATE)
    assert kept.size == strength.size <= cps.size
    assert np.all(np.diff(kept) > 0)
    v = np.linalg.norm(np.gradient(Y, t, axis=0), axis=1)
    for c in kept:
        if c not in cps:
            # moved: it sits at a local minimum of the raw speed
            assert v[c] <= v[max(c - 1, 0)] and v[c] <= v[min(c + 1, n - 1)]
