"""The vectorised segmentation matches the per-sample loop baseline of benchmarks/."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.io import read_handwriting_h5, read_robot_h5
from skillbank.segmentation import segment

_BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"

# the profiles are in [0, 1]; where a stream is at rest they are ~1e-14 and the
# cumulative-sum window mean differs from the explicit sum by round-off there,
# hence a tiny absolute tolerance next to the relative one
RTOL, ATOL = 1e-9, 1e-12


@pytest.fixture(scope="module")
def loop():
    if str(_BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(_BENCHMARKS))
    return importlib.import_module("_loop_segmentation")


def _min_jerk_path(t, waypoints):
    """Rest-to-rest minimum-jerk moves through ``waypoints``, equal time per move."""
    s = (t - t[0]) / (t[-1] - t[0]) * (len(waypoints) - 1)
    k = np.minimum(s.astype(int), len(waypoints) - 2)
    tau = s - k
    blend = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    return waypoints[k] + blend[:, None] * (waypoints[k + 1] - waypoints[k])


def _synthetic_demo(n=600, seed=0):
    rng = np.random.default_rng(seed)
    dt = 0.01 * (1.0 + 0.2 * rng.uniform(-1.0, 1.0, n - 1))
    t = np.concatenate(([0.0], np.cumsum(dt)))
    position = _min_jerk_path(t, rng.normal(size=(5, 3)))
    position += 0.01 * np.sin(2 * np.pi * 0.3 * t)[:, None] * np.array([1.0, -0.5, 0.2])
    centre = t[-1] / 2
    force = np.column_stack([np.tanh((t - centre) / 0.15), 0.5 * np.tanh((t - 0.25 * t[-1]) / 0.2)])
    force += 0.05 * np.cos(2 * np.pi * 0.2 * t)[:, None]
    gripper = 0.04 / (1.0 + np.exp(-(t - 0.75 * t[-1]) / 0.1))
    return Demonstration(t, {"position": position, "force": force, "gripper": gripper})


def _assert_same(fast, slow, streams):
    for name in streams:
        np.testing.assert_allclose(fast.streams[name].profile, slow.profiles[name], rtol=RTOL, atol=ATOL)
        np.testing.assert_array_equal(fast.streams[name].changepoints, slow.changepoints[name])
    np.testing.assert_array_equal(fast.keypoints, slow.keypoints)


def test_loop_gradient_matches_numpy(loop):
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.5, 1.5, 50))
    f = np.sin(t) + rng.normal(scale=0.1, size=50)
    for edge_order in (1, 2):
        expected = np.gradient(f, t, edge_order=edge_order)
        np.testing.assert_allclose(loop.loop_gradient(list(t), list(f), edge_order), expected, rtol=1e-12)
    uniform = np.arange(50.0)
    np.testing.assert_allclose(loop.loop_gradient(list(uniform), list(f)),
                               np.gradient(f, uniform, edge_order=2), rtol=1e-12)


def test_synthetic_multistream_matches_loop(loop):
    demo = _synthetic_demo()
    streams = ["position", "force", "gripper"]
    fast = segment(demo, streams, combine="product")
    slow = loop.loop_segment(demo, streams)
    assert sum(len(c) for c in slow.changepoints.values()) >= 3  # the comparison is not vacuous
    assert len(slow.keypoints) >= 1
    _assert_same(fast, slow, streams)


def test_synthetic_explicit_params_match_loop(loop):
    demo = _synthetic_demo(seed=3)
    params = {"window": 16, "min_size": 30, "threshold": 0.3, "grace": 10, "scale": "absolute",
              "normalize": "max"}
    fast = segment(demo, ["position", "force"], combine="product", **params)
    slow = loop.loop_segment(demo, ["position", "force"], **params)
    _assert_same(fast, slow, ["position", "force"])


def test_copy_with_few_digits_matches_loop(loop):
    # 8 significant digits on a 1 ms grid: both differentiate over the same stride of samples
    rng = np.random.default_rng(0)
    t = np.arange(3000) * 1e-3
    position = _min_jerk_path(t, rng.normal(size=(6, 3))) + 0.01 * np.sin(2 * np.pi * 0.3 * t)[:, None]
    demo = Demonstration(t, {"position": np.array([[float(f"{v:.8g}") for v in row] for row in position])})
    fast = segment(demo, combine="product")
    slow = loop.loop_segment(demo)
    assert fast.streams["position"].jerk_step == slow.steps["position"] > 1
    np.testing.assert_allclose(fast.streams["position"].jerk, slow.raw["position"], rtol=RTOL)
    assert len(slow.keypoints) >= 3
    _assert_same(fast, slow, ["position"])


def test_loop_strided_gradient_matches_numpy_on_the_subsampled_grid(loop):
    # where the stride fits, a stride-h difference is np.gradient on every h-th sample
    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.5, 1.5, 60))
    f = np.sin(t)
    got = loop.loop_strided_gradient(list(t), list(f), 3)
    np.testing.assert_allclose(got[3:-3:3], np.gradient(f[::3], t[::3])[1:-1], rtol=1e-12)
    np.testing.assert_allclose(loop.loop_strided_gradient(list(t), list(f), 1)[1:-1],
                               np.gradient(f, t)[1:-1], rtol=1e-12)


def test_r_demo_3_matches_loop(loop, data_dir):
    demo = read_handwriting_h5(data_dir / "seed" / "r_shape.h5", group="normalized")[3]
    fast = segment(demo, combine="product")
    slow = loop.loop_segment(demo)
    assert len(slow.keypoints) >= 1
    _assert_same(fast, slow, demo.stream_names)


def test_three_button_matches_loop(loop, data_dir):
    demo = read_robot_h5(data_dir / "seed" / "three_button_pressing_demo.h5")
    streams = ["joints", "position", "force", "gripper"]
    fast = segment(demo, streams, combine="product")
    slow = loop.loop_segment(demo, streams)
    for name in streams:
        np.testing.assert_array_equal(fast.streams[name].changepoints, slow.changepoints[name])
        np.testing.assert_allclose(fast.streams[name].jerk, slow.raw[name], rtol=RTOL)
    np.testing.assert_array_equal(fast.keypoints, slow.keypoints)
    for name in ["joints", "position", "force"]:
        np.testing.assert_allclose(fast.streams[name].profile, slow.profiles[name], rtol=RTOL, atol=ATOL)
    # gripper: its "typical speed" is round-off (~2e-12), so its relative jerk spans ~1e19 and the
    # cumulative-sum window mean is only accurate to ~1e4 absolute; round-off ripples then change
    # which local maxima the robust scale (median of the five highest) sees. Same shape, other scale.
    f, s = fast.streams["gripper"].profile, slow.profiles["gripper"]
    np.testing.assert_allclose(f * (s.max() / f.max()), s, rtol=1e-6, atol=ATOL)
