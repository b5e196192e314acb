"""Vectorised building blocks of elastic clustering: assignment, node solve, energies.

Notation follows the paper (Algorithm 1, eqs. 1-3): data ``X`` (the paper's
zeta, shape ``(n_samples, n_features)``), nodes ``x`` (shape ``(N, n_features)``),
clusters kappa_i given by ``labels``, stretching constant lambda.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse

# Weight, in points, of the partner cluster's spread in a cluster's spread estimate.
PRIOR_COUNT = 5.0

__all__ = [
    "assign", "cluster_sums", "solve_paper", "solve_capped", "em_nodes", "stretch_energy", "selection_energy",
    "pairwise_separation", "closest_separation", "local_splits",
]


def assign(X: np.ndarray, nodes: np.ndarray, x_sq: np.ndarray | None = None):
    """Nearest node of every point (ties go to the lowest index) and its squared distance.

    ``||x - c||^2 = ||x||^2 - 2 x.c + ||c||^2`` turns the distances into one
    matrix product. It is accurate when ``X`` is centred near the data (the
    estimator centres once per fit); ``x_sq`` (``||x||^2`` per row) may be
    passed to avoid recomputing it every EM round.

    Examples
    --------
    >>> assign(np.array([[0.0], [3.0]]), np.array([[0.0], [2.0]]))[0].tolist()
    [0, 1]
    """
    if x_sq is None:
        x_sq = np.einsum("ij,ij->i", X, X)
    c_sq = np.einsum("ij,ij->i", nodes, nodes)
    d2 = X @ (-2.0 * nodes.T)
    d2 += c_sq[None, :]
    labels = np.argmin(d2, axis=1)
    nearest = np.take_along_axis(d2, labels[:, None], axis=1)[:, 0]
    if nodes.shape[0] > 1:
        # The expanded form is off by up to a few ulps of ||x||^2 + ||c||^2: a point (nearly) as far
        # from two nodes could go to either, and to another one under another shift (predict centres
        # on the nodes, fit on the data). Those points are decided on direct differences instead,
        # exact for exact ties, which then go to the lowest index whatever the shift.
        margin = 64 * np.finfo(float).eps * (x_sq + c_sq.max())
        near = d2 <= (nearest + margin)[:, None]
        rows = np.flatnonzero(near.sum(axis=1) > 1)
        if rows.size:
            diff = X[rows, None, :] - nodes[None, :, :]
            exact = np.einsum("ijk,ijk->ij", diff, diff)
            labels[rows] = np.argmin(exact, axis=1)
            nearest[rows] = exact[np.arange(rows.size), labels[rows]] - x_sq[rows]
    return labels, np.maximum(nearest + x_sq, 0.0)


def cluster_sums(X: np.ndarray, labels: np.ndarray, n_clusters: int):
    """Counts ``|kappa_i|`` and sums ``C_i`` of the points of each cluster (lines 18-20)."""
    counts = np.bincount(labels, minlength=n_clusters).astype(float)
    if X.shape[1] <= 16:  # a few weighted bincounts beat building a sparse one-hot matrix
        return counts, np.stack([np.bincount(labels, weights=X[:, k], minlength=n_clusters)
                                 for k in range(X.shape[1])], axis=1)
    onehot = scipy.sparse.csr_matrix(
        (np.ones(labels.shape[0]), (labels, np.arange(labels.shape[0]))),
        shape=(n_clusters, labels.shape[0]),
    )
    return counts, np.asarray(onehot @ X)


def _laplacian(n: int) -> np.ndarray:
    # Lines 8-13 of Algorithm 1 add -lambda * (N I - 1 1^T): the complete graph's Laplacian.
    return n * np.eye(n) - np.ones((n, n))


def solve_paper(counts: np.ndarray, sums: np.ndarray, stretch: float) -> np.ndarray:
    """The authors' node update: least squares on ``(diag|kappa| - lambda L) x = C``.

    The system is singular or indefinite when the repulsion beats the springs
    of small or empty clusters; least squares then returns the minimum-norm
    stationary point, as the authors' code does.
    """
    A = np.diag(counts) - stretch * _laplacian(counts.shape[0])
    return np.linalg.lstsq(A, sums, rcond=None)[0]


def solve_capped(counts: np.ndarray, sums: np.ndarray, stretch: float,
                 softening: float = 0.1) -> tuple[np.ndarray, float]:
    """Node update with the repulsion capped so that eq. (3) keeps a well-defined minimum.

    ``diag(n) - lambda L`` is positive definite iff ``lambda < 1 / mu`` where
    ``mu`` is the largest eigenvalue of ``D^-1/2 L D^-1/2``. Lambda is capped
    at ``softening / mu`` so the matrix stays above ``(1 - softening) diag(n)``:
    the repulsion may soften no cluster's springs by more than that fraction,
    so a small cluster's node is not pushed off its own points. All counts
    must be positive.

    Returns
    -------
    nodes : ndarray of shape (N, n_features)
    stretch_used : float
    """
    n = counts.shape[0]
    if n == 1 or stretch == 0.0:
        return sums / counts[:, None], float(stretch)
    inv_sqrt = 1.0 / np.sqrt(counts)
    mu = float(np.linalg.eigvalsh(_laplacian(n) * np.outer(inv_sqrt, inv_sqrt))[-1])
    lam = min(float(stretch), softening / mu)
    A = np.diag(counts) - lam * _laplacian(n)
    return scipy.linalg.solve(A, sums, assume_a="pos"), lam


def em_nodes(X: np.ndarray, nodes: np.ndarray, *, stretch: float, max_iter: int, tol: float, paper: bool,
             x_sq: np.ndarray | None = None, prior_counts: np.ndarray | None = None,
             prior_sums: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """EM for a fixed number of nodes, Algorithm 1's inner loop: the nodes after at most ``max_iter`` rounds.

    Each round assigns every point of ``X`` to its nearest node and solves
    the node equations from each cluster's count and sum, by
    :func:`solve_paper` (``paper``) or :func:`solve_capped`. ``prior_counts``
    ``(N,)`` and ``prior_sums`` ``(N, n_features)``, when given, are added to
    them: points of each cluster that are not in ``X`` and are never
    reassigned (the earlier members ``partial_fit`` keeps as statistics).
    Without ``paper`` nodes left with no point are moved to the points
    farthest from their nodes, as k-means does (EM stops instead when ``X``
    has fewer points than empty nodes, or the farthest of those points lie
    on their nodes). EM also stops when the squared node displacement is at
    most ``tol``.

    Returns
    -------
    nodes : ndarray of shape (N, n_features)
    n_iter : int
        Rounds run.

    Examples
    --------
    >>> X = np.array([[0.0], [1.0], [10.0], [11.0]])
    >>> nodes, n_iter = em_nodes(X, np.array([[0.0], [1.0]]), stretch=0.0, max_iter=20, tol=0.0, paper=False)
    >>> nodes.ravel().tolist(), n_iter
    ([0.5, 10.5], 3)
    >>> em_nodes(X, nodes, stretch=0.0, max_iter=20, tol=0.0, paper=False, prior_counts=np.array([2.0, 0.0]),
    ...          prior_sums=np.array([[5.0], [0.0]]))[0].ravel().tolist()
    [1.5, 10.5]
    """
    nodes = nodes.copy()
    n = nodes.shape[0]
    n_iter = 0
    for _ in range(max_iter):
        n_iter += 1
        labels, d2 = assign(X, nodes, x_sq)
        counts, sums = cluster_sums(X, labels, n)
        if prior_counts is not None:
            counts, sums = prior_counts + counts, prior_sums + sums
        if paper:
            new = solve_paper(counts, sums, stretch)
        else:
            empty = np.flatnonzero(counts == 0)
            if empty.size:
                far = np.argsort(-d2, kind="stable")[:empty.size]
                # With prior counts the nodes may outnumber the points of X.
                if far.size < empty.size or d2[far[-1]] == 0.0:
                    break
                nodes[empty] = X[far]
                continue
            new, _ = solve_capped(counts, sums, stretch)
        if not np.all(np.isfinite(new)):
            raise ValueError(f"stretch: the node equations have no finite solution with stretch={stretch!r}; "
                             "use a smaller stretching constant")
        moved = float(np.sum((new - nodes) ** 2))
        nodes = new
        if moved <= tol:
            break
    return nodes, n_iter


def stretch_energy(nodes: np.ndarray) -> float:
    """``sum_{i<j} ||x_i - x_j||^2`` computed as ``N sum ||x_i - m||^2`` (m: the nodes' mean)."""
    centred = nodes - nodes.mean(axis=0)
    return float(nodes.shape[0] * np.sum(centred * centred))


def selection_energy(u_x: float, nodes: np.ndarray, stretch: float) -> float:
    """The energy that decides the number of clusters: ``U_X + lambda sum_{i<j} ||x_i - x_j||^2``."""
    return float(u_x + stretch * stretch_energy(nodes))


def _sorted_slices(labels: np.ndarray, counts: np.ndarray):
    order = np.argsort(labels, kind="stable")
    stops = np.cumsum(counts.astype(np.intp))
    return order, stops - counts.astype(np.intp), stops


def closest_separation(X: np.ndarray, labels: np.ndarray, n_clusters: int) -> float:
    """The smallest :func:`pairwise_separation` between two different clusters; ``inf`` for one cluster.

    Examples
    --------
    >>> X = np.array([[0.0], [1.0], [10.0], [11.0]])
    >>> round(closest_separation(X, np.array([0, 0, 1, 1]), 2), 4)
    9.02
    >>> closest_separation(X, np.zeros(4, int), 1)
    inf
    """
    if n_clusters == 1:
        return np.inf
    delta = pairwise_separation(X, labels, n_clusters)
    return float(np.min(delta[~np.eye(n_clusters, dtype=bool)]))


def pairwise_separation(X: np.ndarray, labels: np.ndarray, n_clusters: int) -> np.ndarray:
    """Separation of every pair of clusters along the line joining their means.

    ``delta_ij = g_ij / ((s_i + s_j) / 2)`` with ``g_ij^2 = ||m_i - m_j||^2 -
    tr(S_i) / n_i - tr(S_j) / n_j`` (the squared distance between the means
    minus its expected sampling noise, floored at 0) and ``s_i`` the standard
    deviation of cluster i projected on that line (``n_i - 1`` degrees of
    freedom), shrunk towards ``s_j`` with the weight of ``PRIOR_COUNT`` points
    so that a handful of tail points is not mistaken for a tight cluster. ``inf`` when neither
    cluster spreads along the line (repeated points); ``0`` on the diagonal,
    for empty clusters and for two single-point clusters (no spread can be
    measured, so no evidence of a gap).

    Examples
    --------
    >>> X = np.array([[0.0], [1.0], [10.0], [11.0]])
    >>> round(float(pairwise_separation(X, np.array([0, 0, 1, 1]), 2)[0, 1]), 4)
    9.02
    """
    counts, sums = cluster_sums(X, labels, n_clusters)
    filled = counts > 0
    means = np.zeros_like(sums)
    means[filled] = sums[filled] / counts[filled, None]
    diff = means[None, :, :] - means[:, None, :]
    dist = np.sqrt(np.einsum("ijk,ijk->ij", diff, diff))
    with np.errstate(invalid="ignore", divide="ignore"):
        units = np.where(dist[:, :, None] > 0, diff / dist[:, :, None], 0.0)
    centred = X - means[labels]
    # ||m_i - m_j||^2 overestimates the squared gap by the noise of both means,
    # tr(S_i) / n_i + tr(S_j) / n_j; subtract it, with tr(S_i) shrunk like the spreads below
    # (so that a single point, which has no spread, is measured by its partner's).
    within = np.bincount(labels, weights=np.einsum("ij,ij->i", centred, centred), minlength=n_clusters)
    dof = np.maximum(counts - 1.0, 0.0)[:, None]
    trace = _shrink(within[:, None] / np.maximum(dof, 1.0), dof)
    noise = trace / np.maximum(counts, 1.0)[:, None]
    dist = np.sqrt(np.maximum(dist * dist - noise - noise.T, 0.0))
    order, starts, stops = _sorted_slices(labels, counts)
    half = np.zeros((n_clusters, n_clusters))
    for i in np.flatnonzero(filled):  # one vectorised projection per cluster, not per point
        proj = centred[order[starts[i]:stops[i]]] @ units[i].T
        half[i] = np.einsum("ij,ij->j", proj, proj)
    # Each cluster's variance along the line, shrunk towards its partner's with the weight of
    # PRIOR_COUNT points: a few tail points of one blob look tight only by chance.
    var = _shrink(half / np.maximum(dof, 1.0), dof)
    spread = 0.5 * (np.sqrt(var) + np.sqrt(var.T))
    # a spread at the round-off level of the data is no spread (repeated points, or
    # points that differ only across the line): treat it as zero, not as a tiny divisor
    spread = np.where(spread > 1e-9 * max(1.0, float(np.abs(X).max(initial=0.0))), spread, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        delta = np.where(spread > 0, dist / spread, np.where(dist > 0, np.inf, 0.0))
    delta = _lower_bound(delta, counts[:, None], counts[None, :])
    single = dof == 0
    delta[single & single.T] = 0.0  # two single points: no spread can be measured, no evidence of a gap
    delta[~filled, :] = 0.0
    delta[:, ~filled] = 0.0
    np.fill_diagonal(delta, 0.0)
    # the pair is judged once: round-off must not make i-j and j-i disagree
    return np.minimum(delta, delta.T)


def _lower_bound(delta, n_i, n_j):
    """``delta`` minus one standard error, ``sqrt(1/n_i + 1/n_j + delta^2 / (2 (n_i + n_j)))``.

    The approximate standard error of a standardised mean difference (Hedges
    and Olkin); it vanishes as clusters grow, so large clusters are judged by
    ``delta`` alone while a few points need a wider gap. Infinite stays infinite.
    """
    n_i = np.maximum(n_i, 1.0)
    n_j = np.maximum(n_j, 1.0)
    with np.errstate(invalid="ignore"):
        se = np.sqrt(1.0 / n_i + 1.0 / n_j + np.square(delta) / (2.0 * (n_i + n_j)))
        return np.where(np.isinf(delta), delta, np.maximum(delta - se, 0.0))


def _shrink(value: np.ndarray, dof: np.ndarray) -> np.ndarray:
    """Pairwise shrinkage ``(dof_i v_ij + PRIOR_COUNT v_ji) / (dof_i + PRIOR_COUNT)``."""
    return (dof * value + PRIOR_COUNT * value.T) / (dof + PRIOR_COUNT)


def local_splits(X, labels, n_clusters, *, by="separation", n_axes=1, n_power=20, n_lloyd=10,
                 max_points=4096):
    """Best two-way split of each cluster: 2-means seeded along its leading principal axes.

    For each of the ``n_axes`` leading principal axes (block power iteration)
    the projections are cut by 1-D 2-means and the two halves refined by
    2-means in the full feature space (so that a cluster holding three blobs
    is cut one-against-two, not through the middle blob). Of these candidate
    splits the one with the largest ``by`` is kept. Clusters larger than
    ``max_points`` are represented by a regular subsample.

    Returns
    -------
    separation : ndarray of shape (N,)
        ``delta`` of the two halves (as in :func:`pairwise_separation`), 0 when
        the cluster cannot be split (fewer than 2 distinct points).
    gain : ndarray of shape (N,)
        Decrease of ``U_X`` from the split (Ward: ``n_a n_b / n |m_a - m_b|^2``).
    seeds : ndarray of shape (N, 2, n_features)
        Means of the two halves.

    Examples
    --------
    >>> X = np.array([[0.0], [1.0], [10.0], [11.0]])
    >>> sep, gain, seeds = local_splits(X, np.zeros(4, dtype=int), 1)
    >>> round(float(sep[0]), 4), float(gain[0]), sorted(seeds[0].ravel().tolist())
    (9.02, 100.0, [0.5, 10.5])
    """
    counts, sums = cluster_sums(X, labels, n_clusters)
    order, starts, stops = _sorted_slices(labels, counts)
    best = np.zeros((n_clusters, 2))  # (separation, gain) of the kept split
    seeds = np.zeros((n_clusters, 2, X.shape[1]))
    key = 0 if by == "separation" else 1
    for i in range(n_clusters):  # loop over clusters; every step inside is vectorised over points
        if counts[i] < 2:
            continue
        mean = sums[i] / counts[i]
        # A regular subsample is plenty to choose and seed a split, and keeps this O(N max_points).
        step = -(-int(counts[i]) // max_points)
        Z = X[order[starts[i]:stops[i]:step]] - mean
        for v in _principal_axes(Z, n_axes, n_power):
            right = _cut_1d(Z @ v, n_lloyd)
            for _ in range(n_lloyd):
                if right.all() or not right.any():
                    break
                m_r, m_l = Z[right].mean(axis=0), Z[~right].mean(axis=0)
                # Nearer to m_r than to m_l  <=>  beyond the midpoint along m_r - m_l.
                new = (Z - 0.5 * (m_r + m_l)) @ (m_r - m_l) > 0.0
                if np.array_equal(new, right):
                    break
                right = new
            score = _split_score(Z, right)
            if score is not None and score[key] > best[i, key]:
                best[i] = score[0], score[1] * step  # the gain of the whole cluster
                seeds[i] = np.stack([score[2], score[3]]) + mean
    return best[:, 0], best[:, 1], seeds


def _principal_axes(Z: np.ndarray, n_axes: int, n_power: int) -> np.ndarray:
    """Leading principal axes of centred points ``Z`` (rows of the result), by block power iteration."""
    sq = np.einsum("ij,ij->i", Z, Z)
    if sq.max() == 0.0:
        return np.zeros((0, Z.shape[1]))
    k = min(n_axes, Z.shape[1], Z.shape[0])
    # Start from the farthest points: deterministic and already near the spread directions.
    Q = Z[np.argsort(-sq, kind="stable")[:k]].T
    for _ in range(n_power):
        Q, r = np.linalg.qr(Z.T @ (Z @ Q))
    Q, r = np.linalg.qr(Z.T @ (Z @ Q))
    keep = np.abs(np.diag(r)) > 1e-12 * np.abs(r[0, 0])
    return Q[:, keep].T


def _split_score(Z: np.ndarray, right: np.ndarray):
    n_r = int(right.sum())
    n_l = right.shape[0] - n_r
    if n_r == 0 or n_l == 0:
        return None
    m_r, m_l = Z[right].mean(axis=0), Z[~right].mean(axis=0)
    dm = m_r - m_l
    dist = float(np.linalg.norm(dm))
    if dist == 0.0:
        return None
    u = dm / dist
    dof = np.array([[n_l - 1.0], [n_r - 1.0]])
    halves = (Z[~right] - m_l, Z[right] - m_r)
    # Same estimates as pairwise_separation, for the two halves.
    trace = _shrink(np.array([[np.sum(h * h)] * 2 for h in halves]) / np.maximum(dof, 1.0), dof)
    var = _shrink(np.array([[np.sum((h @ u) ** 2)] * 2 for h in halves]) / np.maximum(dof, 1.0), dof)
    gain = n_r * n_l / (n_r + n_l) * dist * dist
    dist = np.sqrt(max(dist * dist - trace[0, 1] / n_l - trace[1, 0] / n_r, 0.0))
    sd_l, sd_r = np.sqrt(var[0, 1]), np.sqrt(var[1, 0])
    spread = 0.5 * (sd_r + sd_l)
    if n_r + n_l <= 2:
        sep = 0.0
    else:
        sep = float(_lower_bound(np.inf if spread == 0.0 else dist / spread, n_l, n_r))
    return sep, gain, m_l, m_r


def _cut_1d(p: np.ndarray, n_iter: int) -> np.ndarray:
    """1-D 2-means on projections ``p`` (mean zero); returns the mask of the upper group."""
    cut = 0.0
    for _ in range(n_iter):
        right = p > cut
        if right.all() or not right.any():
            break
        new_cut = 0.5 * (p[right].mean() + p[~right].mean())
        if new_cut == cut:
            break
        cut = new_cut
    return p > cut
