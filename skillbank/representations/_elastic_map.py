"""Elastic maps for learning from demonstration."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.linalg import solveh_banded
from scipy.spatial import cKDTree

from ..core import resample
from ..core._validation import check_array, check_finite_result, check_positive, numerical_errors
from ._base import Representation

__all__ = ["ElasticMap"]


def _smoothness(n_nodes: int, stretch: float, bend: float):
    """``stretch (N-1) Δ¹ᵀΔ¹ + bend (N-1)³ Δ²ᵀΔ²`` as a sparse matrix (5 diagonals)."""
    m = n_nodes - 1
    K = sp.csr_matrix((n_nodes, n_nodes))
    if n_nodes >= 2 and stretch > 0:
        d1 = sp.diags([-1.0, 1.0], [0, 1], shape=(n_nodes - 1, n_nodes), format="csr")
        K = K + stretch * m * (d1.T @ d1)
    if n_nodes >= 3 and bend > 0:
        d2 = sp.diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(n_nodes - 2, n_nodes), format="csr")
        K = K + bend * m**3 * (d2.T @ d2)
    return K.tocsr()


class ElasticMap(Representation):
    """Elastic map (Hertel & Ahmadzadeh, IROS 2022) fitted to one or more demonstrations.

    A polyline of ``N`` nodes ``x_1 ... x_N`` is fitted to the pooled points
    ``ζ`` of all demonstrations by minimising::

        U = (1/M) Σ_j ||ζ_j - x_a(j)||²                   (approximation)
          + stretch (N-1) Σ_i ||x_{i+1} - x_i||²           (stretching)
          + bend (N-1)³ Σ_i ||x_{i-1} - 2 x_i + x_{i+1}||²  (bending)

    where ``a(j)`` is the node nearest to ``ζ_j``. The factors ``N-1`` and
    ``(N-1)³`` make the energies discretisations of ``∫||x'||²`` and
    ``∫||x''||²`` over the map's parameter in [0, 1], so the hyperparameters
    do not depend on the number of nodes or points. Expectation-maximisation
    alternates the assignment (a k-d tree query) with the exact minimisation
    over the nodes, a pentadiagonal symmetric positive definite system solved
    banded; no step increases ``U`` (recorded in ``energy_history_``).

    Nearness may include phase: point ``j`` of a demonstration of ``n``
    samples carries the coordinate ``phase_weight * spread_ * j / (n - 1)``
    and node ``i`` the fixed ``phase_weight * spread_ * i / (N - 1)``; the
    distance in ``U`` includes that coordinate. With
    ``phase_weight=0`` the assignment is purely spatial, as in the paper, and
    nodes slide along the curve (the shape is kept, the timing is not: on
    LASA shapes the pointwise error is 5-14 mm for a 0.1-0.6 mm distance to
    the curve, and EM needs hundreds of iterations). The default 10 keeps each
    node with the points of its own phase, which keeps the timing and
    converges in a few iterations.

    Constraints are fixed nodes: the start is node 0, the goal node N-1, a
    via-point at phase φ node ``round(φ (N-1))``. :meth:`reproduce` resamples
    the fitted map to ``n_steps`` nodes, fixes the constrained ones, and runs
    EM again, so the output meets the constraints exactly. Node ``i`` is
    reproduced at time ``t0 + i T / (N-1)``; boundary velocities are not
    supported.

    Parameters
    ----------
    n_nodes : int, optional
        Nodes of the fitted map; default the demonstrations' median length.
    stretch : float, default=1e-6
        Weight of the stretching energy.
    bend : float, default=1e-6
        Weight of the bending energy.
    phase_weight : float, default=10.0
        Weight of phase in the assignment, relative to the spatial spread
        (0: spatial nearest node only).
    max_iter : int, default=200
        EM iterations at most.
    tol : float, default=1e-6
        Stop when the energy falls by less than ``tol`` times its value, or
        when no assignment changes.

    Attributes
    ----------
    nodes_ : ndarray of shape (n_nodes, n_dims)
        The fitted map; its end nodes are held at ``start_`` and ``goal_``.
    start_, goal_ : ndarray of shape (n_dims,)
        Mean first and last positions of the demonstrations.
    spread_ : float
        Root of the summed per-dimension variance of the pooled points.
    energy_history_ : list of float
        Energy of the initial map, then after each EM iteration, of the last
        fit or reproduction.
    n_iter_ : int
        EM iterations of the last fit or reproduction.
    n_dims_, n_demos_, t_ : see :class:`Representation`.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Constraints
    >>> t = np.linspace(0, 1, 200)
    >>> model = ElasticMap().fit(np.column_stack([t, np.sin(np.pi * t)]))
    >>> out = model.reproduce(Constraints(goal=[1.1, 0.2]))
    >>> out["position"][-1].tolist()
    [1.1, 0.2]
    """

    default_k = 3
    min_samples = 3
    supports_start_velocity = False
    supports_end_velocity = False

    def __init__(self, *, n_nodes=None, stretch=1e-6, bend=1e-6, phase_weight=10.0, max_iter=200,
                 tol=1e-6):
        self.n_nodes = n_nodes
        self.phase_weight = phase_weight
        self.stretch = stretch
        self.bend = bend
        self.max_iter = max_iter
        self.tol = tol

    def _params(self):
        stretch = check_positive(self.stretch, name="stretch", allow_zero=True)
        bend = check_positive(self.bend, name="bend", allow_zero=True)
        max_iter = check_positive(self.max_iter, name="max_iter", integer=True)
        tol = check_positive(self.tol, name="tol", allow_zero=True)
        check_positive(self.phase_weight, name="phase_weight", allow_zero=True)
        return stretch, bend, max_iter, tol

    def _fit(self, Ys):
        self._params()
        if self.n_nodes is None:
            n_nodes = self.t_.shape[0]
        else:
            n_nodes = check_positive(self.n_nodes, name="n_nodes", integer=True)
            if n_nodes < self.min_samples:
                raise ValueError(f"n_nodes: expected at least {self.min_samples} nodes, got {n_nodes}")
        pooled = np.vstack(Ys)
        self.spread_ = float(np.sqrt(max(pooled.var(axis=0).sum(), np.finfo(float).tiny)))
        phases = np.concatenate([np.linspace(0.0, 1.0, Y.shape[0]) for Y in Ys])
        self._points = np.column_stack([pooled, self._phase_column(phases)])
        start = np.mean([resample(Y, n_nodes) for Y in Ys], axis=0)
        self.start_ = np.mean([Y[0] for Y in Ys], axis=0)
        self.goal_ = np.mean([Y[-1] for Y in Ys], axis=0)
        self.nodes_ = self._em(start, {0: self.start_, n_nodes - 1: self.goal_})

    def _phase_column(self, phases):
        return float(self.phase_weight) * self.spread_ * phases

    def _augment(self, nodes):
        """Nodes with their fixed phase coordinate appended (zero weight: pure space)."""
        return np.column_stack([nodes, self._phase_column(np.linspace(0.0, 1.0, nodes.shape[0]))])

    def energy(self, nodes) -> float:
        """Energy ``U`` of a map ``nodes`` (n_nodes, n_dims) for the fitted points.

        Examples
        --------
        >>> import numpy as np
        >>> line = np.c_[np.linspace(0, 1, 11), np.zeros(11)]
        >>> model = ElasticMap(stretch=0.0, bend=0.0).fit(line)
        >>> model.energy(line)
        0.0
        """
        self._check_fitted()
        nodes = check_array(nodes, name="nodes", n_dims=self.n_dims_, min_samples=self.min_samples)
        stretch, bend, _, _ = self._params()
        with numerical_errors("ElasticMap.energy"):
            dist, _ = cKDTree(self._augment(nodes)).query(self._points)
            K = _smoothness(nodes.shape[0], stretch, bend)
            energy = float(np.mean(dist**2) + np.einsum("ij,ij->", nodes, K @ nodes))
        return check_finite_result(energy, name="ElasticMap.energy")

    def _em(self, nodes, fixed):
        """EM from ``nodes`` with ``fixed`` (index -> position) held; returns the map."""
        stretch, bend, max_iter, tol = self._params()
        n, d = nodes.shape
        points = self._points
        M = points.shape[0]
        K = _smoothness(n, stretch, bend)
        nodes = nodes.copy()
        fixed_idx = np.array(sorted(fixed), dtype=np.intp)
        if fixed_idx.size:
            nodes[fixed_idx] = np.array([fixed[i] for i in fixed_idx.tolist()])
        free = np.setdiff1d(np.arange(n), fixed_idx)
        K_ff = K[free][:, free]
        K_fx = K[free][:, fixed_idx]
        offsets = [K_ff.diagonal(k) if k < free.size else np.zeros(0) for k in range(3)]
        dist, labels = cKDTree(self._augment(nodes)).query(points)
        history = [float(np.mean(dist**2) + np.einsum("ij,ij->", nodes, K @ nodes))]
        self.n_iter_ = 0
        for _ in range(max_iter):
            if free.size:
                counts = np.bincount(labels, minlength=n) / M
                sums = np.column_stack(
                    [np.bincount(labels, weights=col, minlength=n) for col in points[:, :d].T]
                ) / M
                ab = np.zeros((3, free.size))
                ab[2] = offsets[0] + counts[free]
                ab[1, 1:] = offsets[1]
                ab[0, 2:] = offsets[2]
                if not np.all(ab[2] > 0):
                    raise ValueError(
                        "ElasticMap: the map is underdetermined (a node has no data and neither "
                        "stretching nor bending holds it); use stretch > 0 or bend > 0"
                    )
                rhs = sums[free] - K_fx @ nodes[fixed_idx] if fixed_idx.size else sums[free]
                nodes[free] = solveh_banded(ab, rhs, check_finite=False)
            self.n_iter_ += 1
            dist, new_labels = cKDTree(self._augment(nodes)).query(points)
            history.append(float(np.mean(dist**2) + np.einsum("ij,ij->", nodes, K @ nodes)))
            unchanged = np.array_equal(new_labels, labels)
            labels = new_labels
            if unchanged or history[-2] - history[-1] <= tol * abs(history[-2]):
                break
        self.energy_history_ = history
        return nodes

    def _reproduce(self, constraints, n_steps):
        if constraints.has_velocity:
            raise ValueError(
                "constraints: ElasticMap does not support start/end velocity constraints; "
                "give positions only"
            )
        start = resample(self.nodes_, n_steps)
        constraints = self._constraints(constraints, start)
        idx, pts = constraints.resolve(n_steps)
        return self._em(start, dict(zip(idx.tolist(), pts, strict=True)))
