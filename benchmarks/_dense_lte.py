"""Baseline: LTE as the authors' LfD code does it, dense least squares with soft constraints.

The Laplacian ``L`` is built as a dense ``(n, n)`` matrix; each positional
constraint adds a row of weight ``1e9``, and ``numpy.linalg.lstsq`` solves the
stacked system for all dimensions at once. Cost and memory grow as ``n^3`` and
``n^2``.
"""

from __future__ import annotations

import numpy as np


def dense_laplacian(n: int) -> np.ndarray:
    """Uniform path Laplacian, one-neighbour rows at both ends (same operator as skillbank's)."""
    L = np.eye(n)
    i = np.arange(1, n - 1)
    L[i, i - 1] = -0.5
    L[i, i + 1] = -0.5
    L[0, 1] = -1.0
    L[n - 1, n - 2] = -1.0
    return L


def dense_lte(Y: np.ndarray, indices: np.ndarray, points: np.ndarray, *, weight: float = 1e9) -> np.ndarray:
    """Edit ``Y`` (n, d) so that ``P[indices] ~ points``, keeping ``L Y`` in the least-squares sense."""
    n = Y.shape[0]
    L = dense_laplacian(n)
    C = np.zeros((len(indices), n))
    C[np.arange(len(indices)), indices] = weight
    A = np.vstack([L, C])
    b = np.vstack([L @ Y, weight * points])
    return np.linalg.lstsq(A, b, rcond=None)[0]
