"""ProMP: conditioning against the closed-form joint Gaussian of trajectory points."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.core import Constraints, ViaPoint
from skillbank.representations import ProMP
from skillbank.representations._promp import gaussian_basis


def _demos(n_demos=6, n=80, seed=0):
    rng = np.random.default_rng(seed)
    s = np.linspace(0, 1, n)
    return [np.column_stack([s + 0.1 * rng.normal() * np.sin(np.pi * s),
                             rng.uniform(0.8, 1.2) * np.sin(np.pi * s) + 0.05 * rng.normal()])
            for _ in range(n_demos)]


def test_basis_rows_sum_to_one():
    Phi = gaussian_basis(np.linspace(0, 1, 30), 7, 0.1)
    np.testing.assert_allclose(Phi.sum(axis=1), 1.0)
    assert Phi[0].argmax() == 0 and Phi[-1].argmax() == 6


def test_unconditioned_mean_is_mean_of_projections():
    demos = _demos()
    model = ProMP(n_basis=12, reg=1e-6).fit(demos)
    Phi = gaussian_basis(np.linspace(0, 1, 80), 12, 1 / 11)
    G = Phi.T @ Phi
    G += 1e-6 * np.trace(G) / 12 * np.eye(12)
    projections = [Phi @ np.linalg.solve(G, Phi.T @ Y) for Y in demos]
    np.testing.assert_allclose(model.reproduce()["position"], np.mean(projections, axis=0), atol=1e-10)
    mean, std = model.mean_and_std()
    np.testing.assert_allclose(mean, np.mean(projections, axis=0), atol=1e-10)
    assert std.shape == (80, 2) and np.all(std > 0)


def test_conditioning_matches_joint_gaussian_of_trajectory_points():
    demos = _demos()
    model = ProMP(n_basis=12, cov_reg=1e-3, obs_noise=1e-4).fit(demos)
    n, d, K = 80, 2, 12
    c = Constraints(start=[0.05, 0.0], goal=[1.1, 0.1], via=[ViaPoint([0.6, 1.3], phase=0.4)])
    # Independent closed form: the trajectory stacked per dimension is Gaussian with mean Ψμ and
    # covariance ΨΣΨᵀ (Ψ = I_d ⊗ Φ); observe the constrained entries with noise, condition.
    Phi = gaussian_basis(np.linspace(0, 1, n), K, 1 / (K - 1))
    Psi = np.kron(np.eye(d), Phi)
    mu, S = Psi @ model.mean_w_, Psi @ model.cov_w_ @ Psi.T
    idx = np.array([0, round(0.4 * (n - 1)), n - 1])
    obs = np.concatenate([idx + j * n for j in range(d)])
    values = np.concatenate([[0.05, 0.6, 1.1], [0.0, 1.3, 0.1]])
    noise = 1e-4 * model.scale_
    gain = S[:, obs] @ np.linalg.inv(S[np.ix_(obs, obs)] + noise * np.eye(obs.size))
    mu_c = mu + gain @ (values - mu[obs])
    S_c = S - gain @ S[obs]
    mean, std = model.mean_and_std(c)
    np.testing.assert_allclose(mean, mu_c.reshape(d, n).T, atol=1e-9)
    np.testing.assert_allclose(std, np.sqrt(np.clip(np.diag(S_c), 0, None)).reshape(d, n).T, atol=1e-7)
    np.testing.assert_allclose(model.reproduce(c)["position"], mean, atol=1e-12)


def test_tiny_noise_meets_constraints_exactly(gshape):
    Y = gshape[0]["position"]
    c = Constraints(start=Y[0] + [1.0, 1.0], goal=Y[-1] + [2.0, -2.0], via=[(0.5, Y[500] + [0.5, 0.5])],
                    start_velocity=[0.0, 5.0])
    for demos in (gshape, gshape[0]):
        out = ProMP().fit(demos).reproduce(c)
        assert c.position_error(out["position"]) < 1e-6
        assert c.velocity_error(out["position"], out.t) < 2e-5  # of 5 mm/s; measured 8e-6
        model = ProMP().fit(demos)
        _, std = model.mean_and_std(c)
        # Posterior std at an observed point: at most the observation noise's.
        assert std[[0, 500, 999]].max() <= 1.01 * np.sqrt(model.obs_noise * model.scale_)


def test_samples_follow_the_conditioned_distribution():
    demos = _demos()
    c = Constraints(via=[(0.5, [0.5, 1.2])])
    model = ProMP(n_basis=12, random_state=3).fit(demos)
    draws = model.sample(4000, c)
    assert draws.shape == (4000, 80, 2)
    mean, std = model.mean_and_std(c)
    np.testing.assert_allclose(draws.mean(axis=0), mean, atol=5 * std.max() / np.sqrt(4000) + 1e-9)
    np.testing.assert_allclose(draws.std(axis=0), std, atol=0.1 * std.max() + 1e-9)
    np.testing.assert_allclose(draws[:, 40], np.broadcast_to([0.5, 1.2], (4000, 2)), atol=1e-5)
    again = [ProMP(n_basis=12, random_state=3).fit(demos).sample(5, c, n_steps=30) for _ in range(2)]
    np.testing.assert_array_equal(again[0], again[1])
    again = again[0]
    assert again.shape == (5, 30, 2)


def test_errors():
    demos = _demos()
    with pytest.raises(ValueError, match="n_basis: expected at least 2 basis functions, got 1"):
        ProMP(n_basis=1).fit(demos)
    with pytest.raises(ValueError, match="n_basis: expected an integer > 0, got 2.5"):
        ProMP(n_basis=2.5).fit(demos)
    with pytest.raises(ValueError, match="width: expected a number > 0, got -0.1"):
        ProMP(width=-0.1).fit(demos)
    with pytest.raises(ValueError, match="reg: expected a number >= 0, got -1"):
        ProMP(reg=-1).fit(demos)
    with pytest.raises(ValueError, match="cov_reg: expected a number > 0, got 0"):
        ProMP(cov_reg=0).fit(demos)
    with pytest.raises(ValueError, match="obs_noise: expected a number > 0"):
        ProMP(obs_noise=float("nan")).fit(demos)
    model = ProMP().fit(demos)
    with pytest.raises(ValueError, match="n: expected an integer > 0, got 0"):
        model.sample(0)
    with pytest.raises(ValueError, match="constraints: via\\[0\\] has 3 dimensions"):
        model.mean_and_std(Constraints(via=[(0.5, [0.0, 0.0, 0.0])]))


def test_the_cached_basis_changes_nothing_and_cannot_be_changed():
    """reproduce computes the basis once per grid and skips the posterior covariance: the same result as
    the full posterior's mean, call after call, and after set_params the new basis."""
    s = np.linspace(0, 1, 300)
    Ys = [np.column_stack([s, np.sin(np.pi * s) * (1 + 0.1 * k)]) for k in range(4)]
    c = Constraints(start=[0.1, 0.0], goal=[1.1, 0.1], via=[(0.5, [0.5, 1.2])])
    model = ProMP().fit(Ys)
    first = model.reproduce(c)["position"]
    np.testing.assert_array_equal(model.reproduce(c)["position"], first)
    mean, _ = model.mean_and_std(c)
    np.testing.assert_allclose(first, mean, atol=1e-12)
    with pytest.raises(ValueError, match="read-only"):
        model._basis(300)[0, 0] = 1.0
    fresh = ProMP(n_basis=12).fit(Ys).reproduce(c)["position"]
    np.testing.assert_array_equal(model.set_params(n_basis=12).fit(Ys).reproduce(c)["position"], fresh)
