"""The stitched-sequence generator and the scorer of benchmarks/bench_segmentation_quality.py."""

from __future__ import annotations

import importlib
import math
import sys
from pathlib import Path

import numpy as np
import pytest

_BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


@pytest.fixture(scope="module")
def bench():
    if str(_BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(_BENCHMARKS))
    return importlib.import_module("bench_segmentation_quality")


@pytest.fixture(scope="module")
def stitched():
    if str(_BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(_BENCHMARKS))
    return importlib.import_module("_stitched")


def _speed(demo):
    return np.linalg.norm(np.gradient(demo["position"], demo.t, axis=0), axis=1)


def test_generator_is_deterministic_per_seed(stitched, data_dir):
    kw = {"gripper": True, "force": True, "noise": 10e-6, "data": data_dir}
    a, ta = stitched.make_sequence(np.random.default_rng([7, 3]), **kw)
    b, tb = stitched.make_sequence(np.random.default_rng([7, 3]), **kw)
    c, _ = stitched.make_sequence(np.random.default_rng([7, 4]), **kw)
    np.testing.assert_array_equal(ta, tb)
    for name in ("position", "gripper", "force"):
        np.testing.assert_array_equal(a[name], b[name])
    assert a.metadata["labels"] == b.metadata["labels"]
    assert a.n_steps != c.n_steps or not np.array_equal(a["position"], c["position"])


@pytest.mark.parametrize("max_dwell", [None, 0.0])
def test_truth_lies_at_rest_and_in_order(stitched, data_dir, max_dwell):
    # without a dwell, only the time-warp brings the motion to rest at the junction
    kw = {} if max_dwell is None else {"max_dwell": max_dwell}
    for i in range(6):
        demo, truth = stitched.make_sequence(np.random.default_rng([11, i]), rate=300.0, data=data_dir, **kw)
        v = _speed(demo)
        assert 1 <= truth.size <= 4 and np.all(np.diff(truth) > 0)
        assert truth[0] > demo.t[0] and truth[-1] < demo.t[-1]
        at = np.abs(demo.t[:, None] - truth[None, :]).argmin(axis=0)
        assert np.all(v[at] < 1e-3 * v.max()), (i, v[at] / v.max())


def test_gripper_toggles_only_at_boundaries(stitched, data_dir):
    demo, truth = stitched.make_sequence(np.random.default_rng([5, 1]), gripper=True, n_primitives=4,
                                         data=data_dir)
    g = demo["gripper"][:, 0]
    assert set(np.unique(np.round(g))) <= {0.0, 1.0}
    moving = np.flatnonzero(np.abs(np.diff(g)) > 0)
    # every change of the gripper is within 0.3 s of a boundary
    assert moving.size > 0
    assert np.all(np.min(np.abs(demo.t[moving][:, None] - truth[None, :]), axis=1) < 0.3)


def test_suite_balances_the_conditions(stitched, data_dir):
    suite = stitched.make_suite(3, 12, data=data_dir)
    assert [c.index for c in suite] == list(range(12))
    for factor, levels in (("noise", stitched.NOISE_LEVELS), ("rate", stitched.RATES)):
        counts = [sum(c.conditions[factor] == lv for c in suite) for lv in levels]
        assert counts == [4, 4, 4], (factor, counts)
    assert sum(c.conditions["force"] for c in suite) == 6
    assert all(("force" in c.demo) == c.conditions["force"] for c in suite)


@pytest.mark.parametrize(
    ("pred", "truth", "expected"),
    [
        ([1.0, 2.0], [1.0, 2.0], (1.0, 1.0, 1.0, 0.0)),  # perfect
        ([1.0], [1.0, 2.0], (1.0, 0.5, 2 / 3, 0.0)),  # one miss
        ([1.0, 2.0, 3.0], [1.0, 2.0], (2 / 3, 1.0, 0.8, 0.0)),  # one extra
        ([1.0, 2.0 + 0.05], [1.0, 2.0], (1.0, 1.0, 1.0, 0.025)),  # within tolerance
        ([1.0, 2.15], [1.0, 2.0], (0.5, 0.5, 0.5, 0.0)),  # off by more than tol
        ([1.0, 1.01], [1.0], (0.5, 1.0, 2 / 3, 0.0)),  # one to one: a truth is matched once
        # nearest-first matching would pair 1.05 with 1.06 and leave two unmatched; the
        # assignment matches both, within 0.09 and 0.08
        ([1.05, 1.14], [0.96, 1.06], (1.0, 1.0, 1.0, 0.085)),
        ([], [1.0], (1.0, 0.0, 0.0, math.nan)),  # no prediction
        ([], [], (1.0, 1.0, 1.0, math.nan)),  # nothing to find, nothing found
    ],
)
def test_score_known_answers(bench, pred, truth, expected):
    got = bench.score(pred, truth, tol=0.1)
    np.testing.assert_allclose(got, expected, atol=1e-12)


def test_an_oracle_scores_one_on_two_primitives_with_a_long_dwell(bench, stitched, data_dir):
    demo, truth = stitched.make_sequence(np.random.default_rng([2, 0]), n_primitives=2, min_dwell=0.5,
                                         max_dwell=0.6, data=data_dir)

    def oracle(d):
        """The middles of the interior rests of 0.3 s or more, read from the positions alone."""
        rest = np.concatenate(([0], (np.linalg.norm(np.diff(d["position"], axis=0), axis=1) == 0), [0]))
        edges = np.flatnonzero(np.diff(rest.astype(int)))
        runs = [(a, b) for a, b in zip(edges[::2], edges[1::2], strict=True)
                if 0 < a and b < d.n_steps - 1 and d.t[b] - d.t[a] >= 0.3]
        return np.array([(d.t[a] + d.t[b]) / 2 for a, b in runs])

    case = stitched.Case(demo, truth, 2, 0, {"noise": 0.0, "rate": 300.0, "gripper": False,
                                             "force": False, "family": "mixed"})
    report = bench.evaluate(oracle, [case])
    assert truth.size == 1
    assert report["mean_f1"] == 1.0
    assert report["mean_error"] < 1 / 300
    assert report["seed_spread"]["min"] == report["seed_spread"]["max"] == 1.0
    assert report["by_condition"]["family"] == {"mixed": 1.0}
