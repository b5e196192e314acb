"""The joint a part moves about, found from its poses (skillbank.core.fit_joint)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skillbank.core import Joint, fit_joint
from skillbank.core._rotations import exp_map, quaternion_multiply, quaternion_to_matrix

unit = st.tuples(*[st.floats(-1, 1)] * 3).map(np.array).filter(lambda v: np.linalg.norm(v) > 0.2).map(
    lambda v: v / np.linalg.norm(v))
point = st.tuples(*[st.floats(-1, 1)] * 3).map(np.array)


def _turned(axis, centre, angles, start_p, start_q):
    turn = exp_map(np.asarray(angles)[:, None] * axis)
    p = np.einsum("nij,j->ni", quaternion_to_matrix(turn), start_p - centre) + centre
    return p, quaternion_multiply(turn, np.broadcast_to(start_q, turn.shape))


def _off_line(joint, axis, centre):
    """The distance (m) from the fitted point to the true line."""
    d = joint.point - centre
    return float(np.linalg.norm(d - (d @ axis) * axis))


@given(axis=unit, centre=point, lever=point, sweep=st.floats(0.2, 2.0), seed=st.integers(0, 2 ** 16))
def test_a_turn_about_a_line_is_found_with_its_axis_point_and_angles(axis, centre, lever, sweep, seed):
    rng = np.random.default_rng(seed)
    angles = np.sort(rng.uniform(0, sweep, 30))
    angles[0] = 0.0
    start_q = exp_map(rng.normal(size=3))
    p, q = _turned(axis, centre, angles, centre + lever, start_q)
    j = fit_joint(p, q)
    assert j.kind == "revolute"
    assert abs(j.axis @ axis) > 1 - 1e-6
    assert _off_line(j, axis, centre) < 1e-6
    assert np.allclose(j.values * np.sign(j.axis @ axis), angles, atol=1e-6)
    assert j.residual < 1e-6
    moved_p, moved_q = j.move(p[0], q[0], j.values[-1])
    assert np.allclose(moved_p, p[-1], atol=1e-6)
    assert min(np.abs(moved_q - q[-1]).max(), np.abs(moved_q + q[-1]).max()) < 1e-6


@given(axis=unit, start=point, travel=st.floats(0.02, 0.5), seed=st.integers(0, 2 ** 16))
def test_a_slide_along_an_axis_is_found_with_its_direction_and_travel(axis, start, travel, seed):
    rng = np.random.default_rng(seed)
    d = np.sort(rng.uniform(0, travel, 25))
    d[0] = 0.0
    q0 = exp_map(rng.normal(size=3))
    j = fit_joint(start + d[:, None] * axis, np.tile(q0, (25, 1)))
    assert j.kind == "prismatic"
    assert j.axis @ axis > 1 - 1e-9  # the way it was moved
    assert np.allclose(j.values, d, atol=1e-9)


def test_a_door_hinge_seen_with_a_millimetre_of_noise_is_found_within_a_degree_and_a_centimetre():
    rng = np.random.default_rng(0)
    axis, centre = np.array([0.0, 0.0, 1.0]), np.array([-0.46, -0.30, 1.1])
    angles = np.linspace(0.0, 0.4, 80)
    p, q = _turned(axis, centre, angles, np.array([-0.2, -0.33, 1.1]),
                   np.array([0.0, 0.0, -0.7, 0.7]) / np.sqrt(0.98))
    q = quaternion_multiply(exp_map(rng.normal(scale=0.002, size=(80, 3))), q)
    j = fit_joint(p + rng.normal(scale=0.001, size=p.shape), q)
    assert j.kind == "revolute"
    assert np.degrees(np.arccos(min(1.0, j.axis @ axis))) < 1.0
    assert _off_line(j, axis, centre) < 0.01
    assert abs(j.values[-1] - 0.4) < 0.02


def test_a_turn_in_place_is_not_taken_for_a_slide_nor_a_slide_for_a_turn():
    a = np.linspace(0, 1.0, 20)
    turn_q = np.c_[np.zeros((20, 2)), np.sin(a / 2), np.cos(a / 2)]
    assert fit_joint(np.zeros((20, 3)) + [0.3, 0.1, 0.0], turn_q).kind == "revolute"
    assert fit_joint(np.zeros((20, 3)), turn_q, kind="prismatic").residual > fit_joint(
        np.zeros((20, 3)), turn_q).residual


def test_joint_move_broadcasts_one_pose_over_many_values():
    j = Joint("prismatic", np.array([1.0, 0, 0]), np.zeros(3), np.zeros(1), 0.0, 0.1)
    p, q = j.move([0.0, 0.0, 0.0], [0, 0, 0, 1.0], np.array([0.0, 0.5, 1.0]))
    assert p.shape == (3, 3) and q.shape == (3, 4)
    assert np.allclose(p[:, 0], [0.0, 0.5, 1.0])


@pytest.mark.parametrize("p, q, kind, match", [
    (np.zeros((5, 2)), np.tile([0, 0, 0, 1.0], (5, 1)), None, "positions"),
    (np.zeros((5, 3)), np.tile([0, 0, 0, 1.0], (4, 1)), None, r"quaternions: expected an \(5, 4\)"),
    (np.zeros((2, 3)), np.tile([0, 0, 0, 1.0], (2, 1)), None, "3 poses or more"),
    (np.zeros((5, 3)), np.tile([0, 0, 0, 2.0], (5, 1)), None, "unit quaternions"),
    (np.zeros((5, 3)), np.tile([0, 0, 0, 1.0], (5, 1)), None, "did not move"),
    (np.eye(3), np.tile([0, 0, 0, 1.0], (3, 1)), "ball", "kind: expected one of"),
    (np.full((3, 3), np.nan), np.tile([0, 0, 0, 1.0], (3, 1)), None, "positions"),
])
def test_bad_poses_are_refused_with_what_to_do(p, q, kind, match):
    with pytest.raises(ValueError, match=match):
        fit_joint(p, q, kind=kind)
