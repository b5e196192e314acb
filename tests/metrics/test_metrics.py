"""Metrics against hand-computed values and straightforward loop versions."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.core import Box, Constraints, Sphere
from skillbank.metrics import (
    angular_similarity,
    constraint_report,
    curvature_deviation,
    dtw_distance,
    frechet_distance,
    jerk_cost,
    path_length,
    swept_error_area,
)


def loop_dp(P, Q, combine):
    n, m = len(P), len(Q)
    C = np.full((n, m), np.inf)
    for i in range(n):
        for j in range(m):
            d = float(np.linalg.norm(P[i] - Q[j]))
            prev = [C[i - 1, j] if i else np.inf, C[i, j - 1] if j else np.inf,
                    C[i - 1, j - 1] if i and j else np.inf]
            C[i, j] = d if i == j == 0 else combine(d, min(prev))
    return C[-1, -1]


def loop_angular(P, Q):
    total = 0.0
    for i in range(len(P) - 1):
        u, v = P[i + 1] - P[i], Q[i + 1] - Q[i]
        if np.linalg.norm(u) > 0 and np.linalg.norm(v) > 0:
            total += np.arccos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1, 1)) / np.pi
    return total / len(P)


def shoelace(poly):
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


curves = st.integers(1, 25).flatmap(lambda n: st.lists(
    st.lists(st.floats(-10, 10), min_size=2, max_size=2), min_size=n, max_size=n))


@settings(max_examples=50, deadline=None)
@given(P=curves, Q=curves)
def test_dp_distances_match_loops(P, Q):
    P, Q = np.array(P), np.array(Q)
    assert frechet_distance(P, Q) == pytest.approx(loop_dp(P, Q, max), abs=1e-12)
    assert dtw_distance(P, Q) == pytest.approx(loop_dp(P, Q, lambda a, b: a + b), rel=1e-12, abs=1e-12)
    assert frechet_distance(P, Q) == pytest.approx(frechet_distance(Q, P), abs=1e-12)


def test_distance_known_values():
    P = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    assert frechet_distance(P, P) == 0.0 and dtw_distance(P, P) == 0.0
    assert frechet_distance(P, P + [0, 3]) == 3.0 and dtw_distance(P, P + [0, 3]) == 9.0
    # Q lingers at its start: Frechet stays 0, DTW too (repeated samples align at zero cost).
    Q = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    assert frechet_distance(P, Q) == 0.0 and dtw_distance(P, Q) == 0.0
    assert frechet_distance([[0.0], [10.0]], [[0.0], [5.0], [10.0]]) == 5.0
    assert dtw_distance([[0.0], [10.0]], [[0.0], [5.0], [10.0]]) == 5.0


def test_swept_error_area():
    s = np.linspace(0, 2, 21)
    P = np.column_stack([s, np.zeros_like(s)])
    Q = np.column_stack([s, 0.5 * s])  # triangle of area 1/2 * 2 * 1
    assert swept_error_area(P, Q) == pytest.approx(1.0)
    # Same in 3-D, rotated out of the plane.
    R = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))[0]
    P3, Q3 = np.column_stack([P, np.zeros(21)]) @ R, np.column_stack([Q, np.zeros(21)]) @ R
    assert swept_error_area(P3, Q3) == pytest.approx(1.0)
    assert swept_error_area(P, P) == 0.0 and swept_error_area([[0.0], [1.0]], [[1.0], [2.0]]) == 0.0


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 30), seed=st.integers(0, 10_000))
def test_swept_area_matches_shoelace_for_graphs(n, seed):
    # Two graphs y = f(x) over the same x with f >= g: each quadrilateral is a convex trapezoid.
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.uniform(0.1, 1.0, n))
    lo = rng.normal(size=n)
    hi = lo + rng.uniform(0.0, 2.0, n)
    P, Q = np.column_stack([x, lo]), np.column_stack([x, hi])
    expected = sum(shoelace(np.array([P[i], P[i + 1], Q[i + 1], Q[i]])) for i in range(n - 1))
    assert swept_error_area(P, Q) == pytest.approx(expected, rel=1e-10, abs=1e-12)


def test_angular_similarity():
    P = [[0, 0], [1, 0], [2, 0], [3, 0]]
    assert angular_similarity(P, P) == 0.0
    # Opposite directions on 3 steps: 3 * 1 / 4.
    assert angular_similarity(P, [[0, 0], [-1, 0], [-2, 0], [-3, 0]]) == pytest.approx(0.75)
    # A right angle on one step, standing still on another: (0.5 + 0 + 0) / 4.
    assert angular_similarity(P, [[0, 0], [0, 1], [0, 1], [1, 1]]) == pytest.approx(0.125)
    rng = np.random.default_rng(3)
    A, B = rng.normal(size=(200, 3)), rng.normal(size=(200, 3))
    B[50] = B[49]
    assert angular_similarity(A, B) == pytest.approx(loop_angular(A, B), abs=1e-12)


def test_curvature_deviation_and_path_length():
    P = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    assert curvature_deviation(P, P + [5.0, -2.0]) == pytest.approx(0.0, abs=1e-15)  # translation
    Q = P.copy()
    Q[1, 1] = 1.0  # Laplacian changes by -1 at row 0, +1 at row 1, -0.5 at row 2: mean 2.5 / 4
    assert curvature_deviation(P, Q) == pytest.approx(0.625)
    assert curvature_deviation(P, Q, t=[0.0, 1.0, 2.0, 3.0]) == pytest.approx(0.625)
    assert path_length(P) == 3.0 and path_length([[0, 0], [3, 4]]) == 5.0 and path_length([[1.0]]) == 0.0


def test_jerk_cost():
    # Minimum-jerk motion over distance D in time T: integral of jerk^2 is 720 D^2 / T^5.
    T, D = 2.0, 0.3
    t = np.linspace(0.0, T, 4001)
    tau = t / T
    x = D * (10 * tau**3 - 15 * tau**4 + 6 * tau**5)
    assert jerk_cost(x, t) == pytest.approx(720 * D**2 / T**5, rel=1e-3)
    # Exact for cubic motion on uneven time stamps: jerk 6 everywhere.
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.05, 0.2, 30))
    expected = 36.0 * (t[-1] - t[0])
    assert jerk_cost(np.column_stack([t**3, 2 * t]), t) == pytest.approx(expected, rel=1e-9)
    assert jerk_cost(np.column_stack([t, t**2]), t) == pytest.approx(0.0, abs=1e-6)


def test_constraint_report():
    c = Constraints(start=[0.0, 0.0], goal=[1.0, 0.0], start_velocity=[1.0, 0.0],
                    obstacles=[Sphere([0.5, 0.0], 0.2), Box([5.0, 5.0], [6.0, 6.0])])
    Y = np.array([[0.0, 0.0], [0.25, 0.0], [0.5, 0.1], [1.0, 0.1]])
    r = constraint_report(Y, c, t=[0.0, 0.25, 0.5, 1.0])
    assert r["position_error"] == pytest.approx(0.1) and r["velocity_error"] == pytest.approx(0.0)
    assert r["collision"] and r["n_colliding"] == 1
    assert r["min_signed_distance"] == pytest.approx([-0.1, np.hypot(4.0, 4.9)])
    assert r["clearance"] == pytest.approx(-0.1)
    empty = constraint_report(Y, Constraints())
    assert empty == {"position_error": 0.0, "velocity_error": 0.0, "collision": False, "n_colliding": 0,
                     "min_signed_distance": [], "clearance": float("inf")}


@pytest.mark.parametrize("call, match", [
    (lambda: frechet_distance(np.zeros((3, 2)), np.zeros((3, 3))), r"Q: expected 2 columns to match P"),
    (lambda: dtw_distance(np.zeros((0, 2)), np.zeros((3, 2))), r"P: expected at least 1 samples"),
    (lambda: frechet_distance([[np.nan, 0]], [[0, 0]]), r"P: expected finite values"),
    (lambda: swept_error_area(np.zeros((3, 2)), np.zeros((4, 2))), r"same number of samples"),
    (lambda: angular_similarity(np.zeros((3, 2)), np.zeros((4, 2))), r"same number of samples"),
    (lambda: curvature_deviation(np.zeros((3, 2)), np.zeros((3, 2)), t=[0, 1]), r"t: expected 3 samples"),
    (lambda: jerk_cost(np.zeros((3, 2)), [0, 1, 2]), r"Y: expected at least 4 samples"),
    (lambda: jerk_cost(np.zeros((4, 2)), [0, 1, 1, 2]), r"t: expected strictly increasing time"),
    (lambda: path_length(np.zeros((2, 2, 2))), r"Y: expected a 1-D or 2-D array"),
    (lambda: constraint_report(np.zeros((3, 2)), None), r"constraints: expected a skillbank Constraints"),
    (lambda: constraint_report(np.zeros((3, 3)), Constraints(goal=[0, 0])), r"goal has 2 dimensions"),
])
def test_error_paths(call, match):
    with pytest.raises(ValueError, match=match):
        call()
