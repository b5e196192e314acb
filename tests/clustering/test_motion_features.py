"""MotionFeatures: how slow steps count, and its parameter checks."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.clustering import MotionFeatures


def _line_with_hook(n=200, hook=+1.0, dims=2):
    """A straight stroke that comes to rest, then creeps 1 % of its length sideways (a pen settling)."""
    s = np.linspace(0.0, 1.0, n)
    move = np.clip(s / 0.8, 0.0, 1.0)
    Y = np.zeros((n, dims))
    Y[:, 0] = move
    Y[:, 1] = hook * 0.01 * np.clip((s - 0.8) / 0.2, 0.0, 1.0)
    return Y


@pytest.mark.parametrize("slow_steps", ["auto", "weighted"])
def test_a_hook_at_the_end_of_a_drawing_counts_little(slow_steps):
    left, right = _line_with_hook(hook=+1.0), _line_with_hook(hook=-1.0)
    model = MotionFeatures(n_points=16, slow_steps=slow_steps)
    F = model.fit_transform([left, right])
    unit = MotionFeatures(n_points=16, slow_steps="unit").fit_transform([left, right])
    # counted in full, the 3 slow steps of opposite hooks are unit vectors apart; weighted, far less
    assert np.linalg.norm(F[0] - F[1]) < 0.5 * np.linalg.norm(unit[0] - unit[1])


def test_auto_keeps_a_robots_slow_phase_in_full():
    # in 3-D the slow phase (creeping in contact) is part of the skill: "auto" counts it as "unit" does
    left, right = _line_with_hook(dims=3, hook=+1.0), _line_with_hook(dims=3, hook=-1.0)
    auto = MotionFeatures(n_points=16, mirror=False).fit_transform([left, right])
    unit = MotionFeatures(n_points=16, mirror=False, slow_steps="unit").fit_transform([left, right])
    np.testing.assert_allclose(auto, unit)


def test_a_trajectory_that_never_moves_keeps_finite_features():
    F = MotionFeatures(n_points=8).fit_transform([np.zeros((20, 2)), _line_with_hook()])
    assert np.all(np.isfinite(F))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"slow_steps": "fast"}, r"slow_steps: expected 'auto', 'weighted' or 'unit', got 'fast'"),
        ({"mirror": "yes"}, r"mirror: expected 'auto', True or False, got 'yes'"),
    ],
)
def test_parameter_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        MotionFeatures(**kwargs).fit_transform([_line_with_hook(), _line_with_hook(hook=-1.0)])
