"""Tests for the shared constraint type."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

from skillbank.core import OBSTACLES, Box, Constraints, Sphere, ViaPoint, parse_obstacle

coords = st.floats(-100, 100, allow_nan=False)


def points(d):
    return st.lists(coords, min_size=d, max_size=d)


def test_resolve_orders_and_rounds_phases():
    c = Constraints(start=[0, 0], goal=[1, 1], via=[(0.5, [0.5, 0.8]), ViaPoint([0.1, 0.1], index=2)])
    idx, pts = c.resolve(11)
    assert idx.tolist() == [0, 2, 5, 10]
    assert pts.tolist() == [[0, 0], [0.1, 0.1], [0.5, 0.8], [1, 1]]
    assert ViaPoint([0.0], phase=0.5).sample(2) == 1  # half rounds up
    assert ViaPoint([0.0], index=-1).sample(7) == 6


def test_same_point_twice_is_merged():
    idx, pts = Constraints(start=[1.0, 2.0], via=[ViaPoint([1.0, 2.0], index=0)]).resolve(5)
    assert idx.tolist() == [0] and pts.tolist() == [[1.0, 2.0]]


def test_empty_constraints():
    c = Constraints()
    assert c.is_empty and c.n_dims is None and not c.has_velocity
    idx, pts = c.resolve(10)
    assert idx.shape == (0,) and pts.shape == (0, 0)
    Y = np.zeros((4, 2))
    assert c.position_error(Y) == 0.0 and c.velocity_error(Y, None) == 0.0 and not c.collides(Y)
    assert Constraints(obstacles=[Sphere([0, 0], 1)]).n_dims == 2


@settings(max_examples=60, deadline=None)
@given(d=st.integers(1, 4), n=st.integers(1, 60), data=st.data())
def test_resolve_properties(d, n, data):
    start = data.draw(points(d))
    phases = data.draw(st.lists(st.floats(0, 1), max_size=5))
    via = [(p, data.draw(points(d))) for p in phases]
    c = Constraints(start=start, via=via)
    try:
        idx, pts = c.resolve(n)
    except ValueError as exc:
        assert "different positions" in str(exc)
        return
    assert np.all(np.diff(idx) > 0) and idx.min() >= 0 and idx.max() < n
    assert pts.shape == (len(idx), d) and idx[0] == 0
    # The resolved points are the given ones, each at its rounded phase.
    for p, q in via:
        i = int(np.floor(p * (n - 1) + 0.5))
        assert np.allclose(pts[idx.tolist().index(i)], q) or np.allclose(pts[0], q)
    Y = np.zeros((n, d))
    Y[idx] = pts
    assert c.position_error(Y) == 0.0


@settings(max_examples=60, deadline=None)
@given(d=st.integers(1, 4), data=st.data())
def test_signed_distance_properties(d, data):
    center = np.array(data.draw(points(d)))
    r = data.draw(st.floats(0.01, 10))
    Y = np.array(data.draw(st.lists(points(d), min_size=1, max_size=20)))
    sd = Sphere(center, r).signed_distance(Y)
    assert np.allclose(sd, np.linalg.norm(Y - center, axis=1) - r)
    lo = np.array(data.draw(points(d)))
    hi = lo + np.array(data.draw(st.lists(st.floats(0.01, 10), min_size=d, max_size=d)))
    box = Box(lo, hi)
    sd = box.signed_distance(Y)
    inside = np.all((Y > lo) & (Y < hi), axis=1)
    assert np.array_equal(sd < 0, inside)
    # Outside, the distance equals the distance to the clamped point.
    outside = ~np.all((Y >= lo) & (Y <= hi), axis=1)
    assert np.allclose(sd[outside], np.linalg.norm(Y - np.clip(Y, lo, hi), axis=1)[outside])
    # Pushed out across the path, samples inside land at the requested clearance.
    for ob in (Sphere(center, r), box):
        inner = Y[ob.signed_distance(Y) < 0]
        if inner.size:
            T = np.zeros_like(inner)
            T[:, 0] = 1.0  # the path runs along the first axis
            out = ob.push_out(inner, T, 0.5)
            tol = 1e-9 * (1 + np.abs(Y).max() + r)
            assert np.all(ob.signed_distance(out) > 0.5 - tol)
            if d > 1:  # across the path: the coordinate along it is kept
                assert np.allclose(out[:, 0], inner[:, 0])


@settings(max_examples=80, deadline=None)
@given(d=st.integers(1, 3), data=st.data())
def test_segment_hits_match_the_minimum_along_each_segment(d, data):
    """The closed-form segment test agrees with minimising the signed distance along each segment.

    The signed distance to a convex set is convex, so along a segment a bounded scalar minimiser
    finds its global minimum: an independent reference for "the segment passes through the inside".
    """
    pts = np.array(data.draw(st.lists(points(d), min_size=2, max_size=6)))
    lo = np.array(data.draw(points(d)))
    obstacles = [Sphere(data.draw(points(d)), data.draw(st.floats(0.1, 5))),
                 Box(lo, lo + np.array(data.draw(st.lists(st.floats(0.1, 5), min_size=d, max_size=d))))]
    for ob in obstacles:
        hits = ob.segment_hits(pts)
        for i in range(len(pts) - 1):
            A, V = pts[i], pts[i + 1] - pts[i]
            best = minimize_scalar(lambda s, ob=ob, A=A, V=V: float(ob.signed_distance(A + s * V)[0]),
                                   bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-12})
            depth = min(best.fun, float(ob.signed_distance(pts[i:i + 2]).min()))
            if depth < -1e-6 * ob.size:  # clearly through the inside
                assert hits[i]
            elif depth > 1e-6 * ob.size:  # clearly outside
                assert not hits[i]
        assert ob.collides(pts) == bool(hits.any() or (ob.signed_distance(pts) < 0).any())


def test_obstacle_spec_round_trip_and_registry():
    for ob in (Sphere([0.5, -1.0, 2.0], 0.25), Box([0.0, 0.0], [1.0, 2.0])):
        assert parse_obstacle(ob.spec()) == ob
        assert OBSTACLES[ob.kind] is type(ob)
        lo, hi = ob.bounds()
        assert np.all(ob.signed_distance(np.vstack(ob.outline())) > -1e-9)  # the outline is on or outside
        assert np.all(np.vstack(ob.outline()) >= lo - 1e-12) and np.all(np.vstack(ob.outline()) <= hi + 1e-12)


def test_box_and_sphere_known_values():
    box = Box([0, 0, 0], [2, 2, 2])
    assert box.signed_distance([[1, 1, 1], [3, 1, 1], [3, 3, 1], [1, 1.5, 1]]).tolist() == pytest.approx(
        [-1, 1, np.sqrt(2), -0.5])
    # a sample at the centre is pushed normal to the tangent
    assert Sphere([0, 0], 1).push_out(np.zeros((1, 2)), np.array([[0.0, 1.0]]), 0.5).tolist() == [[1.5, 0.0]]
    assert box.push_out(np.array([[1.0, 0.2, 1.0]]), np.array([[1.0, 0.0, 0.0]]), 0.1).tolist() == [
        [1.0, -0.1, 1.0]]
    assert Sphere([0.0], 1.0).signed_distance([2.0]).tolist() == [1.0]


def test_collisions_and_errors():
    c = Constraints(start=[0, 0], goal=[2, 0], obstacles=[Sphere([1, 0], 0.5), Box([5, 5], [6, 6])],
                    start_velocity=[1, 0], end_velocity=[0, 1])
    Y = np.array([[0, 0], [1, 0.1], [2, 0.5], [2, 1.0]])
    assert c.collision_mask(Y).tolist() == [False, True, False, False]
    assert c.collides(Y)
    assert c.position_error(Y) == pytest.approx(1.0)  # goal [2, 0] vs [2, 1]
    t = np.array([0.0, 0.5, 1.0, 2.0])
    # v0 = (1, 0.1)/0.5 = (2, 0.2); v1 = (0, 0.5)/1 -> errors |(1, 0.2)| and |(0, -0.5)|
    assert c.velocity_error(Y, t) == pytest.approx(np.hypot(1.0, 0.2))
    assert c.signed_distances(Y).shape == (2, 4)


def test_with_defaults_and_check_dims():
    Y = np.array([[0.0, 1.0], [2.0, 3.0], [4.0, 5.0]])
    c = Constraints(goal=[9.0, 9.0]).with_defaults(Y)
    assert c.start.tolist() == [0.0, 1.0] and c.goal.tolist() == [9.0, 9.0]
    c.check_dims(2)
    with pytest.raises(ValueError, match=r"start has 2 dimensions but the trajectory has 3"):
        c.check_dims(3)
    with pytest.raises(ValueError, match=r"obstacles\[0\] has 3 dimensions"):
        Constraints(obstacles=[Sphere([0, 0, 0], 1)]).with_defaults(Y)


@pytest.mark.parametrize("build, match", [
    (lambda: ViaPoint([0, 0]), r"exactly one of index or phase"),
    (lambda: ViaPoint([0, 0], index=1, phase=0.5), r"exactly one of index or phase"),
    (lambda: ViaPoint([0, 0], index=1.5), r"ViaPoint index: expected an integer"),
    (lambda: ViaPoint([0, 0], phase=-0.1), r"ViaPoint phase: expected a number in \[0.0, 1.0\]"),
    (lambda: ViaPoint([], phase=0.1), r"via position: expected at least 1 samples, got 0"),
    (lambda: ViaPoint([[0, 0]], phase=0.1), r"via position: expected a 1-D array"),
    (lambda: Sphere([0, np.nan], 1.0), r"sphere center: expected finite values"),
    (lambda: Sphere([0, 0], 0.0), r"sphere radius: expected a number > 0"),
    (lambda: Box([0, 0], [1, 1, 1]), r"box: expected lower and upper corners of equal length"),
    (lambda: Box([0, 1], [1, 1]), r"box: expected lower < upper"),
    (lambda: Constraints(via=[(1.2, [0, 0])]), r"via\[0\]: ViaPoint phase: expected a number in"),
    (lambda: Constraints(via=[[0, 0, 0]]), r"via\[0\]: expected a ViaPoint or a \(phase, position\) pair"),
    (lambda: Constraints(via="0.5:1,1"), r"via: expected a sequence, got str"),
    (lambda: Constraints(obstacles=["sphere:0,0,1"]),
     r"obstacles\[0\]: expected an Obstacle \(Sphere, Box, ...\), got str"),
    (lambda: Constraints(start=[0, 0], via=[(0.5, [1, 1, 1])]), r"start has 2, via\[0\] has 3"),
    (lambda: Constraints(goal=[0, 0], end_velocity=[1]), r"goal has 2, end_velocity has 1"),
    (lambda: Constraints(start=[0, 0], via=[ViaPoint([1, 1], index=0)]).resolve(5),
     r"start and via\[0\] put different positions \[0.0, 0.0\] and \[1.0, 1.0\] on sample 0 of 5"),
    (lambda: Constraints(start=[0, 0], goal=[1, 1]).resolve(1), r"start and goal put different positions"),
    (lambda: Constraints(via=[(0.0, [0]), (0.1, [1])]).resolve(3), r"via\[0\] and via\[1\] put different"),
    (lambda: Constraints(via=[ViaPoint([0], index=7)]).resolve(5),
     r"ViaPoint index: expected an index in \[-5, 5\) for 5 samples, got 7"),
    (lambda: Constraints().resolve(0), r"n_steps: expected an integer > 0"),
    (lambda: Constraints(start=[0, 0]).position_error(np.zeros((3, 3))), r"start has 2 dimensions but"),
    (lambda: Constraints(start_velocity=[0]).velocity_error(np.zeros((1, 1)), None),
     r"at least 2 samples to measure velocity"),
    (lambda: Constraints(start_velocity=[0]).velocity_error(np.zeros((3, 1)), [0, 1, 1]),
     r"t: expected strictly increasing time"),
    (lambda: Sphere([0, 0], 1).signed_distance([1, 2, 3]), r"Y: expected a point with 2 coordinates"),
    (lambda: Box([0, 0], [1, 1]).signed_distance(np.zeros((2, 3))), r"Y: expected 2 columns to match"),
])
def test_error_paths(build, match):
    with pytest.raises(ValueError, match=match):
        build()


def test_repr_roundtrip_information():
    c = Constraints(start=[0, 0], via=[(0.5, [1, 1])], obstacles=[Sphere([0, 1], 0.5), Box([0, 0], [1, 1])])
    text = repr(c)
    assert "start=[0.0, 0.0]" in text and "ViaPoint([1.0, 1.0], phase=0.5)" in text and "Box(" in text


def test_dimension_mismatch_among_many_via_points_is_summarised():
    """Issue 12, item 6: the message lists the first few constraints that differ, then a count."""
    via = [(k / 1000, [0.0, 0.0, 0.0]) for k in range(1000)]
    with pytest.raises(ValueError) as info:
        Constraints(goal=[1.0, 0.0], via=via)
    assert str(info.value) == ("constraints: expected the same number of dimensions everywhere, got goal has "
                               "2, via[0] has 3, via[1] has 3, via[2] has 3 and 997 more")
