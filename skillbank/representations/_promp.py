"""Probabilistic movement primitives."""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from ..core._validation import check_finite_result, check_positive, numerical_errors
from ._base import Representation, as_constraints

__all__ = ["ProMP", "gaussian_basis"]


def gaussian_basis(phase, n_basis: int, width: float) -> np.ndarray:
    """Normalised Gaussian basis functions over phase.

    Parameters
    ----------
    phase : array-like of shape (n_steps,)
        Values in [0, 1].
    n_basis : int
        Centres are evenly spaced on [0, 1].
    width : float
        Standard deviation of each Gaussian, in phase units.

    Returns
    -------
    ndarray of shape (n_steps, n_basis)
        Rows sum to 1.

    Examples
    --------
    >>> Phi = gaussian_basis(np.linspace(0, 1, 5), 3, 0.5)
    >>> Phi.shape, np.allclose(Phi.sum(axis=1), 1.0)
    ((5, 3), True)
    """
    z = np.asarray(phase, dtype=float)[:, None]
    centres = np.linspace(0.0, 1.0, n_basis)[None, :]
    log_b = -0.5 * ((z - centres) / width) ** 2
    log_b -= log_b.max(axis=1, keepdims=True)  # normalisation is shift-invariant; avoids underflow
    b = np.exp(log_b)
    return b / b.sum(axis=1, keepdims=True)


