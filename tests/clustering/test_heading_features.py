"""HeadingFeatures: invariances, shapes and errors."""

from __future__ import annotations

import numpy as np
import pytest

import skillbank
from skillbank.clustering import HeadingFeatures, heading_directions


def _curve(n=60):
    t = np.linspace(0.0, 1.0, n)
    return np.column_stack([t, 0.3 * np.sin(np.pi * t), 0.2 * (1 - t) ** 2])


def _yaw(Y, angle):
    c, s = np.cos(angle), np.sin(angle)
    out = Y.copy()
    out[:, 0], out[:, 1] = c * Y[:, 0] - s * Y[:, 1], s * Y[:, 0] + c * Y[:, 1]
    return out


def test_directions_are_unit_and_canonical():
    U = heading_directions(_curve()[None])
    norms = np.linalg.norm(U, axis=2)
    assert np.allclose(norms, 1.0)
    # The straight segment from start to end points along +x once aligned.
    line = np.column_stack([np.zeros(5), np.linspace(0, 2, 5), np.zeros(5)])[None]
    assert np.allclose(heading_directions(line)[0], [1.0, 0.0, 0.0])


def test_zero_length_steps_stay_zero():
    Y = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0]])[None]
    assert heading_directions(Y)[0].tolist() == [[0.0, 0.0], [1.0, 0.0]]


@pytest.mark.parametrize("angle", [0.3, 1.7, -2.5])
def test_invariant_to_translation_yaw_scale_and_mirror(angle):
    Y = _curve()
    moved = 2.5 * _yaw(Y, angle) + np.array([0.4, -1.0, 0.3])
    mirrored = Y * np.array([1.0, -1.0, 1.0])
    U = heading_directions(np.stack([Y, moved, mirrored]))
    assert np.allclose(U[0], U[1], atol=1e-12)
    assert np.allclose(U[0], U[2], atol=1e-12)
    # Without mirroring the mirror image differs.
    assert not np.allclose(*heading_directions(np.stack([Y, mirrored]), mirror=False))


def test_vertical_motion_is_not_confused_with_horizontal():
    t = np.linspace(0.0, 1.0, 40)
    down = np.column_stack([t, 0 * t, 1 - t])
    flat = np.column_stack([t, 0 * t, 0 * t])
    U = heading_directions(np.stack([down, flat]))
    assert np.linalg.norm(U[0] - U[1], axis=1).min() > 0.5


def test_features_separate_two_kinds_and_transform_matches_fit_transform():
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 1.0, 80)
    down = [np.column_stack([a * t, b * t, 1 - t]) + rng.normal(0, 1e-3, (80, 3))
            for a, b in rng.uniform(0.2, 0.5, (6, 2))]
    flat = [np.column_stack([a * t, b * t ** 2, 0 * t]) + rng.normal(0, 1e-3, (80, 3))
            for a, b in rng.uniform(0.2, 0.5, (6, 2))]
    model = HeadingFeatures(n_points=12, n_components=2, random_state=0)
    F = model.fit_transform(down + flat)
    assert F.shape == (12, 2)
    assert np.allclose(model.transform(down + flat), F)
    gap = np.linalg.norm(F[:6].mean(axis=0) - F[6:].mean(axis=0))
    spread = max(np.linalg.norm(F[:6] - F[:6].mean(axis=0), axis=1).max(),
                 np.linalg.norm(F[6:] - F[6:].mean(axis=0), axis=1).max())
    assert gap > 3 * spread


def test_accepts_demonstrations_of_different_lengths_and_no_pca():
    a = skillbank.Demonstration.from_array(_curve(50))
    b = skillbank.Demonstration(np.linspace(0, 3, 70), {"position": _curve(70)})
    F = HeadingFeatures(n_points=10, n_components=None).fit_transform([a, b])
    assert F.shape == (2, 9 * 3)


def test_component_count_is_capped_by_the_data():
    F = HeadingFeatures(n_points=4, n_components=3).fit_transform([_curve(), _curve()[::-1]])
    assert F.shape == (2, 2)


@pytest.mark.parametrize(
    ("kwargs", "X", "match"),
    [
        ({"n_points": 1}, None, r"n_points: expected an integer >= 2, got 1"),
        ({"n_points": 2.5}, None, r"n_points: expected an integer > 0, got 2.5"),
        ({}, "single", r"X: expected at least 2 trajectories to fit the PCA, got 1"),
        ({}, [], r"X: expected at least one trajectory, got none"),
        ({}, "same", r"X: every trajectory has the same features \(to float64 precision\), so PCA has no "
                     r"variance to keep; pass n_components=None"),
    ],
)
def test_errors(kwargs, X, match):
    line = np.outer(np.linspace(0.0, 1.0, 30), [1.0, 0.0, 0.0])  # every unit step is exactly (1, 0, 0)
    named = {None: [_curve(), _curve() * 2], "single": [_curve()], "same": [line, 2.0 * line]}
    data = X if isinstance(X, list) else named[X]
    with pytest.raises(ValueError, match=match):
        HeadingFeatures(**kwargs).fit_transform(data)


def test_transform_checks_dimensions():
    model = HeadingFeatures(n_points=5, n_components=2).fit([_curve(), _curve() ** 2])
    with pytest.raises(ValueError, match=r"X: expected trajectories with 3 dimensions, got 2"):
        model.transform([_curve()[:, :2]])
