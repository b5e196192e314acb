"""DMP: reproduction, new start/goal, exact discretisation against an ODE solver."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from skillbank.core import Constraints
from skillbank.representations import DMP


def test_unchanged_start_and_goal_reproduce_the_demo(gshape):
    Y = gshape[0]["position"]
    out = DMP().fit(gshape[0]).reproduce()
    # Measured 0.014 mm on a 35 mm shape.
    assert np.abs(out["position"] - Y).max() < 0.03


def test_new_start_and_goal(gshape):
    Y = gshape[0]["position"]
    c = Constraints(start=Y[0] + [-3.0, 2.0], goal=Y[-1] + [5.0, 5.0])
    out = DMP().fit(gshape[0]).reproduce(c)["position"]
    np.testing.assert_array_equal(out[0], c.start)
    # The goal-change term is not quite zero at T: measured 0.005 mm for a 7 mm move.
    assert c.position_error(out) < 0.02


def test_start_velocity_sets_the_initial_state(arc):
    model = DMP().fit(arc)
    c = Constraints(start_velocity=[0.0, 2.0])
    out = model.reproduce(c)
    # First differences measure the initial velocity to O(dt · acceleration).
    assert c.velocity_error(out["position"], out.t) < 0.05 * 2.0


def test_integration_matches_an_ode_solver(arc):
    model = DMP(meet_goal=False).fit(arc)  # the dynamics alone
    K, D, a_s = model.alpha * model.alpha / 4, model.alpha, model.alpha_phase
    tau, x0, g, v0 = model.tau_, np.array([-1.0, 0.2]), np.array([-1.3, 0.4]), np.array([0.1, -0.3])

    def rhs(t, q):
        x, v = q[:2], q[2:]
        s = np.exp(-a_s * t / tau)
        psi = np.exp(-model.widths_ * (s - model.centres_) ** 2)
        f = (psi * s / psi.sum()) @ model.weights_
        return np.concatenate([v / tau, (K * (g - x) - D * v - K * (g - x0) * s + K * f) / tau])

    t = np.linspace(0, tau, 2000)
    ref = solve_ivp(rhs, (0, tau), np.concatenate([x0, tau * v0]), t_eval=t, rtol=1e-11, atol=1e-12)
    out = model.reproduce(Constraints(start=x0, goal=g, start_velocity=v0), n_steps=2000)
    assert np.abs(out["position"] - ref.y[:2].T).max() < 1e-5


def test_the_goal_is_met_exactly_and_nothing_else_changes_but_by_the_offset(arc):
    """meet_goal blends in what the dynamics leave at T: the goal exact, start and both end velocities as
    they were, no sample moved by more than that offset."""
    x0, g, v0 = np.array([-1.0, 0.2]), np.array([-1.3, 0.4]), np.array([0.1, -0.3])
    c = Constraints(start=x0, goal=g, start_velocity=v0)
    raw = DMP(meet_goal=False).fit(arc).reproduce(c, n_steps=2000)
    met = DMP().fit(arc).reproduce(c, n_steps=2000)
    P, R = met["position"], raw["position"]
    offset = np.linalg.norm(R[-1] - g)
    assert offset > 1e-4  # the dynamics alone leave the goal short
    np.testing.assert_array_equal(P[-1], g)
    np.testing.assert_array_equal(P[0], R[0])
    dt = met.t[1] - met.t[0]
    np.testing.assert_allclose((P[1] - P[0]) / dt, (R[1] - R[0]) / dt, atol=1e-9 * offset / dt)
    np.testing.assert_allclose((P[-1] - P[-2]) / dt, (R[-1] - R[-2]) / dt, atol=1e-4 * offset / dt + 1e-12)
    assert np.linalg.norm(P - R, axis=1).max() <= offset * (1 + 1e-12)
    with pytest.raises(ValueError, match=r"meet_goal: expected True or False, got 'yes'"):
        DMP(meet_goal="yes").fit(arc).reproduce(c)


def test_several_demos_are_averaged(arc):
    Y = arc["position"]
    single = DMP().fit(arc).reproduce()["position"]
    both = DMP().fit([Y, Y + [0.0, 0.0]]).reproduce()["position"]
    np.testing.assert_allclose(both, single, atol=1e-9)


def test_errors(arc):
    model = DMP().fit(arc)
    with pytest.raises(ValueError, match="DMP does not support via-points"):
        model.reproduce(Constraints(via=[(0.5, [0.0, 1.0])]))
    with pytest.raises(ValueError, match="DMP does not support an end velocity"):
        model.reproduce(Constraints(end_velocity=[0.0, 0.0]))
    with pytest.raises(ValueError, match="alpha: expected a number > 0, got 0"):
        DMP(alpha=0).fit(arc)
    with pytest.raises(ValueError, match="beta: expected a number > 0, got -1"):
        DMP(beta=-1).fit(arc)
    with pytest.raises(ValueError, match="n_basis: expected an integer > 0, got 0"):
        DMP(n_basis=0).fit(arc)