class ProMP(Representation):
    """Probabilistic movement primitive (Paraschos et al., 2013).

    Each demonstration is projected on ``n_basis`` normalised Gaussian basis
    functions of the phase ``s = (t - t0) / T`` by ridge regression, one weight
    vector per demonstration; the weights' mean and covariance define a
    Gaussian over trajectories. Constraints condition that Gaussian: each
    position (start, goal, via-point at sample ``i``) observes ``Φ(s_i) w``
    with a tiny noise, so the conditioned mean meets it to about
    ``obs_noise / cov_reg`` times the displacement. Velocities observe the
    first difference ``(Φ(s_1) - Φ(s_0)) w / dt`` (the measure of
    :meth:`~skillbank.Constraints.velocity_error`).

    The empirical covariance of a few demonstrations is singular (zero with
    one), so ``cov_reg`` adds an isotropic prior variance to every weight,
    scaled by the data's spatial variance; it lets constraints outside the
    demonstrated variation be met, with a deformation local in phase.

    Parameters
    ----------
    n_basis : int, default=25
        Number of basis functions.
    width : float, optional
        Standard deviation of each basis function in phase units; default
        the spacing of the centres, ``1 / (n_basis - 1)``.
    reg : float, default=1e-6
        Ridge regularisation of the per-demonstration regression, relative
        to the mean of ``ΦᵀΦ / n_steps``.
    cov_reg : float, default=1e-2
        Prior variance added to each weight, relative to the data's mean
        per-dimension variance. Too small a prior lets a constraint the
        demonstrations never varied (LASA: all end at the origin) be met
        through their weakly correlated variation elsewhere, with a wildly
        distorted trajectory (measured: with 1e-4, a goal moved by 20 % of
        the extent changed the 7-demo GShape mean by 10 times its curvature).
    obs_noise : float, default=1e-12
        Observation variance of the constraints, on the same relative scale.
    random_state : int, RandomState or None, default=None
        Seeds :meth:`sample`.

    Attributes
    ----------
    weights_ : ndarray of shape (n_demos, n_dims * n_basis)
        Per-demonstration weights, dimension-major (all weights of dimension
        0 first).
    mean_w_ : ndarray of shape (n_dims * n_basis,)
    cov_w_ : ndarray of shape (n_dims * n_basis, n_dims * n_basis)
        Empirical covariance plus the ``cov_reg`` prior.
    scale_ : float
        Mean per-dimension variance of the demonstrated positions (the unit of
        ``cov_reg`` and ``obs_noise``).
    n_dims_, n_demos_, t_ : see :class:`Representation`.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Constraints
    >>> t = np.linspace(0, 1, 100)
    >>> demos = [np.column_stack([t, a * np.sin(np.pi * t)]) for a in (0.8, 1.0, 1.2)]
    >>> model = ProMP(n_basis=10).fit(demos)
    >>> out = model.reproduce(Constraints(via=[(0.5, [0.5, 1.1])]))
    >>> np.allclose(out["position"][50], [0.5, 1.1], atol=1e-6)
    True
    """

    default_k = 3
    min_samples = 2

    def __init__(self, *, n_basis=25, width=None, reg=1e-6, cov_reg=1e-2, obs_noise=1e-12,
                 random_state=None):
        self.n_basis = n_basis
        self.width = width
        self.reg = reg
        self.cov_reg = cov_reg
        self.obs_noise = obs_noise
        self.random_state = random_state

    def _width(self) -> float:
        n_basis = check_positive(self.n_basis, name="n_basis", integer=True)
        if n_basis < 2:
            raise ValueError(f"n_basis: expected at least 2 basis functions, got {n_basis}")
        if self.width is None:
            return 1.0 / (n_basis - 1)
        return check_positive(self.width, name="width")

    def _basis(self, n_steps: int) -> np.ndarray:
        # a reproduction asks for the same grid again and again (reuse, planning): computed once per
        # (grid, n_basis, width), read-only so no caller can change the cached one
        key = (int(n_steps), int(self.n_basis), self._width())
        cache = self.__dict__.setdefault("_basis_cache", {})
        if key not in cache:
            if len(cache) >= 8:
                cache.clear()
            Phi = gaussian_basis(np.linspace(0.0, 1.0, key[0]), key[1], key[2])
            Phi.setflags(write=False)
            cache[key] = Phi
        return cache[key]

    def _fit(self, Ys):
        self._width()
        reg = check_positive(self.reg, name="reg", allow_zero=True)
        cov_reg = check_positive(self.cov_reg, name="cov_reg")
        check_positive(self.obs_noise, name="obs_noise")
        weights = []
        for Y in Ys:
            Phi = self._basis(Y.shape[0])
            G = Phi.T @ Phi
            G[np.diag_indices_from(G)] += reg * np.trace(G) / self.n_basis
            W = cho_solve(cho_factor(G), Phi.T @ Y)  # (n_basis, n_dims)
            weights.append(W.T.ravel())
        self.weights_ = np.array(weights)
        self.mean_w_ = self.weights_.mean(axis=0)
        pooled = np.vstack(Ys)
        self.scale_ = float(max(pooled.var(axis=0).mean(), np.finfo(float).tiny))
        k = self.mean_w_.shape[0]
        empirical = np.cov(self.weights_, rowvar=False).reshape(k, k) if len(Ys) > 1 else np.zeros((k, k))
        self.cov_w_ = empirical + cov_reg * self.scale_ * np.eye(k)

    # ----------------------------------------------------------- conditioning
    def _observations(self, constraints, n_steps, Phi):
        """Observation matrix H (m, n_dims*n_basis), values (m,), variances (m,)."""
        d, K = self.n_dims_, int(self.n_basis)
        idx, pts = constraints.resolve(n_steps)
        rows, values, noise = [], [], []
        var = self.obs_noise * self.scale_
        for i, p in zip(idx.tolist(), pts, strict=True):
            rows.append(Phi[i])
            values.append(p)
            noise.append(var)
        dt = self.duration_ / (n_steps - 1)
        for v, (a, b) in ((constraints.start_velocity, (0, 1)), (constraints.end_velocity, (n_steps - 2,
                                                                                             n_steps - 1))):
            if v is not None:
                rows.append((Phi[b] - Phi[a]) / dt)
                values.append(v)
                noise.append(var / dt**2)
        if not rows:
            return np.zeros((0, d * K)), np.zeros(0), np.zeros(0)
        rows, values, noise = np.array(rows), np.array(values), np.array(noise)
        m = rows.shape[0]
        H = np.zeros((m * d, d * K))
        for j in range(d):  # dimension blocks: observation (row r, dim j) reads weights of dim j
            H[j * m:(j + 1) * m, j * K:(j + 1) * K] = rows
        return H, values.T.ravel(), np.tile(noise, d)

    def _posterior(self, constraints, n_steps, *, covariance=True):
        """Weight mean and covariance given ``constraints`` (None: the prior), and the basis.

        ``covariance=False``: the mean only (the covariance returned is None), what a reproduction needs.
        """
        self._check_fitted()
        n_steps = self._n_steps(n_steps)
        Phi = self._basis(n_steps)
        mean, cov = self.mean_w_.copy(), self.cov_w_
        if constraints is None:
            return mean, (cov.copy() if covariance else None), Phi
        constraints = as_constraints(constraints)
        constraints.check_dims(self.n_dims_)
        constraints = constraints.with_defaults(self._trajectory(mean, Phi[[0, -1]]))  # its two ends
        H, o, noise = self._observations(constraints, n_steps, Phi)
        if H.shape[0] == 0:
            return mean, (cov.copy() if covariance else None), Phi
        HC = H @ cov
        S = HC @ H.T
        S[np.diag_indices_from(S)] += noise
        gain = cho_solve(cho_factor(S), HC).T  # Σ Hᵀ S⁻¹
        mean = mean + gain @ (o - H @ mean)
        if not covariance:
            return mean, None, Phi
        cov = cov - gain @ HC
        return mean, 0.5 * (cov + cov.T), Phi

    def _trajectory(self, w, Phi):
        return Phi @ w.reshape(self.n_dims_, -1).T

    def _reproduce(self, constraints, n_steps):
        use = None if constraints.is_empty and not constraints.has_velocity else constraints
        mean, _, Phi = self._posterior(use, n_steps, covariance=False)
        return self._trajectory(mean, Phi)

    def mean_and_std(self, constraints=None, n_steps=None):
        """Mean and standard deviation of the (conditioned) trajectory distribution.

        Parameters
        ----------
        constraints : Constraints, optional
            Condition on these first (missing start / goal: the mean's own).
        n_steps : int, optional

        Returns
        -------
        mean, std : ndarray of shape (n_steps, n_dims)
            Pointwise; observation noise is not included.

        Examples
        --------
        >>> import numpy as np
        >>> t = np.linspace(0, 1, 50)
        >>> model = ProMP(n_basis=8).fit([np.c_[t, a * t] for a in (0.9, 1.0, 1.1)])
        >>> mean, std = model.mean_and_std()
        >>> bool(std[-1, 1] > std[0, 1])
        True
        """
        step = "ProMP.mean_and_std"
        with numerical_errors(step):
            mean, cov, Phi = self._posterior(constraints, n_steps)
            K = int(self.n_basis)
            std = np.empty((Phi.shape[0], self.n_dims_))
            for j in range(self.n_dims_):
                block = cov[j * K:(j + 1) * K, j * K:(j + 1) * K]
                std[:, j] = np.sqrt(np.maximum(np.einsum("ik,kl,il->i", Phi, block, Phi), 0.0))
            mean = self._trajectory(mean, Phi)
        return check_finite_result(mean, name=step), check_finite_result(std, name=step)

    def sample(self, n, constraints=None, n_steps=None):
        """Draw trajectories from the (conditioned) distribution.

        Parameters
        ----------
        n : int
            Number of trajectories.
        constraints : Constraints, optional
        n_steps : int, optional

        Returns
        -------
        ndarray of shape (n, n_steps, n_dims)

        Examples
        --------
        >>> import numpy as np
        >>> t = np.linspace(0, 1, 50)
        >>> model = ProMP(n_basis=8, random_state=0).fit([np.c_[t, a * t] for a in (0.9, 1.1)])
        >>> model.sample(4).shape
        (4, 50, 2)
        """
        n = check_positive(n, name="n", integer=True)
        from sklearn.utils import check_random_state  # slow to import; only when sampling

        with numerical_errors("ProMP.sample"):
            mean, cov, Phi = self._posterior(constraints, n_steps)
            rng = check_random_state(self.random_state)
            vals, vecs = np.linalg.eigh(cov)
            root = vecs * np.sqrt(np.maximum(vals, 0.0))
            W = mean + rng.standard_normal((n, mean.shape[0])) @ root.T
            out = np.einsum("ik,njk->nij", Phi, W.reshape(n, self.n_dims_, -1))
        return check_finite_result(out, name="ProMP.sample")
