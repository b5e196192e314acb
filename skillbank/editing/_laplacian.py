"""The linear algebra of Laplacian trajectory editing.

LTE (Nierhoff, Hirche and Nakamura, 2016) keeps the Laplacian (differential)
coordinates ``delta = L Y`` of a path while moving some samples to new
positions. Writing the new path as ``P = Y + E``, the kept coordinates are met
exactly when ``L E = 0``, so the edit is the displacement ``E`` of least
Laplacian energy ``||L E||^2`` that satisfies the constraints.

The normal equations ``L^T L`` of that problem are a fourth-difference matrix
whose condition number grows like ``n^4``; at 10^5 samples they lose every
digit. We solve instead for the first differences ``g = diff(E)``: ``L E = B g``
with a lower-bidiagonal ``B``, so ``H = B^T B`` is a tridiagonal, well-behaved
M-matrix (condition ~ ``n^2``), factored once by banded Cholesky. A position
constraint between consecutive constrained samples is a sum of ``g`` over the
gap between them, which leaves a small ``(k - 1)``-square system for ``k``
constraints. The cost is ``O(n k)``.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_solve_banded, cholesky_banded

from ..core import neighbour_weights

__all__ = ["LaplacianSystem"]


class LaplacianSystem:
    """Factored LTE system for one path length and time base.

    Parameters
    ----------
    n_steps : int
    t : ndarray of shape (n_steps,), optional
        Time stamps; they set the Laplacian's neighbour weights.

    Examples
    --------
    >>> import numpy as np
    >>> system = LaplacianSystem(5)
    >>> E = system.solve(np.array([0, 4]), np.array([[0.0], [1.0]]))
    >>> E[[0, 4], 0].tolist()
    [0.0, 1.0]
    """

    def __init__(self, n_steps: int, t=None):
        self.n_steps = int(n_steps)
        n = self.n_steps
        if n < 2:
            self._chol = None
            return
        a, b = neighbour_weights(n, t)
        m = n - 1
        diag = np.zeros(m)
        diag[0] += 1.0
        diag[-1] += 1.0
        i = np.arange(1, n - 1)  # interior rows: a_i g_{i-1} - b_i g_i
        diag[i - 1] += a[i] ** 2
        diag[i] += b[i] ** 2
        bands = np.zeros((2, m))
        bands[1] = diag
        bands[0, 1:] = -a[i] * b[i]
        self._chol = cholesky_banded(bands, lower=False)

    def solve_g(self, rhs: np.ndarray) -> np.ndarray:
        """Apply ``H^{-1}`` to the columns of ``rhs`` (n_steps - 1, ...)."""
        return cho_solve_banded((self._chol, False), rhs, check_finite=False)

    def solve(self, indices, targets, *, hard: bool = True, weight: float = 1e6) -> np.ndarray:
        """Displacement ``E`` of least Laplacian energy meeting ``E[indices] = targets``.

        Parameters
        ----------
        indices : ndarray of int, shape (k,)
            Sorted, unique sample indices.
        targets : ndarray of shape (k, n_dims)
            Wanted displacements at those samples.
        hard : bool, default=True
            Equality constraints; otherwise rows of weight ``weight`` added to
            the least-squares problem.
        weight : float, default=1e6

        Returns
        -------
        E : ndarray of shape (n_steps, n_dims)
        """
        n = self.n_steps
        targets = np.asarray(targets, dtype=float)
        d = targets.shape[1]
        k = len(indices)
        if k == 0:
            return np.zeros((n, d))
        if k == 1 or n == 1:
            return np.broadcast_to(targets[0], (n, d)).copy()
        m = n - 1
        # Gap r holds the differences g_j with indices[r] <= j < indices[r + 1].
        gap_of = np.searchsorted(indices, np.arange(m), side="right") - 1
        inside = (gap_of >= 0) & (gap_of < k - 1)
        A = np.zeros((m, k - 1))
        A[np.flatnonzero(inside), gap_of[inside]] = 1.0
        Z = self.solve_g(A)
        C = np.zeros((n, k - 1))
        np.cumsum(Z, axis=0, out=C[1:])
        S = C[indices[1:]] - C[indices[:-1]]  # A^T H^{-1} A: sums of Z over each gap
        S = 0.5 * (S + S.T)
        if hard:
            v = np.diff(targets, axis=0)
        else:
            # Minimise v^T S^{-1} v + w^2 |Q (T v - e)|^2 over the gap sums v, with T the cumulative
            # sum from the first constraint and Q the centring projector (c eliminated).
            T = np.tril(np.ones((k, k - 1)), -1)
            QT = T - T.mean(axis=0)
            Qe = targets - targets.mean(axis=0)
            lhs = np.eye(k - 1) / weight**2 + S @ (QT.T @ QT)
            v = np.linalg.solve(lhs, S @ (QT.T @ Qe))
        lam = np.linalg.solve(S, v)
        g = self.solve_g(A @ lam)
        G = np.zeros((n, d))
        np.cumsum(g, axis=0, out=G[1:])
        G -= G[indices[0]]
        if hard:
            E = targets[0] + G
            # Spread the round-off left at each constraint linearly over the gaps.
            miss = targets - E[indices]
            pos = np.arange(n)
            for j in range(d):
                E[:, j] += np.interp(pos, indices, miss[:, j])
            E[indices] = targets
            return E
        c = (targets - G[indices]).mean(axis=0)
        return c + G
