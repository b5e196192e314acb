"""The one resampler: each trajectory resampled as on its own, wherever it stands in a batch."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.core import resample_many


def _progress(Y, t, by):
    if by == "time":
        return (t - t[0]) / (t[-1] - t[0])
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(Y, axis=0), axis=1))]
    return s / s[-1]


def _reference(Y, t, n, by):
    """Straightforward: np.interp of each coordinate on the trajectory's own progress."""
    p = _progress(Y, t, by)
    return np.column_stack([np.interp(np.linspace(0.0, 1.0, n), p, Y[:, d]) for d in range(Y.shape[1])])


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_trajs=st.integers(2, 40), dims=st.integers(1, 4),
       n_points=st.integers(2, 30), by=st.sampled_from(["time", "arc_length"]),
       scale=st.sampled_from([1e-6, 1.0, 1e6]))
def test_a_trajectory_resamples_to_the_same_bits_anywhere_in_a_batch(seed, n_trajs, dims, n_points, by,
                                                                     scale):
    rng = np.random.default_rng(seed)
    trajs = [scale * np.cumsum(rng.normal(size=(rng.integers(2, 60), dims)), axis=0) for _ in range(n_trajs)]
    times = [np.cumsum(rng.uniform(0.1, 2.0, len(Y))) + rng.uniform(-1e3, 1e3) for Y in trajs]
    where = rng.integers(1, n_trajs)
    trajs[where], times[where] = trajs[0].copy(), times[0].copy()  # the first one again, further on
    R = resample_many(trajs, times, n_points, by)
    alone = resample_many(trajs[:1], times[:1], n_points, by)[0]
    np.testing.assert_array_equal(R[where], R[0])
    np.testing.assert_array_equal(R[0], alone)
    for Y, t, got in zip(trajs, times, R, strict=True):
        np.testing.assert_allclose(got, _reference(Y, t, n_points, by), rtol=1e-12, atol=1e-12 * scale)


@pytest.mark.parametrize("by", ["time", "arc_length"])
def test_a_short_path_after_long_ones_keeps_its_precision(by):
    """After 2,000 long random walks a 3-sample path's progress is its own, to the last bits."""
    rng = np.random.default_rng(4)
    long = [np.cumsum(rng.normal(size=(500, 3)), axis=0) * 100.0 for _ in range(2000)]
    short = np.array([[0.0, 0.0, 0.0], [1e-3, 0.0, 0.0], [1e-3, 3e-3, 0.0]])
    trajs = [*long, short]
    times = [np.arange(len(Y), dtype=float) for Y in trajs]
    got = resample_many(trajs, times, 5, by)[-1]
    np.testing.assert_allclose(got, _reference(short, times[-1], 5, by), rtol=0, atol=1e-18)
