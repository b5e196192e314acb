"""Tests for the shared constraint type."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank._constraints import Box, Constraints, Sphere, ViaPoint

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
    # Exterior points are at the requested clearance.
    for ob in (Sphere(center, r), box):
        out = ob.exterior_point(Y, margin=0.5)
        assert np.all(ob.signed_distance(out) > 0.5 - 1e-9 * (1 + np.abs(Y).max()))


def test_box_and_sphere_known_values():
    box = Box([0, 0, 0], [2, 2, 2])
    assert box.signed_distance([[1, 1, 1], [3, 1, 1], [3, 3, 1], [1, 1.5, 1]]).tolist() == pytest.approx(
        [-1, 1, np.sqrt(2), -0.5])
    assert Sphere([0, 0], 1).exterior_point([[0.0, 0.0]], margin=0.5).tolist() == [[1.5, 0.0]]
    assert box.exterior_point([[1.0, 0.2, 1.0]], margin=0.1).tolist() == [[1.0, -0.1, 1.0]]
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


def test_from_cli():
    c = Constraints.from_cli(start="0,0,0", goal="1, 1, 1", via=["0.5:0.5,0.5,0.9"],
                             obstacle=["sphere:0.5,0.5,0.5,0.1", "BOX:0,0,0,0.2,0.2,0.2"])
    assert c.n_dims == 3 and c.via[0].phase == 0.5 and c.obstacles[0].radius == 0.1
    assert c.obstacles[1].upper.tolist() == [0.2, 0.2, 0.2]
    c2 = Constraints.from_cli(goal="1,2", via="0.3:1,1", obstacle="box:0,0,1,1", start_velocity="0,1")
    assert c2.n_dims == 2 and c2.start_velocity.tolist() == [0, 1] and isinstance(c2.obstacles[0], Box)
    assert Constraints.from_cli().is_empty


@pytest.mark.parametrize("kwargs, match", [
    (dict(start="0,0", goal="1,1,1"), r"same number of dimensions.*start has 2, goal has 3"),
    (dict(start="0,x"), r"start: expected a number, got 'x'"),
    (dict(start="0,,1"), r"start: expected comma-separated numbers"),
    (dict(goal=""), r"goal: expected comma-separated numbers"),
    (dict(start="0,inf"), r"start: expected a finite number"),
    (dict(via=["0.5"]), r"via: expected 'PHASE:X,Y\[,Z\]'"),
    (dict(via=["1.5:0,0"]), r"ViaPoint phase: expected a number in \[0.0, 1.0\], got 1.5"),
    (dict(via=["a:0,0"]), r"via phase: expected a number, got 'a'"),
    (dict(obstacle=["cone:0,0,1"]), r"obstacle: expected 'sphere:X,Y\[,Z\],R' or 'box:"),
    (dict(obstacle=["sphere"]), r"obstacle: expected 'sphere"),
    (dict(obstacle=["sphere:1"]), r"a sphere needs a center and a radius, got 1"),
    (dict(obstacle=["sphere:0,0,-1"]), r"sphere radius: expected a number > 0, got -1.0"),
    (dict(obstacle=["box:0,0,1"]), r"a box needs an even number of values.*got 3"),
    (dict(obstacle=["box:1,1,0,0"]), r"expected lower < upper in every coordinate"),
])
def test_from_cli_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Constraints.from_cli(**kwargs)


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
    (lambda: Constraints(obstacles=["sphere:0,0,1"]), r"obstacles\[0\]: expected a Sphere or Box, got str"),
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
