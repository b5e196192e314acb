"""Incremental elastic clustering: each cluster kept as sufficient statistics, not as its points.

A cluster is summarised by its count ``n``, mean ``m`` and scatter matrix
``C = sum (x - m)(x - m)^T`` (``n_features`` squared numbers), as mini-batch
k-means keeps counts. These are exactly what the elastic map needs: the node
equations use counts and sums (``n m``), the energy ``U_X`` of a cluster about
a node ``x`` is ``tr(C) + n ||m - x||^2``, and the separation ``delta`` of two
clusters (:func:`pairwise_separation` in ``_em``) uses their counts, means,
the trace of their covariances and their variances along the line joining
the means (``u^T C u``). Statistics of two sets combine exactly
(:func:`merge`), so memory is ``O(n_clusters n_features^2)`` however many
points have been seen.

:func:`grow` is one ``partial_fit``: the points seen before stay in the
cluster they joined (their statistics are frozen to it), the new batch is
assigned and EM runs on it with the frozen statistics counted in every node
update; new clusters are then split off as in ``criterion="auto"``. To split a
cluster whose earlier members are two groups, each cluster also keeps a
uniform sample of at most ``SAMPLE_SIZE`` of its members (bottom-k sampling:
every point draws a random key, a cluster keeps its members whose key is below
its threshold ``tau``, lowering ``tau`` to keep at most ``SAMPLE_SIZE``; the
members of a sample that fall on one side of a split are a uniform sample of
that side). A split is searched on the sample (each point weighted by the
members it stands for) together with the batch; when the sample falls on both
sides, the earlier members' statistics are divided in proportion, estimated
from the sample's halves (exact while a cluster has at most ``SAMPLE_SIZE``
members).

The estimator comes here only once a cluster has more members than
``SAMPLE_SIZE``: until then the samples would be every point, so it keeps the
points themselves (in the order they came, which ``fit`` depends on) and
refits them with each batch, :func:`keep_indices` carrying the indices of the
clusters that persist over to the refit.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ._em import (
    _cut_1d,
    _lower_bound,
    _principal_axes,
    _shrink,
    assign,
    cluster_sums,
    em_nodes,
    selection_energy,
)

__all__ = ["Stats", "Sample", "point_stats", "merge", "pooled", "separation", "energy", "sample_of", "grow",
           "keep_indices", "SAMPLE_SIZE"]

#: Earlier members of a cluster kept as a uniform sample, to split it when new points show it is two.
SAMPLE_SIZE = 1000
_LOOKAHEAD = 3  # as ElasticClustering.fit: invalid maps in a row before the search stops
_N_LLOYD = 10


class Stats(NamedTuple):
    """Statistics of N clusters: counts ``(N,)``, means ``(N, d)``, scatter matrices ``(N, d, d)``."""

    counts: np.ndarray
    means: np.ndarray
    scatter: np.ndarray

    def take(self, index) -> Stats:
        return Stats(self.counts[index], self.means[index], self.scatter[index])

    def shifted(self, offset) -> Stats:
        """The same clusters in coordinates moved by ``-offset`` (the scatter does not change)."""
        return Stats(self.counts, self.means - offset, self.scatter)


def point_stats(X: np.ndarray, labels: np.ndarray, n_clusters: int) -> Stats:
    """Statistics of the points ``X`` of each of ``n_clusters`` clusters (empty clusters: zeros).

    Examples
    --------
    >>> s = point_stats(np.array([[0.0], [2.0], [5.0]]), np.array([0, 0, 1]), 2)
    >>> s.counts.tolist(), s.means.ravel().tolist(), s.scatter.ravel().tolist()
    ([2.0, 1.0], [1.0, 5.0], [2.0, 0.0])
    """
    counts, sums = cluster_sums(X, labels, n_clusters)
    means = np.zeros_like(sums)
    filled = counts > 0
    means[filled] = sums[filled] / counts[filled, None]
    centred = X - means[labels]
    order = np.argsort(labels, kind="stable")
    stops = np.cumsum(counts.astype(np.intp))
    scatter = np.zeros((n_clusters, X.shape[1], X.shape[1]))
    for i in np.flatnonzero(filled):  # one matrix product per cluster
        Z = centred[order[stops[i] - int(counts[i]):stops[i]]]
        scatter[i] = Z.T @ Z
    return Stats(counts, means, scatter)


def merge(a: Stats, b: Stats) -> Stats:
    """Statistics of the union of two sets of points, cluster by cluster (Chan et al.'s update).

    Examples
    --------
    >>> X = np.array([[0.0], [2.0], [5.0], [7.0]])
    >>> one = lambda rows: point_stats(X[rows], np.zeros(len(rows), int), 1)
    >>> m = merge(one([0, 1]), one([2, 3]))
    >>> m.counts.tolist(), m.means.ravel().tolist(), m.scatter.ravel().tolist()
    ([4.0], [3.5], [29.0])
    """
    n = a.counts + b.counts
    w = np.divide(b.counts, n, out=np.zeros_like(n), where=n > 0)
    delta = b.means - a.means
    means = a.means + w[:, None] * delta
    # n_a n_b / n = n_a w: the spread the gap between the two means adds
    cross = (a.counts * w)[:, None, None] * delta[:, :, None] * delta[:, None, :]
    return Stats(n, means, a.scatter + b.scatter + cross)


def energy(stats: Stats, nodes: np.ndarray) -> float:
    """``U_X``, each point's squared distance to its node: ``sum tr(C_i) + n_i ||m_i - x_i||^2``."""
    gap = stats.means - nodes
    within = np.trace(stats.scatter, axis1=1, axis2=2).sum()
    return float(within + np.sum(stats.counts * np.sum(gap * gap, axis=1)))


def separation(stats: Stats, scale: float) -> np.ndarray:
    """``delta`` of every pair of clusters from their statistics, as ``_em.pairwise_separation`` on points.

    ``scale`` is the largest absolute coordinate of the points (in the same
    coordinates as ``stats``): below ``1e-9`` of it a spread is round-off.

    Examples
    --------
    >>> s = point_stats(np.array([[0.0], [1.0], [10.0], [11.0]]), np.array([0, 0, 1, 1]), 2)
    >>> round(float(separation(s, 11.0)[0, 1]), 4)
    9.02
    """
    counts, means, scatter = stats
    n = counts.shape[0]
    filled = counts > 0
    diff = means[None, :, :] - means[:, None, :]
    dist = np.sqrt(np.einsum("ijk,ijk->ij", diff, diff))
    with np.errstate(invalid="ignore", divide="ignore"):
        units = np.where(dist[:, :, None] > 0, diff / dist[:, :, None], 0.0)
    within = np.trace(scatter, axis1=1, axis2=2)
    dof = np.maximum(counts - 1.0, 0.0)[:, None]
    trace = _shrink(within[:, None] / np.maximum(dof, 1.0), dof)
    noise = trace / np.maximum(counts, 1.0)[:, None]
    dist = np.sqrt(np.maximum(dist * dist - noise - noise.T, 0.0))
    half = np.einsum("ijk,ikl,ijl->ij", units, scatter, units)  # u^T C_i u along each line
    var = _shrink(half / np.maximum(dof, 1.0), dof)
    spread = 0.5 * (np.sqrt(np.maximum(var, 0.0)) + np.sqrt(np.maximum(var.T, 0.0)))
    spread = np.where(spread > 1e-9 * max(1.0, float(scale)), spread, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        delta = np.where(spread > 0, dist / spread, np.where(dist > 0, np.inf, 0.0))
    delta = _lower_bound(delta, counts[:, None], counts[None, :])
    single = dof == 0
    delta[single & single.T] = 0.0
    delta[~filled, :] = 0.0
    delta[:, ~filled] = 0.0
    np.fill_diagonal(delta, 0.0)
    return np.minimum(delta, delta.T) if n else delta




class Sample(NamedTuple):
    """A uniform sample of a cluster's members: ``points`` ``(r, d)``, ``keys``, threshold ``tau``."""

    points: np.ndarray
    keys: np.ndarray
    tau: float

    def add(self, points, keys, size: int | None = None) -> Sample:
        """The sample after ``points`` (with random ``keys``) joined the cluster (``size``: SAMPLE_SIZE)."""
        size = SAMPLE_SIZE if size is None else size  # read at call time, so a test may lower it
        inside = keys < self.tau
        points, keys = np.vstack([self.points, points[inside]]), np.r_[self.keys, keys[inside]]
        if keys.shape[0] <= size:
            return Sample(points, keys, self.tau)
        order = np.argsort(keys, kind="stable")
        return Sample(points[order[:size]], keys[order[:size]], float(keys[order[size]]))


def sample_of(X, labels, keys, n_clusters: int, size: int | None = None) -> list:
    """The :class:`Sample` of each cluster of points ``X`` drawn with random ``keys`` in [0, 1).

    Examples
    --------
    >>> s = sample_of(np.arange(5.0)[:, None], np.array([0, 0, 0, 1, 1]), np.array([.5, .1, .9, .3, .2]), 2,
    ...               size=2)
    >>> s[0].points.ravel().tolist(), s[0].tau, s[1].points.ravel().tolist(), s[1].tau
    ([1.0, 0.0], 0.9, [3.0, 4.0], 1.0)
    """
    empty = Sample(np.zeros((0, X.shape[1])), np.zeros(0), 1.0)
    return [empty.add(X[labels == i], keys[labels == i], size) for i in range(n_clusters)]


def _blank(n: int, d: int) -> Stats:
    return Stats(np.zeros(n), np.zeros((n, d)), np.zeros((n, d, d)))


def _em(X, x_sq, old: Stats, nodes, p, tol_abs, paper: bool):
    """EM on the batch ``X`` with the frozen statistics ``old`` of each cluster counted in each update."""
    nodes, n_iter = em_nodes(X, nodes, stretch=p["stretch"], max_iter=p["max_iter"], tol=tol_abs, paper=paper,
                             x_sq=x_sq, prior_counts=old.counts, prior_sums=old.counts[:, None] * old.means)
    n = nodes.shape[0]
    labels, _ = assign(X, nodes, x_sq)
    stats = merge(old, point_stats(X, labels, n))
    return nodes, labels, stats, selection_energy(energy(stats, nodes), nodes, p["stretch"]), \
        bool(np.all(stats.counts > 0)), n_iter


def _two(a: Stats, b: Stats) -> Stats:
    return Stats(np.r_[a.counts, b.counts], np.vstack([a.means, b.means]),
                 np.concatenate([a.scatter, b.scatter]))


def _earlier_halves(S, right_s, old: Stats) -> Stats:
    """The earlier members' statistics ``old`` (one cluster), divided as their sample ``S`` is by ``right_s``.

    Exact while the sample holds every earlier member; otherwise each half
    is estimated from its part of the sample (counts and scatter scaled by
    the members a sampled point stands for).
    """
    if S.shape[0] == 0 or not right_s.any():
        return _two(old, _blank(1, old.means.shape[1]))
    if right_s.all():
        return _two(_blank(1, old.means.shape[1]), old)
    halves = point_stats(S, right_s.astype(np.intp), 2)
    f = old.counts[0] / S.shape[0]  # members each sampled point stands for (1: exact, all are sampled)
    return Stats(halves.counts * f, halves.means, halves.scatter * f)


def _split(S, B, old: Stats, scale):
    """Best two-way split of a cluster: earlier members' sample ``S`` (statistics ``old``), batch ``B``.

    Starts: the batch against the earlier members, and a cut along the
    weighted principal axis; each is refined by weighted 2-means. Returns
    ``(separation, gain, seeds (2, d), side of each sampled point)`` of the
    best by separation, or None.
    """
    P = np.vstack([S, B])
    r = S.shape[0]
    w = np.r_[np.full(r, old.counts[0] / r if r else 0.0), np.ones(B.shape[0])]
    if P.shape[0] < 2:
        return None
    starts = [np.r_[np.zeros(r, dtype=bool), np.ones(B.shape[0], dtype=bool)]] if r and B.shape[0] else []
    Z = P - w @ P / w.sum()
    for v in _principal_axes(Z * np.sqrt(w)[:, None], 1, 20):
        starts.append(_cut_1d(Z @ v, _N_LLOYD))
    best = None
    for right in starts:
        for _ in range(_N_LLOYD):
            if right.all() or not right.any():
                break
            m_r, m_l = w[right] @ P[right] / w[right].sum(), w[~right] @ P[~right] / w[~right].sum()
            new = (P - 0.5 * (m_r + m_l)) @ (m_r - m_l) > 0.0
            if np.array_equal(new, right):
                break
            right = new
        if right.all() or not right.any():
            continue
        # The side with most earlier members (else most points) keeps the cluster's index and identity.
        weight = w if r == 0 else w * (np.arange(P.shape[0]) < r)
        if weight[right].sum() > weight[~right].sum():
            right = ~right
        sides = merge(_earlier_halves(S, right[:r], old), point_stats(B, right[r:].astype(np.intp), 2))
        if np.any(sides.counts == 0):
            continue
        sep = float(separation(sides, scale)[0, 1])
        gap = sides.means[0] - sides.means[1]
        gain = float(sides.counts[0] * sides.counts[1] / sides.counts.sum() * gap @ gap)
        if best is None or sep > best[0]:
            best = (sep, gain, sides.means.copy(), right[:r].copy())
    return best


def _closest_new(delta: np.ndarray, n_old: int) -> float:
    """Smallest ``delta`` of a pair with at least one cluster new in this call (``inf`` when none)."""
    n = delta.shape[0]
    if n == n_old or n < 2:
        return np.inf
    pairs = ~np.eye(n, dtype=bool)
    pairs[:n_old, :n_old] = False
    return float(delta[pairs].min())


def grow(X, keys, old: Stats, samples: list, nodes, p, *, criterion: str, scale_of):
    """One ``partial_fit``: batch ``X`` (random ``keys``) joins the clusters ``old`` (``samples``, ``nodes``).

    Works in coordinates centred on the mean of everything seen. ``scale_of``
    maps the centring offset to the largest absolute centred coordinate.

    Returns
    -------
    nodes, labels (of the batch), stats, samples, energy, n_iter, path
        ``path`` is ``[(n_clusters, energy, smallest delta of a new cluster)]``
        of each map tried.
    """
    d = X.shape[1]
    total = merge(pooled(old), point_stats(X, np.zeros(X.shape[0], dtype=np.intp), 1))
    offset = total.means[0]
    scale = scale_of(offset)
    X, nodes, old = X - offset, nodes - offset, old.shifted(offset)
    samples = [q._replace(points=q.points - offset) for q in samples]
    tol_abs = p["tol"] * float(np.trace(total.scatter[0])) / total.counts[0] / d
    x_sq = np.einsum("ij,ij->i", X, X)
    paper = criterion == "paper"
    n_old = old.counts.shape[0]
    nodes, labels, stats, e, ok, n_iter = _em(X, x_sq, old, nodes, p, tol_abs, paper)
    path = [(n_old, e, np.inf)]
    target = p["n_fixed"]
    stop = target if target is not None else (p["cap"] if p["cap"] is not None else np.inf)
    best, failures = (nodes, labels, stats, old, samples, e, n_iter), 0
    while nodes.shape[0] < stop:
        n = nodes.shape[0]
        if paper:
            cand, c_old = np.vstack([nodes, X[-1:]]), _two(old, _blank(1, d))
            c_samples = samples + [Sample(np.zeros((0, d)), np.zeros(0), 1.0)]
        else:
            found = [_split(samples[i].points, X[labels == i], old.take([i]), scale) for i in range(n)]
            sep = np.array([-1.0 if f is None else f[0] for f in found])
            c = int(np.argmax(sep))
            if found[c] is None or found[c][1] <= 0.0:
                break
            _, _, seeds, side = found[c]
            cand = np.vstack([nodes[:c], seeds[:1], nodes[c + 1:], seeds[1:]])
            halves = _earlier_halves(samples[c].points, side, old.take([c]))
            c_old = Stats(*(np.concatenate([a[:c], h[:1], a[c + 1:], h[1:]])
                            for a, h in zip(old, halves, strict=True)))
            q = samples[c]
            c_samples = samples[:c] + [Sample(q.points[~side], q.keys[~side], q.tau)] + samples[c + 1:] + \
                [Sample(q.points[side], q.keys[side], q.tau)]
        c_nodes, c_labels, c_stats, c_e, c_ok, c_iter = _em(X, x_sq, c_old, cand, p, tol_abs, paper)
        min_sep = _closest_new(separation(c_stats, scale), n_old)
        path.append((n + 1, c_e, min_sep))
        if paper:
            if not c_e < best[5]:
                break
            best = (c_nodes, c_labels, c_stats, c_old, c_samples, c_e, c_iter)
            nodes, labels, old, samples = c_nodes, c_labels, c_old, c_samples
            continue
        if not c_ok:
            break
        nodes, labels, old, samples = c_nodes, c_labels, c_old, c_samples
        if min_sep >= p["min_sep"]:
            best, failures = (c_nodes, c_labels, c_stats, c_old, c_samples, c_e, c_iter), 0
        else:
            failures += 1  # as fit: an invalid map may lead to a valid one, so look a few nodes ahead
            if failures >= _LOOKAHEAD:
                break
    nodes, labels, stats, _, samples, e, n_iter = best
    samples = [q.add(X[labels == i] + offset, keys[labels == i])
               for i, q in enumerate(q._replace(points=q.points + offset) for q in samples)]
    return nodes + offset, labels, stats.shifted(-offset), samples, e, n_iter, path


def pooled(stats: Stats) -> Stats:
    """The statistics of all clusters together, as one cluster.

    Examples
    --------
    >>> s = pooled(point_stats(np.array([[0.0], [2.0], [4.0]]), np.array([0, 0, 1]), 2))
    >>> s.counts.tolist(), s.means.ravel().tolist(), s.scatter.ravel().tolist()
    ([3.0], [2.0], [8.0])
    """
    n = stats.counts.sum()
    mean = stats.counts @ stats.means / n
    gap = stats.means - mean
    scatter = stats.scatter.sum(axis=0) + np.einsum("i,ij,ik->jk", stats.counts, gap, gap)
    return Stats(n[None], mean[None], scatter[None])


def keep_indices(before, after, n_before: int, n_after: int) -> np.ndarray:
    """The index each of the ``n_after`` clusters of a refit takes: clusters that persist keep theirs.

    ``before`` and ``after`` are the clusters of the same earlier points
    before and after the refit. Old and refit clusters are paired greedily
    by the earlier points they share, most first (ties: the lower old index,
    then the lower refit index), each in at most one pair: a paired refit
    cluster persists and keeps its old index if that is below ``n_after``.
    The other refit clusters take the free indices in increasing order:
    first those that persist with an index out of range (merges or removals
    left fewer clusters; by old index), then the new ones (in the refit's
    order). With no cluster removed, new clusters are appended.

    Examples
    --------
    Old cluster 0 split in two (its larger part keeps index 0), a new cluster
    (refit cluster 3, no earlier points) appended:

    >>> keep_indices([0, 0, 0, 1], [0, 1, 1, 2], 2, 4).tolist()
    [2, 0, 1, 3]

    Old clusters 1 and 2 merged: the merged cluster keeps index 1.

    >>> keep_indices([0, 0, 1, 1, 2, 2], [1, 1, 0, 0, 0, 0], 3, 2).tolist()
    [1, 0]
    """
    before, after = np.asarray(before, dtype=np.intp), np.asarray(after, dtype=np.intp)
    shared = np.bincount(before * n_after + after, minlength=n_before * n_after)
    pairs = np.flatnonzero(shared)
    old, new = np.divmod(pairs, n_after)
    successor_of = np.full(n_after, -1, dtype=np.intp)  # the old index of each refit cluster that persists
    taken = np.zeros(n_before, dtype=bool)
    for k in np.lexsort((new, old, -shared[pairs])):
        if not taken[old[k]] and successor_of[new[k]] == -1:
            taken[old[k]], successor_of[new[k]] = True, old[k]
    index = np.where(successor_of < n_after, successor_of, -1)
    moved = np.flatnonzero(successor_of >= n_after)
    rest = np.r_[moved[np.argsort(successor_of[moved], kind="stable")], np.flatnonzero(successor_of == -1)]
    index[rest] = np.setdiff1d(np.arange(n_after), index)
    return index
