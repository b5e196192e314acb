"""Is a cluster one skill? The best split of its points against the best split of one Gaussian.

Both criteria of :class:`ElasticClustering` that choose the number of
clusters judge a split by its separation ``delta`` (gap between the means
over the clusters' spread, :func:`~._em.pairwise_separation`) against one
fixed threshold. The spread of ``delta`` itself depends on the number of
points: 7 demonstrations of one letter, featurised in 3 dimensions, can be
cut so that ``delta`` is 5 or 50 by chance (two of them happen to be nearly
equal, so a half looks tight), while a thousand points of one Gaussian never
give much more than 2.65. Here a split is compared with what splitting *one
cluster* of the same size and shape gives: the null hypothesis is one
Gaussian with the points' own covariance (its sample eigenvalues, as
SigClust does: Liu, Hayes, Nobel and Marron, "Statistical significance of
clustering for high-dimension, low-sample-size data", JASA 2008), and the
statistic is the ``delta`` of the best two-way split found by the same
procedure on the data and on each draw (2-means seeded along the principal
axis, as the ``"auto"`` criterion splits). The p-value is the fraction of
draws split at least as cleanly.

The sample eigenvalues include the spread *between* the two clusters when
there are two, so the null is as elongated as the data; ``delta`` is
measured along the split and is scale-free, so this costs little power, and
the null is, if anything, conservative (it keeps fewer clusters apart).
"""

from __future__ import annotations

import numpy as np

from ._em import PRIOR_COUNT, pairwise_separation
from ._hierarchy import MIN_MEMBERS
from ._primitive import nearest_centre

__all__ = ["split_separation", "split_p_value", "merge_insignificant", "N_DRAWS", "MAX_TEST_POINTS"]

#: Draws from the null per test: p-values resolve 1 / (N_DRAWS + 1).
N_DRAWS = 200
#: Points a test splits at most; larger unions are tested on a regular sample of this many (the
#: sampling noise of ``delta`` is already small there, and the cost stays bounded).
MAX_TEST_POINTS = 256
# Draws computed at once (memory: this many times points times dimensions floats).
_CHUNK = 64
# Rounds of the 1-D cut and of the 2-means refinement, as in the estimator's own splits.
_N_LLOYD = 10


def split_separation(Z) -> np.ndarray:
    """``delta`` of the best two-way split of each of a batch of point sets.

    The split is the one ``criterion="auto"`` makes of a cluster: the points
    are projected on their leading principal axis, cut in two by 1-D
    2-means, and the halves refined by 2-means in the full space; ``delta``
    is then measured as :func:`~._em.local_splits` does (the gap between the
    halves' means less its sampling noise, over the halves' spreads along the
    line joining them, each shrunk towards the other's with the weight of
    ``PRIOR_COUNT`` points, minus one standard error).

    Parameters
    ----------
    Z : ndarray of shape (n_sets, n_points, n_features)
        Each set is split on its own.

    Returns
    -------
    ndarray of shape (n_sets,)
        0 for a set of two or fewer points or with no spread; ``inf`` when
        both halves are single repeated points.

    Examples
    --------
    >>> Z = np.array([[[0.0], [1.0], [10.0], [11.0]]])
    >>> round(float(split_separation(Z)[0]), 4)
    9.02
    """
    Z = np.asarray(Z, dtype=float)
    b, n, _ = Z.shape
    if n <= 2:
        return np.zeros(b)
    Z = Z - Z.mean(axis=1, keepdims=True)
    p = Z @ _leading_axis(Z)[:, :, None]
    p = p[:, :, 0]
    right = _cut_1d(p)
    for _ in range(_N_LLOYD):
        n_r = right.sum(axis=1)
        live = (n_r > 0) & (n_r < n)
        m_r, m_l = _half_means(Z, right)
        # nearer to m_r than to m_l  <=>  beyond the midpoint along m_r - m_l
        d = m_r - m_l
        new = (Z @ d[:, :, None])[:, :, 0] > np.einsum("bk,bk->b", 0.5 * (m_r + m_l), d)[:, None]
        # a set whose split would leave one side empty keeps its last split (the estimator stops there)
        new[~live] = right[~live]
        if np.array_equal(new, right):
            break
        right = new
    return _score(Z, right)


