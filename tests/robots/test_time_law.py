"""The time law of a joint path (skillbank.robots.time_law): limits met as the exports measure them, samples
kept, no slower than the uniform stretch, known answers, and every refusal."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.robots import STILL, TIME_LAWS, rate_ratio, time_law


@st.composite
def joint_paths(draw):
    """A smooth random joint path (sums of sines, random amplitudes and frequencies), a given uniform time
    base of a random duration, and per-joint limits."""
    n_joints = draw(st.integers(1, 7))
    n = draw(st.integers(50, 300))  # densely sampled, as reproductions are (see the coarse test below)
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, n)[:, None]
    amp = rng.uniform(-1.5, 1.5, (3, n_joints))
    freq = rng.uniform(0.2, 2.0, (3, n_joints))
    q = rng.uniform(-2.0, 2.0, n_joints) + sum(amp[k] * np.sin(np.pi * freq[k] * s + k) for k in range(3))
    duration = draw(st.floats(0.05, 10.0))
    velocity = rng.uniform(0.3, 4.0, n_joints)
    acceleration = rng.uniform(0.5, 10.0, n_joints)
    return q, duration * s[:, 0], velocity, acceleration


@settings(max_examples=60, deadline=None, derandomize=True)
@given(joint_paths())
def test_limits_met_exactly_samples_kept_and_no_slower_than_the_uniform_stretch(case):
    q, t, velocity, acceleration = case
    before = q.copy()
    uniform = time_law(q, velocity=velocity, acceleration=acceleration, t=t, law="uniform")
    for ends in ("given", "rest"):
        times = time_law(q, velocity=velocity, acceleration=acceleration, t=t, ends=ends)
        assert times[0] == 0.0 and (np.diff(times) > 0).all()
        # the tightest limit met exactly, as the exports measure it (finite differences and numpy.gradient)
        ratio = rate_ratio(times, q, velocity=velocity, acceleration=acceleration)
        assert ratio == pytest.approx(1.0, abs=1e-9) and ratio <= 1.0
    np.testing.assert_array_equal(q, before)  # the geometry is the samples, untouched
    # from the uniform stretch's boundary speeds, the fastest timing is no slower than it
    given_ends = time_law(q, velocity=velocity, acceleration=acceleration, t=t, ends="given")
    assert given_ends[-1] <= uniform[-1] * (1 + 1e-6)
    assert rate_ratio(uniform, q, velocity=velocity, acceleration=acceleration) <= 1.0


def test_a_straight_move_is_the_textbook_trapezoid():
    """1 rad at 1 rad/s and 2 rad/s^2 from rest to rest: 0.5 s speeding up, 0.5 s cruising, 0.5 s slowing
    down (1.5 s); the finite differences of 1001 samples see it to 1e-3 s."""
    q = np.linspace(0.0, 1.0, 1001)[:, None] * [1.0, -0.5, 0.25]
    times = time_law(q, velocity=[1.0, 1.0, 1.0], acceleration=2.0)
    assert times[-1] == pytest.approx(1.5, abs=1e-3)
    # the speed profile: from rest, 1 rad/s in the middle, back to rest
    v = np.diff(q[:, 0]) / np.diff(times)
    assert v[0] < 0.1 and v[-1] < 0.1 and v[len(v) // 2] == pytest.approx(1.0, abs=1e-6)


def test_a_stop_keeps_its_dwell_and_both_sides_start_and_end_at_rest():
    q = np.r_[np.linspace(0.0, 1.0, 200), np.ones(50), np.linspace(1.0, 0.0, 200)[1:]][:, None]
    t = np.linspace(0.0, 3.0, len(q))
    times = time_law(q, velocity=2.0, acceleration=4.0, t=t)
    still = np.flatnonzero(np.diff(q[:, 0]) == 0.0)
    np.testing.assert_allclose(np.diff(times)[still], np.diff(t)[still], rtol=1e-12)
    # each move alone: a triangle (1 rad at 4 rad/s^2 peaks at 2 rad/s), 1 s
    moving = times[still[0]] - times[0]
    assert moving == pytest.approx(1.0, abs=2e-2)


def test_the_uniform_law_only_stretches():
    q = np.linspace(0.0, 1.0, 50)[:, None]
    t = np.linspace(0.0, 10.0, 50)
    np.testing.assert_array_equal(time_law(q, velocity=1.0, t=t, law="uniform"), t)  # already within
    fast = time_law(q, velocity=1.0, t=t / 100.0, law="uniform")
    assert fast[-1] == pytest.approx(1.0, rel=1e-9) and TIME_LAWS == ("toppra", "uniform")


@pytest.mark.parametrize("kwargs, match", [
    ({"joints": [[0.0, 1.0]], "velocity": 1.0},
     r"^joints: a time law needs at least 2 samples, got 1 \(one configuration has no motion to time\)$"),
    ({"joints": [[0.0], [np.nan]], "velocity": 1.0}, r"^joints: expected finite values"),
    ({"joints": [[0.0], [np.inf]], "velocity": 1.0}, r"^joints: expected finite values"),
    ({"joints": [0.0, 1.0], "velocity": 1.0}, r"^joints: expected a 2-D array, got 1-D"),
    ({"joints": [[0.0], [1.0]]},
     r"^velocity, acceleration: expected at least one limit .*robot\.rate_limits"),
    ({"joints": [[0.0], [1.0]], "velocity": 0.0},
     r"^velocity: expected limits in \[1e-09, 1e\+09\] per joint \(rad/s or rad/s\^2\), got \[0\.0\]$"),
    ({"joints": [[0.0], [1.0]], "velocity": -1.0}, r"^velocity: expected limits in \[1e-09, 1e\+09\]"),
    ({"joints": [[0.0], [1.0]], "acceleration": np.nan}, r"^acceleration: expected finite values"),
    ({"joints": [[0.0, 0.0], [1.0, 1.0]], "velocity": [1.0, 2.0, 3.0]},
     r"^velocity: expected one number, or one per joint \(2\), got 3$"),
    ({"joints": [[0.0], [1.0]], "velocity": 1.0, "law": "trapezoid"},
     r"^law: expected one of \['toppra', 'uniform'\], got 'trapezoid'$"),
    ({"joints": [[0.0], [1.0]], "velocity": 1.0, "law": "uniform"},
     r"^t: the uniform law stretches a given time base; give t$"),
    ({"joints": [[0.0], [1.0]], "velocity": 1.0, "ends": "given"},
     r"^t: ends='given' starts and ends as a given time base; give t$"),
    ({"joints": [[0.0], [1.0]], "velocity": 1.0, "ends": "moving"}, r"^ends: expected 'rest' or 'given'"),
    ({"joints": [[0.0], [1.0]], "velocity": 1.0, "t": [0.0, 0.0]}, r"^t: expected strictly increasing time"),
    ({"joints": [[0.0], [1.0]], "velocity": 1.0, "t": [0.0, 1.0, 2.0]},
     r"^t: expected 2 samples to match the data, got 3$"),
    ({"joints": [[1.0], [1.0], [1.0]], "velocity": 1.0, "t": [0.0, 1.0, 2.0]},
     rf"^joints: every sample is the same configuration \(no step above {STILL:g} rad\)"),
    ({"joints": [[0.0], [1.0], [1.0]], "velocity": 1.0},
     r"^joints: samples 1 and 2 are the same configuration \(a stop\): give t, whose dwell the stop keeps$"),
])
def test_refusals_say_what_to_do(kwargs, match):
    with pytest.raises(ValueError, match=match):
        time_law(**kwargs)


def test_make_executable_times_a_joint_trajectory_with_the_law_by_default():
    """The law's duration, not the uniform stretch's, and the same samples in both."""
    from skillbank import Constraints, Demonstration
    from skillbank.core import exp_map
    from skillbank.robots import UR5e, tool_point
    from skillbank.selection import make_executable

    s = np.linspace(0.0, 1.0, 120)
    P = np.c_[0.4 + 0.1 * s, -0.2 + 0.2 * s, 0.3 - 0.05 * np.sin(np.pi * s)]
    Q = exp_map(np.c_[0 * s, 0 * s, 0.8 * s], reference=[1.0, 0.0, 0.0, 0.0])
    source = Demonstration(0.2 * s, {"position": P, "orientation": Q}, {"pose_of": tool_point(UR5e())})
    out = Demonstration(0.2 * s, {"position": P})
    law = make_executable(out, [source], Constraints(), robot="ur5e")
    uniform = make_executable(out, [source], Constraints(), robot="ur5e", time_law="uniform")
    assert law.trajectory.metadata["timing"]["law"] == "toppra"
    assert uniform.trajectory.metadata["timing"]["law"] == "uniform"
    assert law.trajectory.t[-1] < uniform.trajectory.t[-1]
    for name in ("position", "orientation", "joints"):
        np.testing.assert_array_equal(law.trajectory[name], uniform.trajectory[name])
    assert any(n.startswith("time law toppra (TOPP-RA, path kept)") for n in law.notes)
    with pytest.raises(ValueError, match=r"^time_law: expected one of \['toppra', 'uniform'\], got 'x'$"):
        make_executable(out, [source], Constraints(), robot="ur5e", time_law="x")
    # a time base given as stamps is strict under either law
    for time_law_name in TIME_LAWS:
        with pytest.raises(ValueError, match=r"^limits: joint_.* cannot be met on the 0\.2 s time base"):
            make_executable(out, [source], Constraints(), robot="ur5e", fixed_time=True,
                            time_law=time_law_name)
