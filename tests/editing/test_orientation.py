"""Orientation constraints and the orientation edit: validation, exactness, unit norm, continuity, profile."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.core import Constraints, ViaPoint, exp_map, log_map, quaternion_angle
from skillbank.editing import LaplacianSystem, edit_orientation, lte, relative_rotations

Z90 = [0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)]


def twisting(n=80):
    """A tool turning 120 degrees about its own z while tilting about x: a non-trivial rotation profile."""
    s = np.linspace(0.0, 1.0, n)
    body = np.column_stack([0.4 * np.sin(np.pi * s), np.zeros(n), 2.1 * s])
    return exp_map(body, reference=[1.0, 0.0, 0.0, 0.0])  # tool pointing down, as on an arm


# ---------------------------------------------------------------- constraint validation

@pytest.mark.parametrize(("kwargs", "match"), [
    ({"goal_orientation": [0.0, 0.0, 1.0]}, r"goal_orientation: expected a quaternion of 4 .* got 3"),
    ({"start_orientation": [0.0, 0.0, 0.0, 0.0]}, r"start_orientation: .*got zero norm"),
    ({"start_orientation": [0.0, 0.0, 1.0, 1.0]}, r"start_orientation: expected unit .*norm 1.41"),
    ({"goal_orientation": [[0.0, 0.0, 0.0, 1.0]]}, r"goal_orientation: expected a 1-D"),
    ({"goal_orientation": [0.0, 0.0, np.nan, 1.0]}, r"goal_orientation: .*finite"),
    ({"via_orientation": [(0.5, [0.0, 1.0])]}, r"via_orientation\[0\]: .*4 components"),
    ({"via_orientation": [(1.5, Z90)]}, r"via_orientation\[0\]: ViaPoint phase"),
    ({"via_orientation": [Z90]}, r"via_orientation\[0\]: expected a ViaPoint or a \(phase, quaternion\)"),
    ({"via_orientation": "x"}, r"via_orientation: expected a sequence"),
])
def test_bad_orientation_constraints(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Constraints(**kwargs)


def test_two_orientations_on_one_sample():
    c = Constraints(goal_orientation=Z90, via_orientation=[ViaPoint([0.0, 0.0, 0.0, 1.0], index=-1)])
    with pytest.raises(ValueError, match=r"goal_orientation and via_orientation\[0\] put different orient"):
        c.resolve_orientation(10)
    # q and -q are one orientation: no clash
    same = Constraints(goal_orientation=Z90, via_orientation=[ViaPoint(-np.array(Z90), index=-1)])
    assert same.resolve_orientation(10)[0].tolist() == [9]


@settings(max_examples=80, deadline=None)
@given(st.lists(st.floats(-2.0, 2.0), min_size=4, max_size=4))
def test_orientation_validator_accepts_exactly_near_unit_quaternions(values):
    q = np.array(values)
    norm = np.linalg.norm(q)
    if abs(norm - 1.0) > 1e-2:
        with pytest.raises(ValueError, match=r"goal_orientation: expected unit quaternions"):
            Constraints(goal_orientation=q)
    else:
        c = Constraints(goal_orientation=q)
        np.testing.assert_allclose(c.goal_orientation, q / norm, atol=1e-15)
        assert c.has_orientation and c.n_dims is None and c.is_empty  # no position constraint


def test_orientations_kept_by_replace_and_with_defaults_and_shown():
    c = Constraints(goal=[1.0, 2.0, 3.0], start_orientation=[0, 0, 0, 1.0], via_orientation=[(0.5, Z90)])
    d = c.with_defaults(np.zeros((5, 3))).replace(via=())
    assert d.start_orientation.tolist() == [0, 0, 0, 1.0] and len(d.via_orientation) == 1
    assert "start_orientation=[0.0, 0.0, 0.0, 1.0]" in repr(c) and "via_orientation=" in repr(c)
    assert c.replace(start_orientation=None).has_orientation  # the via is still there


# ---------------------------------------------------------------- the edit

def test_goal_rotation_follows_the_lte_displacement():
    """Identity stream, goal turned 90 degrees about z: sample i is turned about z by the angle LTE moves a
    1-D path by for the same goal (a blend flat at both ends), on even and uneven time."""
    n = 11
    for t in (None, np.array([0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 20.0])):
        res = edit_orientation(np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)), Constraints(goal_orientation=Z90), t=t)
        expected = lte(np.zeros((n, 1)), Constraints(goal=[np.pi / 2]), t=t).Y[:, 0]
        np.testing.assert_allclose(log_map(res.q), np.c_[np.zeros((n, 2)), expected], atol=1e-14)
        assert (np.diff(expected) > 0).all() and expected[-1] == np.pi / 2


@pytest.mark.parametrize("which", ["start", "goal", "both", "via"])
def test_constraints_met_unit_norm_and_continuity(which):
    q = twisting()
    new_start = exp_map([0.3, -0.2, 0.5], reference=q[0])
    new_goal = exp_map([-0.4, 0.1, 2.5], reference=q[-1])  # far: 2.5 rad about the tool axis
    kw = {"start": dict(start_orientation=new_start), "goal": dict(goal_orientation=new_goal),
          "both": dict(start_orientation=new_start, goal_orientation=new_goal),
          "via": dict(goal_orientation=new_goal, via_orientation=[(0.3, -new_start)])}[which]
    c = Constraints(**kw)
    res = edit_orientation(q, c)
    idx, targets = c.resolve_orientation(len(q))
    assert res.orientation_error <= 1e-12 and quaternion_angle(res.q[idx], targets).max() <= 1e-12
    np.testing.assert_allclose(np.linalg.norm(res.q, axis=1), 1.0, atol=1e-15)
    assert (np.einsum("ij,ij->i", res.q[1:], res.q[:-1]) > 0).all()  # sign-continuous
    if which in ("start", "goal"):  # the end not given is held
        end = -1 if which == "start" else 0
        assert quaternion_angle(res.q[end], q[end]) <= 1e-12


def test_same_turn_at_both_ends_keeps_every_relative_rotation():
    """Start and goal turned by one world rotation R: the result is R q, the rotation profile unchanged."""
    q = twisting()
    R = exp_map([0.2, -0.7, 0.4])
    from skillbank.core._rotations import quaternion_multiply

    turned = quaternion_multiply(R, q)
    res = edit_orientation(q, Constraints(start_orientation=turned[0], goal_orientation=turned[-1]))
    assert quaternion_angle(res.q, turned).max() <= 1e-12
    np.testing.assert_allclose(relative_rotations(res.q), relative_rotations(q), atol=1e-13)


def test_rotation_profile_changes_by_at_most_the_step_of_the_correction():
    """Each relative rotation q_i^-1 q_{i+1} changes by an angle of at most |w_{i+1} - w_i| (1st order)."""
    q = twisting(200)
    goal = exp_map([0.0, 0.5, 1.0], reference=q[-1])
    res = edit_orientation(q, Constraints(goal_orientation=goal))
    change = quaternion_angle(exp_map(relative_rotations(res.q)), exp_map(relative_rotations(q)))
    step = np.linalg.norm(np.diff(res.correction, axis=0), axis=1)
    assert change.max() <= step.max() * (1 + 1e-6) + 1e-14
    # and it is small against the profile itself: under 1 % of the turn per step
    assert change.max() < 0.01 * np.linalg.norm(relative_rotations(q), axis=1).max() + step.max()


@pytest.mark.parametrize("extra", [[0.0, 0.0, 1.5], [0.0, 1.2, 0.0], [0.5, 0.5, -1.0]])
def test_profile_better_kept_than_by_editing_rotation_vectors_about_one_reference(extra):
    """A goal turned further about the tool's own axes: our profile changes in total by exactly the angle
    of the turn (the correction keeps one axis); the alternative (LTE on log(q0^-1 q_i), mapped back)
    distorts it more (measured 1.5 vs 4.9 rad, 1.2 vs 1.6, 1.22 vs 1.44)."""
    q = twisting(200)
    goal = exp_map(extra, reference=q[-1])
    ours = edit_orientation(q, Constraints(goal_orientation=goal)).q
    V = log_map(q, reference=q[0])
    wanted = log_map(goal, reference=q[0]) - V[-1]
    chart = exp_map(V + LaplacianSystem(len(q)).solve(np.array([0, len(q) - 1]),
                                                     np.array([[0.0, 0.0, 0.0], wanted])), reference=q[0])
    assert quaternion_angle(chart[-1], goal) < 1e-12  # it meets the goal too

    def distortion(p):
        return quaternion_angle(exp_map(relative_rotations(p)), exp_map(relative_rotations(q))).sum()

    assert distortion(ours) == pytest.approx(np.linalg.norm(extra), rel=1e-9)
    assert distortion(ours) < 0.9 * distortion(chart)


def test_no_orientation_constraint_leaves_the_stream():
    q = twisting()
    res = edit_orientation(-q, Constraints(goal=[1.0, 2.0]))
    np.testing.assert_allclose(res.q, -q, rtol=0, atol=1e-15)  # the first sample's sign is kept
    assert res.orientation_error == 0.0 and not res.correction.any()


@pytest.mark.parametrize(("args", "kwargs", "match"), [
    ((np.ones((4, 3)),), {}, r"q: expected quaternions of 4 components"),
    ((np.tile([0.0, 0.0, 0.0, 2.0], (3, 1)),), {}, r"q: expected unit quaternions .*norm 2 at sample 0"),
    (([0.0, 0.0, 0.0, 1.0],), {}, r"q: expected an orientation stream of shape \(n_steps, 4\)"),
    ((np.tile([0.0, 0.0, 0.0, 1.0], (3, 1)), "goal"), {}, r"constraints: expected a skillbank Constraints"),
    ((np.tile([0.0, 0.0, 0.0, 1.0], (3, 1)),), {"t": [0.0, 1.0, 1.0]}, r"t: .*increasing"),
])
def test_edit_errors(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        edit_orientation(*args, **kwargs)