def _leading_axis(Z: np.ndarray, n_power: int = 20) -> np.ndarray:
    """Leading principal axis of each centred set, by power iteration from its farthest point.

    As the estimator's ``_principal_axes``: ``n_power`` products with the
    scatter matrix, each O(points x features), where an eigendecomposition
    would cost O(features^3) per set.
    """
    sq = np.einsum("bnk,bnk->bn", Z, Z)
    q = np.take_along_axis(Z, np.argmax(sq, axis=1)[:, None, None], axis=1)[:, 0, :]
    for _ in range(n_power + 1):
        q = (np.swapaxes(Z, 1, 2) @ (Z @ q[:, :, None]))[:, :, 0]
        norm = np.linalg.norm(q, axis=1)
        q = q / np.where(norm > 0.0, norm, 1.0)[:, None]
    return q


def _cut_1d(p: np.ndarray) -> np.ndarray:
    """Batched 1-D 2-means of projections ``p`` (each row has mean zero): the masks of the upper groups."""
    cut = np.zeros(p.shape[0])
    for _ in range(_N_LLOYD):
        right = p > cut[:, None]
        n_r = right.sum(axis=1)
        live = (n_r > 0) & (n_r < p.shape[1])
        upper = np.where(right, p, 0.0).sum(axis=1) / np.maximum(n_r, 1)
        lower = np.where(right, 0.0, p).sum(axis=1) / np.maximum(p.shape[1] - n_r, 1)
        new = np.where(live, 0.5 * (upper + lower), cut)
        if np.array_equal(new, cut):
            break
        cut = new
    return p > cut[:, None]


def _half_means(Z, right):
    n_r = right.sum(axis=1)
    n_l = Z.shape[1] - n_r
    m_r = (right[:, None, :] @ Z)[:, 0, :] / np.maximum(n_r, 1)[:, None]
    m_l = ((~right)[:, None, :] @ Z)[:, 0, :] / np.maximum(n_l, 1)[:, None]
    return m_r, m_l


def _score(Z, right) -> np.ndarray:
    """``delta`` of the split ``right`` of each set (the estimator's ``_split_score``, batched)."""
    n = Z.shape[1]
    n_r = right.sum(axis=1).astype(float)
    n_l = n - n_r
    m_r, m_l = _half_means(Z, right)
    dm = m_r - m_l
    dist = np.sqrt(np.einsum("bk,bk->b", dm, dm))
    valid = (n_r > 0) & (n_l > 0) & (dist > 0.0)
    u = dm / np.where(dist > 0.0, dist, 1.0)[:, None]
    centred = Z - np.where(right[:, :, None], m_r[:, None, :], m_l[:, None, :])
    sq = np.einsum("bnk,bnk->bn", centred, centred)
    along = (centred @ u[:, :, None])[:, :, 0] ** 2
    dof_l, dof_r = n_l - 1.0, n_r - 1.0

    def shrunk(total):  # each half's variance, shrunk towards the other's with PRIOR_COUNT points' weight
        v_l = np.where(right, 0.0, total).sum(axis=1) / np.maximum(dof_l, 1.0)
        v_r = np.where(right, total, 0.0).sum(axis=1) / np.maximum(dof_r, 1.0)
        return ((dof_l * v_l + PRIOR_COUNT * v_r) / (dof_l + PRIOR_COUNT),
                (dof_r * v_r + PRIOR_COUNT * v_l) / (dof_r + PRIOR_COUNT))

    tr_l, tr_r = shrunk(sq)
    var_l, var_r = shrunk(along)
    gap = np.sqrt(np.maximum(dist * dist - tr_l / np.maximum(n_l, 1.0) - tr_r / np.maximum(n_r, 1.0), 0.0))
    spread = 0.5 * (np.sqrt(var_l) + np.sqrt(var_r))
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.where(spread > 0.0, gap / spread, np.inf)
        # minus one standard error (Hedges and Olkin), as the estimator's _lower_bound
        se = np.sqrt(1.0 / np.maximum(n_l, 1.0) + 1.0 / np.maximum(n_r, 1.0)
                     + np.square(delta) / (2.0 * n))
        delta = np.where(np.isinf(delta), delta, np.maximum(delta - se, 0.0))
    return np.where(valid, delta, 0.0)


