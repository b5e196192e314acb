"""Orientation geometry (issue 14): the quaternion validator, continuity, SLERP, log / exp maps, conversions.

scipy's ``Rotation`` and ``Slerp`` are the reference implementations the numpy ones are checked against.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation, Slerp

from skillbank.core import (
    check_quaternions,
    continuous_quaternions,
    exp_map,
    log_map,
    matrix_to_quaternion,
    quaternion_angle,
    quaternion_to_matrix,
    slerp,
)
from skillbank.core._rotations import UNIT_TOLERANCE, quaternion_multiply


def _random_quaternions(n, seed=0):
    return Rotation.random(n, random_state=seed).as_quat()


def _same_rotation(p, q, atol=1e-12):
    """Equal up to the sign q ~ -q, sample by sample."""
    return np.allclose(np.abs(np.sum(p * q, axis=-1)), 1.0, rtol=0.0, atol=atol)


# ------------------------------------------------------------------ the validator


def test_check_quaternions_known_answers():
    s = np.sqrt(0.5)
    q = check_quaternions([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, s, s]])
    assert q.shape == (2, 4) and q.dtype == np.float64
    # scalar-first (w, x, y, z) comes back scalar-last
    assert check_quaternions([[s, 0.0, 0.0, s]], scalar_first=True).tolist() == [[0.0, 0.0, s, s]]
    # within the tolerance: renormalised to norm 1 exactly (to round-off)
    q = check_quaternions([0.0, 0.0, 0.0, 1.005])
    assert q.tolist() == [0.0, 0.0, 0.0, 1.0]


@pytest.mark.parametrize("value, match", [
    ([[0, 0, 0, 1], [0, 0, 0, 0]], r"quaternions: expected unit quaternions .* got zero norm at sample 1"),
    ([[0, 0, 0, 1], [0, 0, 1, 1], [0, 0, 2, 0]],
     r"quaternions: expected unit quaternions \(norm within 0\.01 of 1\), got norm 1\.41421 at sample 1 "
     r"\(2 such samples: 1, 2\)"),
    ([0.0, 0.0, 0.0, 0.5], r"quaternions: expected unit quaternions .* got norm 0\.5 at the quaternion"),
    ([[0, 0, 1]], r"quaternions: expected quaternions of 4 components \(x, y, z, w\), got shape \(1, 3\)"),
    ([[[0, 0, 0, 1]]], r"quaternions: expected a 1-D or 2-D array, got 3-D"),
    ([[0, 0, 0, np.nan]], r"quaternions: expected finite values, got 1 non-finite value\(s\) \(NaN"),
    ([[0, 0, 0, np.inf]], r"quaternions: expected finite values"),
    ([[0, 0, 0, 1 + 0j]], r"quaternions: expected real numbers, got complex values"),
    ([["a", 0, 0, 1]], r"quaternions: expected an array of real numbers"),
])
def test_check_quaternions_rejects(value, match):
    with pytest.raises(ValueError, match=match):
        check_quaternions(value)


def test_check_quaternions_names_the_argument_and_checks_the_tolerance():
    with pytest.raises(ValueError, match=r"^goal_orientation: expected unit quaternions"):
        check_quaternions([0.0, 0.0, 0.0, 2.0], name="goal_orientation")
    with pytest.raises(ValueError, match=r"tolerance: expected a number in \[0\.0, 0\.5\], got 2"):
        check_quaternions([0.0, 0.0, 0.0, 1.0], tolerance=2)
    assert check_quaternions([0.0, 0.0, 0.0, 1.2], tolerance=0.25).tolist() == [0.0, 0.0, 0.0, 1.0]


_FOUR = arrays(np.float64, (4,), elements=st.floats(-3.0, 3.0, allow_nan=False))


@settings(max_examples=200, deadline=None)
@given(q=_FOUR, scalar_first=st.booleans())
def test_property_check_quaternions_accepts_exactly_the_unit_ones(q, scalar_first):
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > UNIT_TOLERANCE:
        with pytest.raises(ValueError, match=r"^quaternions: expected unit quaternions \(norm within"):
            check_quaternions(q, scalar_first=scalar_first)
        return
    out = check_quaternions(q, scalar_first=scalar_first)
    expected = np.roll(q, -1) if scalar_first else q
    np.testing.assert_allclose(out, expected / norm, rtol=0, atol=1e-15)
    assert abs(np.linalg.norm(out) - 1.0) < 1e-15


@settings(max_examples=100, deadline=None)
@given(q=arrays(np.float64, st.tuples(st.integers(1, 6), st.just(4)),
                elements=st.floats(-1.0, 1.0, allow_nan=False)),
       bad=st.sampled_from([np.nan, np.inf, -np.inf]), where=st.integers(0, 23))
def test_property_check_quaternions_rejects_any_non_finite_component(q, bad, where):
    q = q.copy()
    q.flat[where % q.size] = bad
    with pytest.raises(ValueError, match=r"^quaternions: expected finite values"):
        check_quaternions(q)


@settings(max_examples=100, deadline=None)
@given(unit=st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=4, max_size=4).filter(
    lambda v: np.linalg.norm(v) > 0.1), n=st.integers(2, 5), row=st.integers(0, 4))
def test_property_check_quaternions_names_the_first_bad_sample(unit, n, row):
    q = np.tile(np.array(unit) / np.linalg.norm(unit), (n, 1))
    row = row % n
    q[row] *= 1.5
    with pytest.raises(ValueError, match=rf"got norm 1\.5 at sample {row} \(1 such samples: {row}\)"):
        check_quaternions(q)


# ------------------------------------------------------------------ continuity


def test_continuous_quaternions_undoes_random_sign_flips():
    rng = np.random.default_rng(3)
    # a slow rotation, sampled finely: consecutive samples are close, so the right signs are obvious
    truth = Rotation.from_rotvec(np.linspace(0, 1, 200)[:, None] * [0.0, 2.0, 5.0]).as_quat()
    signs = rng.choice([-1.0, 1.0], size=200)
    signs[0] = 1.0
    out = continuous_quaternions(truth * signs[:, None])
    np.testing.assert_array_equal(out, truth)
    assert np.all(np.sum(out[1:] * out[:-1], axis=1) >= 0)


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 30))
def test_property_continuous_quaternions_keeps_rotations_and_makes_dots_non_negative(seed, n):
    q = _random_quaternions(n, seed)
    out = continuous_quaternions(q)
    assert np.array_equal(np.abs(out), np.abs(q)) and np.array_equal(out[0], q[0])
    assert np.all(np.sum(out[1:] * out[:-1], axis=1) >= 0)


# ------------------------------------------------------------------ SLERP


def test_slerp_matches_scipy_and_holds_the_edges():
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.1, 1.0, 12))
    q = _random_quaternions(12, seed=4) * rng.choice([-1.0, 1.0], size=(12, 1))  # signs as recorded
    t_new = np.linspace(t[0], t[-1], 301)
    out = slerp(t, q, t_new)
    reference = Slerp(t, Rotation.from_quat(q))(t_new).as_quat()
    assert _same_rotation(out, reference, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0, atol=1e-15)
    assert np.all(np.sum(out[1:] * out[:-1], axis=1) > 0)  # continuous although the input flips sign
    # the samples themselves come back, and outside the time range the edges are held
    assert _same_rotation(slerp(t, q, t), q)
    assert _same_rotation(slerp(t, q, [t[0] - 5.0, t[-1] + 5.0]), q[[0, -1]])


def test_slerp_turns_at_a_constant_rate_about_one_axis():
    q = Rotation.from_rotvec([[0.0, 0.0, 0.0], [0.0, 0.0, 2.0]]).as_quat()
    out = slerp([0.0, 1.0], q, [0.0, 0.25, 0.5, 1.0])
    np.testing.assert_allclose(Rotation.from_quat(out).as_rotvec(), [[0, 0, 0], [0, 0, 0.5], [0, 0, 1.0],
                                                                     [0, 0, 2.0]], atol=1e-15)
    # a recorded sign flip is not a 360-degree turn: the interpolation takes the short way
    flipped = np.array([q[0], -q[1]])
    np.testing.assert_allclose(quaternion_angle(slerp([0.0, 1.0], flipped, [0.5]), out[2:3]), 0.0, atol=1e-15)


def test_slerp_of_one_sample_and_bad_input():
    assert slerp([2.0], [[0, 0, 0, 1.0]], [0.0, 5.0]).tolist() == [[0, 0, 0, 1.0]] * 2
    with pytest.raises(ValueError, match=r"t: expected 2 samples to match the data, got 3"):
        slerp([0.0, 1.0, 2.0], [[0, 0, 0, 1.0]] * 2, [0.5])
    with pytest.raises(ValueError, match=r"t: expected strictly increasing time"):
        slerp([0.0, 0.0], [[0, 0, 0, 1.0]] * 2, [0.5])
    with pytest.raises(ValueError, match=r"q: expected an orientation stream of shape \(n, 4\), got"):
        slerp([0.0], [0, 0, 0, 1.0], [0.5])
    with pytest.raises(ValueError, match=r"t_new: expected finite values"):
        slerp([0.0, 1.0], [[0, 0, 0, 1.0]] * 2, [np.nan])
    with pytest.raises(ValueError, match=r"q: expected unit quaternions"):
        slerp([0.0, 1.0], [[0, 0, 0, 1.0], [0, 0, 0, 3.0]], [0.5])


# ------------------------------------------------------------------ log / exp maps


def test_log_map_matches_scipy_rotvec_and_exp_inverts_it():
    q = _random_quaternions(500, seed=5)
    v = log_map(q)
    np.testing.assert_allclose(v, Rotation.from_quat(q).as_rotvec(), atol=1e-13)
    assert np.all(np.linalg.norm(v, axis=1) <= np.pi + 1e-15)
    assert _same_rotation(exp_map(v), q)
    assert _same_rotation(exp_map(log_map(-q)), q)  # -q is the same rotation: the same vector


def test_log_and_exp_relative_to_a_reference():
    q = _random_quaternions(100, seed=6)
    ref = _random_quaternions(100, seed=7)
    v = log_map(q, ref)
    # the rotation vector of ref^-1 q, in the reference's (body) frame
    expected = (Rotation.from_quat(ref).inv() * Rotation.from_quat(q)).as_rotvec()
    np.testing.assert_allclose(v, expected, atol=1e-13)
    assert _same_rotation(exp_map(v, ref), q)
    # one reference for every sample
    assert _same_rotation(exp_map(log_map(q, ref[0]), ref[0]), q)
    assert _same_rotation(quaternion_multiply(ref, exp_map(v)), q)


def test_log_and_exp_are_exact_for_tiny_and_half_turn_angles():
    for angle in (0.0, 1e-300, 1e-12, 1e-8, 3e-8, 1e-4, np.pi - 1e-9, np.pi):
        v = np.array([angle, 0.0, 0.0])
        q = exp_map(v)
        expected = [np.sin(angle / 2), 0.0, 0.0, np.cos(angle / 2)]
        np.testing.assert_allclose(q, expected, rtol=1e-15, atol=1e-300)
        np.testing.assert_allclose(log_map(q), v, rtol=1e-14, atol=0)


def test_exp_map_rejects_bad_vectors():
    with pytest.raises(ValueError, match=r"v: expected rotation vectors of 3 components, got shape \(2, 4\)"):
        exp_map(np.zeros((2, 4)))
    with pytest.raises(ValueError, match=r"reference: expected unit quaternions"):
        exp_map([0.0, 0.0, 0.1], reference=[0.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"^q: expected unit quaternions"):
        log_map([1.0, 1.0, 1.0, 1.0])


# ------------------------------------------------------------------ conversions and angles


def test_matrix_conversions_match_scipy_including_half_turns():
    q = np.concatenate([
        _random_quaternions(1000, seed=8),
        # half turns about each axis and about diagonals: w = 0, where the largest component is x, y or z
        Rotation.from_rotvec(np.pi * np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0] / np.sqrt(2),
                                               [0, 1, 1] / np.sqrt(2), [1, 1, 1] / np.sqrt(3)])).as_quat(),
    ])
    R = quaternion_to_matrix(q)
    np.testing.assert_allclose(R, Rotation.from_quat(q).as_matrix(), atol=1e-15)
    back = matrix_to_quaternion(R)
    assert _same_rotation(back, q, atol=1e-15) and np.all(back[:, 3] >= 0)
    np.testing.assert_allclose(np.linalg.norm(back, axis=1), 1.0, atol=1e-15)


def test_quaternion_angle_matches_scipy_and_resolves_tiny_angles():
    p, q = _random_quaternions(300, seed=9), _random_quaternions(300, seed=10)
    expected = (Rotation.from_quat(p).inv() * Rotation.from_quat(q)).magnitude()
    np.testing.assert_allclose(quaternion_angle(p, q), expected, atol=1e-13)
    np.testing.assert_allclose(quaternion_angle(p, -p), 0.0, atol=0)
    tiny = exp_map([1e-10, 0.0, 0.0])
    assert quaternion_angle([0.0, 0.0, 0.0, 1.0], tiny) == pytest.approx(1e-10, rel=1e-12)
