"""Dynamic movement primitives in the formulation of Pastor et al. (2009)."""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm

from ..core._validation import check_positive
from ._base import Representation

__all__ = ["DMP"]


class DMP(Representation):
    """Dynamic movement primitive with the goal-change term (Pastor et al., 2009).

    Per dimension, with phase ``s`` and time constant ``τ`` (the
    demonstrations' mean duration)::

        τ v' = K (g - x) - D v - K (g - x0) s + K f(s)
        τ x' = v
        τ s' = -alpha_phase s,          s(0) = 1

    with ``K = alpha * beta``, ``D = alpha`` and the forcing term
    ``f(s) = s Σ_i ψ_i(s) w_i / Σ_i ψ_i(s)``, ``ψ_i`` Gaussians in ``s`` with
    centres evenly spaced in time. ``w`` is fitted by ridge least squares to
    ``f_target = (τ² x'' + D τ x') / K - (g - x) + (g - x0) s`` of every
    demonstration (several demonstrations are averaged in that sense).

    :meth:`reproduce` integrates from the new start to the new goal. The
    system is linear with a known input ``s(t)``, so it is discretised
    exactly for a piecewise-linear input on the output grid (a matrix
    exponential) and run as a second-order recursion with
    :func:`scipy.signal.lfilter`: no Python loop over samples.

    Constraints: start, goal and ``start_velocity`` (the initial ``x'``;
    default the demonstrations' mean initial velocity). A DMP has no
    mechanism for via-points or a final velocity (it converges to the goal at
    rest): both raise ``ValueError``.

    Parameters
    ----------
    n_basis : int, default=50
        Number of basis functions of the forcing term.
    alpha : float, default=50.0
        Damping ``D`` of the transformation system.
    beta : float, optional
        ``K = alpha * beta``; default ``alpha / 4`` (critical damping).
    alpha_phase : float, default=8.0
        Decay of the phase; ``s(T) = exp(-alpha_phase)``. The goal-change term
        ``K (g - x0) s`` is not yet zero at ``T``, nor has the system settled:
        the dynamics alone meet a changed start or goal to about ``s(T)`` of
        the change (measured 1e-3 of it with the defaults; 5e-2 with the
        common ``alpha=25, alpha_phase=4``). See ``meet_goal``.
    reg : float, default=1e-8
        Ridge regularisation of the weights, relative to the mean diagonal of
        the normal matrix.
    meet_goal : bool, default=True
        The goal is a constraint: the offset the integration leaves at ``T``
        (above) is added back along a minimum-jerk ramp ``10 u^3 - 15 u^4 +
        6 u^5`` of the phase time ``u``, so the last sample is the goal
        exactly, while the start, the initial velocity and the final velocity
        are unchanged (the ramp and its slope are 0 at the start, its slope 0
        at the end) and no sample moves by more than the offset. False: the
        dynamics' own end.

    Attributes
    ----------
    weights_ : ndarray of shape (n_basis, n_dims)
    start_, goal_ : ndarray of shape (n_dims,)
        Mean first and last positions of the demonstrations.
    start_velocity_ : ndarray of shape (n_dims,)
        Mean initial velocity (per unit of the time base).
    tau_ : float
        Mean duration.
    centres_, widths_ : ndarray of shape (n_basis,)
    n_dims_, n_demos_, t_ : see :class:`Representation`.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Constraints, Demonstration
    >>> t = np.linspace(0, 1, 500)
    >>> Y = np.column_stack([t, np.sin(np.pi * t)])
    >>> out = DMP().fit(Demonstration.from_array(Y, t)).reproduce(Constraints(goal=[1.5, 0.0]))
    >>> out["position"].shape
    (500, 2)
    """

    min_samples = 3
    supports_via = False
    supports_end_velocity = False

    def __init__(self, *, n_basis=50, alpha=50.0, beta=None, alpha_phase=8.0, reg=1e-8, meet_goal=True):
        self.n_basis = n_basis
        self.alpha = alpha
        self.beta = beta
        self.alpha_phase = alpha_phase
        self.reg = reg
        self.meet_goal = meet_goal

    def _gains(self):
        alpha = check_positive(self.alpha, name="alpha")
        beta = alpha / 4.0 if self.beta is None else check_positive(self.beta, name="beta")
        alpha_phase = check_positive(self.alpha_phase, name="alpha_phase")
        return alpha * beta, alpha, alpha_phase

    def _features(self, s):
        psi = np.exp(-self.widths_ * (s[:, None] - self.centres_) ** 2)
        return psi * (s / np.maximum(psi.sum(axis=1), np.finfo(float).tiny))[:, None]

    def _fit(self, Ys):
        K, D, a_s = self._gains()
        n_basis = check_positive(self.n_basis, name="n_basis", integer=True)
        reg = check_positive(self.reg, name="reg", allow_zero=True)
        self.tau_ = float(self.t_[-1] - self.t_[0])
        self.centres_ = np.exp(-a_s * np.linspace(0.0, 1.0, n_basis))
        gaps = np.abs(np.diff(self.centres_)) if n_basis > 1 else np.array([1.0])
        self.widths_ = 1.0 / np.append(gaps, gaps[-1]) ** 2
        rows, targets, v0 = [], [], []
        # Demonstrations' own durations: each is stretched to the same phase course.
        durations = self._durations
        for Y, T in zip(Ys, durations, strict=True):
            # Derivatives in the phase time u = t / T: T x' and T^2 x'' directly, so neither a
            # very long nor a very short duration overflows (T^2 of 1e-200 s, 1 / dt^2, ...).
            u = np.linspace(0.0, 1.0, Y.shape[0])
            xu = np.gradient(Y, u, axis=0, edge_order=2)
            xuu = np.gradient(xu, u, axis=0, edge_order=2)
            s = np.exp(-a_s * u)[:, None]
            g, x0 = Y[-1], Y[0]
            targets.append((xuu + D * xu) / K - (g - Y) + (g - x0) * s)
            rows.append(self._features(s[:, 0]))
            v0.append(xu[0] / T)
        Phi, F = np.vstack(rows), np.vstack(targets)
        G = Phi.T @ Phi
        G[np.diag_indices_from(G)] += reg * max(np.trace(G) / n_basis, np.finfo(float).tiny)
        self.weights_ = np.linalg.solve(G, Phi.T @ F)
        self.start_ = np.mean([Y[0] for Y in Ys], axis=0)
        self.goal_ = np.mean([Y[-1] for Y in Ys], axis=0)
        self.start_velocity_ = np.mean(v0, axis=0)

    def _reproduce(self, constraints, n_steps):
        if constraints.via:
            raise ValueError(
                "constraints: DMP does not support via-points (its forcing term is fixed by the "
                "demonstration); use JerkAccuracy, ProMP or ElasticMap, or post-edit with LTE"
            )
        if constraints.end_velocity is not None:
            raise ValueError(
                "constraints: DMP does not support an end velocity; it converges to the goal at rest"
            )
        constraints = self._constraints(constraints, np.vstack([self.start_, self.goal_]))
        if not isinstance(self.meet_goal, (bool, np.bool_)):
            raise ValueError(f"meet_goal: expected True or False, got {self.meet_goal!r}")
        v0 = self.start_velocity_ if constraints.start_velocity is None else constraints.start_velocity
        x = self._integrate(constraints.start, constraints.goal, v0, n_steps)
        if self.meet_goal:
            u = np.linspace(0.0, 1.0, n_steps)
            x += (10 * u ** 3 - 15 * u ** 4 + 6 * u ** 5)[:, None] * (constraints.goal - x[-1])
            x[-1] = constraints.goal  # exactly, not to round-off
        return x

    def _integrate(self, x0, g, xd0, n_steps):
        """Exact discretisation for piecewise-linear input, run with lfilter."""
        from scipy.signal import lfilter, lfiltic  # 0.4 s to import (scipy.stats); only when a DMP runs

        K, D, a_s = self._gains()
        # Integrated in the phase time u = t / tau (the system is the same with tau = 1 and the
        # state v = tau x'), so the duration enters only through the initial velocity.
        dt = 1.0 / (n_steps - 1)
        s = np.exp(-a_s * np.linspace(0.0, 1.0, n_steps))
        f = self._features(s) @ self.weights_  # (n_steps, n_dims)
        u = K * (g - np.outer(s, g - x0) + f)
        M = np.zeros((4, 4))
        M[0, 1] = 1.0
        M[1, 0], M[1, 1], M[1, 2] = -K, -D, 1.0
        M[2, 3] = 1.0
        E = expm(M * dt)
        Phi, b_u, b_du = E[:2, :2], E[:2, 2], E[:2, 3]
        du = np.diff(u, axis=0) / dt
        # q_{k+1} = Phi q_k + w_k, w_k = b_u u_k + b_du du_k  (q = [x, v]; components stacked last)
        w = b_u[:, None, None] * u[None, :-1] + b_du[:, None, None] * du[None]  # (2, n-1, d)
        x = np.empty((n_steps, x0.shape[0]))
        x[0] = x0
        q0 = np.stack([x0, self.tau_ * xd0])
        x[1] = Phi[0] @ q0 + w[0, 0]
        if n_steps > 2:
            tr, det = np.trace(Phi), np.linalg.det(Phi)
            # Cayley-Hamilton: q_{k+2} - tr q_{k+1} + det q_k = w_{k+1} + (Phi - tr I) w_k.
            r = w[0, 1:] + (Phi[0, 0] - tr) * w[0, :-1] + Phi[0, 1] * w[1, :-1]
            a = [1.0, -tr, det]
            zi = np.column_stack([lfiltic([1.0], a, [x[1, j], x[0, j]]) for j in range(x0.shape[0])])
            x[2:] = lfilter([1.0], a, r, axis=0, zi=zi)[0]
        return x