def split_p_value(Y, rng, *, labels=None, n_draws: int = N_DRAWS) -> tuple[float, float]:
    """How often one Gaussian cluster like ``Y`` splits at least as cleanly as ``Y`` is split.

    Parameters
    ----------
    Y : ndarray of shape (n_points, n_features)
        The points of one (candidate) cluster; at most ``MAX_TEST_POINTS`` are used, a regular sample.
    rng : numpy.random.Generator
        Draws the null samples.
    labels : ndarray of shape (n_points,), optional
        A split of ``Y`` into two clusters (0 and 1) to judge: the one a
        clustering found. Default: ``Y``'s own best split
        (:func:`split_separation`). Either way each draw is split as
        :func:`split_separation` splits, which is how ``criterion="auto"``
        splits one cluster.
    n_draws : int, default=N_DRAWS

    Returns
    -------
    p_value : float
        ``(1 + #{draws with delta >= delta of Y}) / (n_draws + 1)``; 1 when
        the split has no separation (two or fewer points, or no gap).
    delta : float
        The separation of the split of ``Y`` judged.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> two = np.concatenate([rng.normal(0.0, 1.0, (20, 2)), rng.normal(8.0, 1.0, (20, 2))])
    >>> split_p_value(two, rng)[0] < 0.01
    True
    >>> split_p_value(rng.normal(0.0, 1.0, (40, 2)), rng)[0] > 0.01
    True
    """
    Y = np.asarray(Y, dtype=float)
    step = -(-Y.shape[0] // MAX_TEST_POINTS)
    Y = Y[::step]
    Y = Y - Y.mean(axis=0)
    m = Y.shape[0]
    if labels is None:
        delta = float(split_separation(Y[None])[0])
    else:
        # the same estimate as the draws' (pairwise_separation is _score's formula), on the same sample
        labels = np.asarray(labels)[::step]
        delta = float(pairwise_separation(Y, labels, 2)[0, 1]) if np.unique(labels).size == 2 else 0.0
    if m <= 2 or delta == 0.0:
        return 1.0, delta
    # The null: a Gaussian with Y's sample eigenvalues, drawn in their eigenbasis (delta does not
    # depend on the rotation); at most m - 1 of them are non-zero.
    sv = np.linalg.svd(Y, compute_uv=False)
    var = sv * sv / (m - 1)
    var = var[var > 1e-12 * var[0]]
    scale = np.sqrt(var)
    beaten = 0
    for start in range(0, n_draws, _CHUNK):
        size = min(_CHUNK, n_draws - start)
        draws = rng.standard_normal((size, m, var.size)) * scale
        beaten += int(np.sum(split_separation(draws) >= delta))
    return (1.0 + beaten) / (n_draws + 1.0), delta


def _nearest(delta: np.ndarray, i: int) -> int:
    """The other cluster of smallest ``delta`` to cluster ``i`` (the first of equals: all may be ``inf``)."""
    others = np.flatnonzero(np.arange(delta.shape[0]) != i)
    return int(others[np.argmin(delta[i, others])])


def merge_insignificant(X, labels, n_clusters: int, *, level: float, rng):
    """Merge neighbouring clusters until each is a significant split from its nearest neighbour.

    Three steps, on the search's clusters:

    1. *Pieces.* A cluster of fewer than ``MIN_MEMBERS`` points has no
       spread of its own to measure a gap by (its ``delta`` leans on its
       partner's). Two such clusters that are nearest to each other (by
       distance between means, nearest pair first) are joined when the test
       below cannot tell them apart: the search may cut one skill into
       crumbs.
    2. *Skills.* Each cluster of at least ``MIN_MEMBERS`` points and its
       nearest such cluster (smallest ``delta``), its likeliest twin, are
       judged with :func:`split_p_value` on their own split. While some
       pair's p-value exceeds ``level`` the pair with the largest is merged
       (the weakest evidence of two skills) and the merged cluster's pairs
       are tested afresh. One skill thus ends as one cluster, however the
       search cut it.
    3. *Odd points.* What is still smaller than ``MIN_MEMBERS`` points is odd
       demonstrations, not a skill (as ``criterion="hierarchy"`` says): each
       point joins the nearest mean of a larger cluster. They are left out
       of step 2, where they would widen a cluster's spread and hide its gap.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
    labels : ndarray of shape (n_samples,)
        Clusters ``0 .. n_clusters - 1``, every one non-empty.
    n_clusters : int
    level : float
        Significance level in (0, 1).
    rng : numpy.random.Generator

    Returns
    -------
    labels : ndarray of shape (n_samples,)
        Renumbered ``0 .. k - 1`` in the order of each cluster's smallest old index.
    k : int
    p_values : ndarray of shape (k,)
        Each final cluster's largest p-value against a nearest neighbour of
        step 2 (``nan`` for a single cluster).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(0.0, 1.0, (9, 2))
    >>> labels, k, _ = merge_insignificant(X, np.arange(9) % 3, 3, level=0.01, rng=rng)
    >>> k, labels.tolist()
    (1, [0, 0, 0, 0, 0, 0, 0, 0, 0])
    """
    labels = np.asarray(labels).copy()
    alive = list(range(n_clusters))
    # the test compares separations with spreads, which one scale does not change: taken at unit scale,
    # points near the float bound (1e99) square without overflowing
    X = np.asarray(X, dtype=float)
    scale = float(np.abs(X).max()) if X.size else 0.0
    if np.isfinite(scale) and scale > 0.0:
        X = X / scale

    def size(c):
        return int(np.count_nonzero(labels == c))

    def p_value(a, b):  # of the split of a's and b's points into a and b
        members = np.flatnonzero((labels == a) | (labels == b))
        return split_p_value(X[members], rng, labels=(labels[members] == b).astype(np.intp))[0]

    # 1. pieces: mutually near crumbs, nearest pair first
    refused: set[bytes] = set()
    while len(alive) > 1:
        means = np.stack([X[labels == c].mean(axis=0) for c in alive])
        gaps = np.sqrt(((means[:, None, :] - means[None, :, :]) ** 2).sum(axis=2))
        np.fill_diagonal(gaps, np.inf)
        small = [i for i, c in enumerate(alive) if size(c) < MIN_MEMBERS]
        pieces = sorted((gaps[i, j], alive[i], alive[j]) for i in small
                        for j in [int(np.argmin(gaps[i]))] if size(alive[j]) < MIN_MEMBERS)
        for _, a, b in pieces:
            key = np.flatnonzero((labels == a) | (labels == b)).tobytes()
            if key not in refused:
                break
        else:
            break
        if p_value(a, b) > level:
            labels[labels == max(a, b)] = min(a, b)
            alive.remove(max(a, b))
        else:
            refused.add(key)

    # 2. skills: the weakest of the nearest pairs merged first, while one is not significant
    centred = X - X.mean(axis=0)
    big = [c for c in alive if size(c) >= MIN_MEMBERS]
    pairs: list[tuple[int, int]] = []
    p_of: dict[tuple[int, int], float] = {}
    while len(big) > 1:
        index = np.full(n_clusters, -1)
        index[big] = np.arange(len(big))
        inside = index[labels] >= 0
        delta = pairwise_separation(centred[inside], index[labels[inside]], len(big))
        pairs = sorted({tuple(sorted((big[i], big[_nearest(delta, i)]))) for i in range(len(big))})
        for pair in pairs:
            if pair not in p_of:  # a pair whose clusters did not change keeps its p-value
                p_of[pair] = p_value(*pair)
        # the largest p-value, ties to the pair of lowest indices (a deterministic order)
        worst = max(pairs, key=lambda q: (p_of[q], -q[0], -q[1]))
        if p_of[worst] <= level:
            break
        keep, gone = worst
        labels[labels == gone] = keep
        big.remove(gone)
        p_of = {q: v for q, v in p_of.items() if keep not in q and gone not in q}
        pairs = []

    # 3. odd points join the nearest larger cluster (all are one when no cluster is large enough)
    if not big:
        big = [alive[0]]
        labels[:] = alive[0]
    odd = ~np.isin(labels, big)
    if odd.any():
        means = np.stack([X[labels == c].mean(axis=0) for c in big])
        labels[odd] = np.asarray(big)[nearest_centre(X[odd], means)]
    index = np.full(n_clusters, -1)
    index[big] = np.arange(len(big))
    p_values = np.full(len(big), np.nan)
    for a, b in pairs:
        for c in (a, b):
            p_values[index[c]] = np.fmax(p_values[index[c]], p_of[(a, b)])
    return index[labels].astype(np.intp), len(big), p_values
