"""``criterion="hierarchy"``: the number of clusters from the cuts of a Ward tree, judged by separation."""

from __future__ import annotations

import numpy as np

from ._em import closest_separation

__all__ = ["hierarchy_seeds", "MIN_MEMBERS"]

#: Fewest members of a cluster: with fewer, its spread along a line has at most one degree of freedom.
MIN_MEMBERS = 3
# Rows the tree is built on; larger data is represented by a regular sample of this many rows.
_MAX_TREE_POINTS = 2000


def hierarchy_seeds(X, *, min_separation: float, max_clusters: int, rng) -> tuple[np.ndarray, list]:
    """Node seeds of the most detailed well-separated cut of the Ward tree of ``X``.

    The Ward tree orders the partitions from coarse to fine. A cut into k
    groups is *valid* when every pair of its clusters (groups of at least
    ``MIN_MEMBERS`` points; smaller groups are outliers that join their
    nearest cluster) is at least ``min_separation`` apart by
    :func:`pairwise_separation` (in ``_em``). The cut with the most clusters is kept.
    Unlike growing one node at a time and stopping at the first refused
    split, this finds 26 separate shapes even when no split of the whole
    set into two halves is clean (each half mixes many shapes).

    Returns
    -------
    seeds : ndarray of shape (n_clusters, n_features)
        Means of the kept clusters.
    path : list of (k, n_clusters, min_separation)
        Each cut tried.
    """
    # scipy is imported here: only this criterion needs its hierarchical clustering.
    from scipy.cluster.hierarchy import fcluster, ward

    m = X.shape[0]
    sample = X if m <= _MAX_TREE_POINTS else X[np.sort(rng.choice(m, _MAX_TREE_POINTS, replace=False))]
    tree = ward(sample)
    best = (1, sample.mean(axis=0)[None, :])
    path = []
    k = 2
    stop = min(sample.shape[0], max_clusters * MIN_MEMBERS)
    while k <= stop:
        labels = fcluster(tree, k, "maxclust") - 1
        counts = np.bincount(labels, minlength=k)
        real = np.flatnonzero(counts >= MIN_MEMBERS)
        if real.size > max_clusters:
            break
        if real.size >= 2:
            inside = np.isin(labels, real)
            index = np.full(k, -1)
            index[real] = np.arange(real.size)
            sep = closest_separation(sample[inside], index[labels[inside]], real.size)
            path.append((k, int(real.size), sep))
            if sep >= min_separation and real.size > best[0]:
                means = np.stack([sample[labels == c].mean(axis=0) for c in real])
                best = (int(real.size), means)
        # Past twice the best count plus a few cuts, finer cuts only chip pieces off the clusters found.
        if k > 2 * best[0] + 8:
            break
        k += 1
    return best[1], path
