"""The jerk-accuracy model as a banded quadratic programme."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.linalg import solveh_banded
from scipy.sparse.linalg import splu

from ..core import resample
from ..core._validation import check_fraction
from ._base import Representation

__all__ = ["JerkAccuracy", "jerk_accuracy_system"]

_MODES = ("demo", "rest", "free")
# Below this accuracy weight the banded Cholesky of Δ³ᵀΔ³ + rI loses more than ~1e-8 (cond ≈ 64 / r).
_CHOLESKY_MIN_R = 1e-6


def jerk_accuracy_system(n_steps: int, lam: float):
    """Normal-equation matrix of the discretised jerk-accuracy cost.

    With phase ``s`` in [0, 1] sampled at ``h = 1 / (n_steps - 1)``, the cost
    ``lam * h * sum ||Y - D||^2 + (1 - lam) * h * sum ||Δ³Y / h³||^2`` divided
    by ``(1 - lam) / h**5`` has the normal equations ``(r I + Δ³ᵀΔ³) Y = r D``
    with ``r = lam h^6 / (1 - lam)``.

    Parameters
    ----------
    n_steps : int
    lam : float in [0, 1)

    Returns
    -------
    A : scipy.sparse.csr_matrix of shape (n_steps, n_steps)
        Symmetric positive semi-definite, 7 diagonals.
    r : float
        Weight of the accuracy term.

    Examples
    --------
    >>> A, r = jerk_accuracy_system(8, 0.5)
    >>> A.shape, bool((abs(A - A.T)).max() == 0)
    ((8, 8), True)
    """
    h = 1.0 / (n_steps - 1)
    r = lam * h**6 / (1.0 - lam)
    d3 = sp.diags([-1.0, 3.0, -3.0, 1.0], [0, 1, 2, 3], shape=(n_steps - 3, n_steps), format="csr")
    A = (d3.T @ d3 + r * sp.identity(n_steps, format="csr")).tocsr()
    return A, r


def _banded(A_ff) -> np.ndarray:
    """Upper banded storage (4, m) of a symmetric matrix with at most 3 off-diagonals."""
    m = A_ff.shape[0]
    ab = np.zeros((4, m))
    for k in range(4):
        if k < m:
            ab[3 - k, k:] = A_ff.diagonal(k)
    return ab


class JerkAccuracy(Representation):
    """Jerk-accuracy model (Meirovitch, Bennequin & Flash, 2016), from one demonstration.

    The reproduction ``y(s)`` over phase ``s = (t - t0) / T`` in [0, 1]
    minimises the trade-off between accuracy and smoothness::

        J(y) = lam * ∫ ||y(s) - d(s)||² ds + (1 - lam) * ∫ ||y'''(s)||² ds

    where ``d`` is the demonstration, subject to the start, goal, via-points
    and boundary velocities and accelerations. ``lam -> 1`` reproduces the
    demonstration; ``lam = 0`` is the minimum-jerk trajectory through the
    constraints. Phase (not seconds) makes ``lam`` independent of the
    duration and of ``n_steps``: the model follows ``d`` at frequencies below
    about ``(lam / (1 - lam)) ** (1 / 6)`` radians per unit phase and smooths
    above, so useful values are close to 1 (the default follows features
    lasting more than about 1/7 of the movement, ``2π / 46``). The same scale
    sets how far a moved start, goal or via-point spreads along the
    trajectory.

    Instead of the authors' boundary-value problem per dimension, the cost is
    discretised on the samples: the third difference ``Δ³`` is banded, so the
    normal equations are a 7-diagonal symmetric positive definite system,
    solved by banded Cholesky after eliminating the constrained samples. Cost
    and memory are linear in ``n_steps``.

    Boundary conditions are finite differences on the output time grid
    (``dt = T / (n_steps - 1)``): a velocity ``v`` fixes
    ``Y[1] - Y[0] = dt * v`` (the measure of
    :meth:`~skillbank.Constraints.velocity_error`), an acceleration ``a``
    fixes ``Y[2] - 2 Y[1] + Y[0] = dt² a``; likewise at the end.

    Parameters
    ----------
    lam : float in [0, 1], default=1 - 1e-10
        Weight of accuracy against jerk, as above. On LASA shapes the default
        reproduces the demonstration to about 1 % of its extent; 1 - 1e-12
        to 0.1 % but then a moved goal bends only the last few samples (a
        hook); 1 - 1e-8 spreads the change further at 3 % error.
    derivatives : {"demo", "rest", "free"}, default="demo"
        Boundary velocity and acceleration where the constraints give none:
        the demonstration's (``"demo"``), zero (``"rest"``), or unconstrained
        (``"free"``). A velocity in the constraints always wins.

    Attributes
    ----------
    demo_ : ndarray of shape (n_steps, n_dims)
        The demonstration on an even time grid.
    n_dims_, n_demos_, t_ : see :class:`Representation`.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Constraints
    >>> t = np.linspace(0, 1, 200)
    >>> Y = np.column_stack([t, np.sin(np.pi * t)])
    >>> model = JerkAccuracy(lam=0.999999).fit(Y)
    >>> out = model.reproduce(Constraints(goal=[1.2, 0.1]))
    >>> np.allclose(out["position"][-1], [1.2, 0.1])
    True
    """

    single_demo = True
    min_samples = 7

    def __init__(self, *, lam=1.0 - 1e-10, derivatives="demo"):
        self.lam = lam
        self.derivatives = derivatives

    def _check_params(self):
        lam = check_fraction(self.lam, name="lam")
        if self.derivatives not in _MODES:
            raise ValueError(f"derivatives: expected one of {list(_MODES)}, got {self.derivatives!r}")
        return lam

    def _fit(self, Ys):
        self._check_params()
        self.demo_ = Ys[0]

    def _boundary(self, D, constraints, dt):
        """Fixed samples from the boundary velocities and accelerations: dict index -> row."""
        fixed = {}
        n = D.shape[0]
        for end, v_given in (("start", constraints.start_velocity), ("end", constraints.end_velocity)):
            if end == "start":
                i0, i1, i2 = 0, 1, 2
            else:
                i0, i1, i2 = n - 1, n - 2, n - 3
            p = constraints.start if end == "start" else constraints.goal
            if self.derivatives == "free" and v_given is None:
                continue
            if v_given is not None:
                step = dt * v_given if end == "start" else -dt * v_given
            elif self.derivatives == "demo":
                step = D[i1] - D[i0]
            else:
                step = np.zeros(D.shape[1])
            fixed[i1] = p + step
            if self.derivatives == "free":
                continue
            curve = D[i2] - 2.0 * D[i1] + D[i0] if self.derivatives == "demo" else 0.0
            fixed[i2] = 2.0 * fixed[i1] - p + curve
        return fixed

    def _reproduce(self, constraints, n_steps):
        lam = self._check_params()
        D = resample(self.demo_, n_steps)
        constraints = self._constraints(constraints, D)
        dt = self.duration_ / (n_steps - 1)
        idx, pts = constraints.resolve(n_steps)
        fixed = self._boundary(D, constraints, dt)
        for i, p in zip(idx.tolist(), pts, strict=True):
            if i in fixed:
                raise ValueError(
                    f"constraints: a via-point lands on sample {i} of {n_steps}, which the boundary "
                    f"velocity/acceleration conditions fix; use derivatives='free', another phase or "
                    "more samples"
                )
            fixed[i] = p
        return self._solve(D, fixed, lam)

    @staticmethod
    def _solve(D, fixed, lam):
        n = D.shape[0]
        Y = D.copy()
        fixed_idx = np.array(sorted(fixed), dtype=np.intp)
        Y[fixed_idx] = np.array([fixed[i] for i in fixed_idx.tolist()])
        if lam == 1.0:
            return Y
        free = np.setdiff1d(np.arange(n), fixed_idx)
        if free.size == 0:
            return Y
        if lam == 0.0 and fixed_idx.size < 3:
            raise ValueError(
                "lam: lam=0 (pure minimum jerk) needs at least 3 constrained samples to fix the "
                f"trajectory, got {fixed_idx.size}"
            )
        A, r = jerk_accuracy_system(n, lam)
        if r >= _CHOLESKY_MIN_R:
            A_ff = A[free][:, free]
            rhs = r * D[free] - A[free][:, fixed_idx] @ Y[fixed_idx]
            Y[free] = solveh_banded(_banded(A_ff), rhs, check_finite=False)
        else:
            Y[free] = _solve_state_space(D, fixed_idx, Y[fixed_idx], r)[free]
        return Y


def _d1(m: int):
    return sp.diags([-1.0, 1.0], [0, 1], shape=(m - 1, m), format="csc")


def _solve_state_space(D, fixed_idx, Y_fixed, r):
    """Same minimiser through the chain ``V = ΔY, A = ΔV, J = ΔA`` and a sparse LU of its KKT system.

    Forming ``Δ³ᵀΔ³`` squares the conditioning (about ``n⁶``); keeping the
    first differences as unknowns leaves a KKT matrix whose sparse LU with
    pivoting stays accurate at 10^5 samples, at a few times the cost of the
    banded Cholesky.
    """
    n = D.shape[0]
    k = fixed_idx.size
    eye = sp.identity
    pick = sp.csc_matrix((np.ones(k), (np.arange(k), fixed_idx)), shape=(k, n))
    H = sp.block_diag([r * eye(n), sp.csc_matrix((2 * n - 3, 2 * n - 3)), eye(n - 3)])
    C = sp.bmat([
        [_d1(n), -eye(n - 1), None, None],
        [None, _d1(n - 1), -eye(n - 2), None],
        [None, None, _d1(n - 2), -eye(n - 3)],
        [pick, None, None, None],
    ])
    K = sp.bmat([[H, C.T], [C, None]], format="csc")
    rhs = np.zeros((K.shape[0], D.shape[1]))
    rhs[:n] = r * D
    rhs[K.shape[0] - k:] = Y_fixed
    return splu(K, permc_spec="COLAMD").solve(rhs)[:n]
