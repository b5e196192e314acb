"""Tests for Laplacian trajectory editing."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.core import Constraints, ViaPoint, laplacian_matrix
from skillbank.editing import LaplacianSystem, lte


def wave(n, d=3):
    s = np.linspace(0.0, 1.0, n)
    cols = [s, 0.2 * np.sin(3 * s), 0.1 * np.cos(5 * s)]
    return np.column_stack(cols[:d])


def dense_hard(Y, idx, pts, t=None):
    """Straightforward LTE: eliminate the constrained samples, dense least squares on the rest."""
    n = Y.shape[0]
    L = laplacian_matrix(n, t).toarray()
    free = np.setdiff1d(np.arange(n), idx)
    P = Y.copy()
    P[idx] = pts
    P[free] = np.linalg.lstsq(L[:, free], L @ Y - L[:, idx] @ pts, rcond=None)[0]
    return P


def dense_soft(Y, idx, pts, w):
    n = Y.shape[0]
    L = laplacian_matrix(n).toarray()
    C = np.zeros((len(idx), n))
    C[np.arange(len(idx)), idx] = 1.0
    return np.linalg.lstsq(np.vstack([L, w * C]), np.vstack([L @ Y, w * pts]), rcond=None)[0]


@pytest.mark.parametrize("n", [2, 3, 10, 1000, 20000])
def test_unchanged_constraints_give_the_path_back(n):
    Y = wave(n)
    mid = Y[int(np.floor(0.5 * (n - 1) + 0.5))]
    for c in (None, Constraints(), Constraints(start=Y[0], goal=Y[-1]), Constraints(via=[(0.5, mid)])):
        res = lte(Y, c)
        assert res.success and np.abs(res.Y - Y).max() <= 1e-9


def test_matches_dense_least_squares():
    rng = np.random.default_rng(0)
    Y = wave(300)
    idx = np.array([0, 40, 41, 150, 299])
    pts = Y[idx] + rng.normal(scale=0.1, size=(5, 3))
    c = Constraints(via=[ViaPoint(p, index=int(i)) for i, p in zip(idx, pts, strict=True)])
    res = lte(Y, c, anchor_ends=False)
    assert res.constraint_error <= 1e-12
    assert np.abs(res.Y - dense_hard(Y, idx, pts)).max() < 1e-9
    t = np.cumsum(rng.uniform(0.5, 1.5, 300))
    assert np.abs(lte(Y, c, t=t, anchor_ends=False).Y - dense_hard(Y, idx, pts, t)).max() < 1e-9
    for w in (0.01, 1.0, 1e3):
        soft = lte(Y, c, hard=False, weight=w, anchor_ends=False)
        assert np.abs(soft.Y - dense_soft(Y, idx, pts, w)).max() < 1e-8
    # Soft rows pull harder with a larger weight and tend to the hard solution.
    weights = (0.01, 0.1, 1.0, 10.0)
    errs = [lte(Y, c, hard=False, weight=w, anchor_ends=False).constraint_error for w in weights]
    assert all(a > b for a, b in zip(errs, errs[1:], strict=False))


def exact_two_point(n, a, b, at):
    """Exact LTE displacement for fixed ends a, b: a cubic in the index on 1..n-2 (rational arithmetic)."""
    def L_row(i):
        if i == 0:
            return {0: Fraction(1), 1: Fraction(-1)}
        if i == n - 1:
            return {n - 1: Fraction(1), n - 2: Fraction(-1)}
        return {i - 1: Fraction(-1, 2), i: Fraction(1), i + 1: Fraction(-1, 2)}
    rows = []
    for i in (1, 2, n - 3, n - 2):  # Euler-Lagrange rows of L^T L that the cubic does not satisfy freely
        M = {}
        for r in range(max(0, i - 1), min(n, i + 2)):
            Lr = L_row(r)
            for j, v in Lr.items():
                M[j] = M.get(j, 0) + Lr.get(i, 0) * v
        coef, rhs = [Fraction(0)] * 4, Fraction(0)
        for j, v in M.items():
            if j in (0, n - 1):
                rhs -= v * (a if j == 0 else b)
            else:
                coef = [c + v * Fraction(j) ** p for p, c in enumerate(coef)]
        rows.append(coef + [rhs])
    for col in range(4):  # Gauss-Jordan in exact arithmetic
        piv = next(r for r in range(col, 4) if rows[r][col] != 0)
        rows[col], rows[piv] = rows[piv], rows[col]
        pivot = rows[col]
        rows = [r if k == col else [x - r[col] / pivot[col] * y for x, y in zip(r, pivot, strict=True)]
                for k, r in enumerate(rows)]
    c = [rows[k][4] / rows[k][k] for k in range(4)]
    return np.array([float(c[0] + j * (c[1] + j * (c[2] + j * c[3]))) for j in at])


@pytest.mark.parametrize("n", [50, 5000, 100000])
def test_exact_solution_at_large_n(n):
    # With only the two ends fixed, the LTE displacement is a cubic in the sample index inside.
    Y = np.zeros((n, 1))
    res = lte(Y, Constraints(start=[0.3], goal=[-1.7]))
    at = np.unique(np.linspace(1, n - 2, 40).astype(int))
    exact = exact_two_point(n, Fraction(3, 10), Fraction(-17, 10), at)
    assert np.abs(res.Y[at, 0] - exact).max() < 1e-8
    assert res.Y[0, 0] == 0.3 and res.Y[-1, 0] == -1.7


def test_system_energy_matches_laplacian():
    rng = np.random.default_rng(1)
    n = 60
    t = np.cumsum(rng.uniform(0.2, 1.0, n))
    E = LaplacianSystem(n, t).solve(np.array([0, 20, 59]), rng.normal(size=(3, 2)))
    L = laplacian_matrix(n, t)
    # Optimality: the gradient L^T L E vanishes on the free samples.
    grad = L.T @ (L @ E)
    free = np.setdiff1d(np.arange(n), [0, 20, 59])
    assert np.abs(grad[free]).max() < 1e-10
    # A constant-velocity path in time has zero interior Laplacian with time weights.
    assert np.abs((L @ np.column_stack([t, 2 * t]))[1:-1]).max() < 1e-12


@settings(max_examples=40, deadline=None)
@given(n=st.integers(5, 400), d=st.integers(1, 3), data=st.data())
def test_hard_constraints_met(n, d, data):
    Y = wave(n, d)
    k = data.draw(st.integers(0, 4))
    phases = data.draw(st.lists(st.floats(0, 1), min_size=k, max_size=k))
    shift = st.lists(st.floats(-2, 2), min_size=d, max_size=d)
    via = [(p, Y[int(np.floor(p * (n - 1) + 0.5))] + data.draw(shift)) for p in phases]
    goal = Y[-1] + np.array(data.draw(shift))
    try:
        c = Constraints(goal=goal, via=via)
        c.with_defaults(Y).resolve(n)  # skip draws whose via-points clash with the anchored ends
    except ValueError:
        return
    res = lte(Y, c)
    assert res.success and res.constraint_error <= 1e-9
    assert np.abs(res.Y[0] - Y[0]).max() == 0.0  # anchored start
    # A single constraint without anchoring is a pure translation.
    single = lte(Y, Constraints(goal=goal), anchor_ends=False)
    assert np.abs(single.Y - (Y + goal - Y[-1])).max() < 1e-9


def test_shape_is_kept_for_small_edits():
    Y = wave(500)
    res = lte(Y, Constraints(goal=Y[-1] + [0.05, 0.02, 0.0]))
    L = laplacian_matrix(500)
    change = np.linalg.norm(L @ (res.Y - Y), axis=1).max()
    assert change < 1e-4 * np.linalg.norm(L @ Y, axis=1).max() + 1e-6
    assert np.abs(res.Y - Y).max() <= 0.054


def test_velocity_constraints():
    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.01, 0.02, 200))
    Y = wave(200)
    c = Constraints(goal=[1.1, 0.0, 0.0], start_velocity=[0.0, 1.0, 0.0], end_velocity=[0.5, 0.0, 0.0])
    res = lte(Y, c, t=t)
    assert res.success and res.velocity_error < 1e-9 and res.constraint_error < 1e-12
    v0, v1 = c.with_defaults(Y).velocities(res.Y, t)
    assert np.allclose(v0, [0, 1, 0], atol=1e-9) and np.allclose(v1, [0.5, 0, 0], atol=1e-9)


@pytest.mark.parametrize("build, match", [
    (lambda Y: lte(Y, Constraints(start_velocity=[1, 0, 0]), anchor_ends=False),
     r"start_velocity: LTE needs a start position"),
    (lambda Y: lte(Y, Constraints(end_velocity=[1, 0, 0]), anchor_ends=False),
     r"end_velocity: LTE needs a goal position"),
    (lambda Y: lte(Y, Constraints(start_velocity=[1, 0, 0], via=[ViaPoint([5, 5, 5], index=1)])),
     r"start_velocity fixes sample 1 at .* already puts it at \[5.0, 5.0, 5.0\]"),
    (lambda Y: lte(Y[:1], Constraints(start_velocity=[1, 0, 0])), r"at least 2 samples for a velocity"),
    (lambda Y: lte(Y, Constraints(goal=[1, 1])), r"goal has 2 dimensions but the trajectory has 3"),
    (lambda Y: lte(Y, {"goal": [1, 1, 1]}), r"constraints: expected a skillbank Constraints, got dict"),
    (lambda Y: lte(Y, None, weight=0), r"weight: expected a number > 0"),
    (lambda Y: lte(Y, None, max_iter=-1), r"max_iter: expected an integer >= 0"),
    (lambda Y: lte(Y, None, margin=-0.1), r"margin: expected a number >= 0"),
    (lambda Y: lte(Y, None, t=np.arange(3.0)), r"t: expected 50 samples to match the data, got 3"),
    (lambda Y: lte(Y[:, :, None], None), r"Y: expected a 2-D array"),
])
def test_error_paths(build, match):
    with pytest.raises(ValueError, match=match):
        build(wave(50))

