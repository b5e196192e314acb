"""Elastic clustering (the paper's Algorithm 1) as a scikit-learn clusterer."""

from __future__ import annotations

import numpy as np
import scipy.sparse
from sklearn.base import BaseEstimator, ClusterMixin
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from ..core._validation import check_array, check_finite_result, check_positive, numerical_errors
from . import _incremental
from ._em import (
    assign,
    closest_separation,
    em_nodes,
    local_splits,
    pairwise_separation,
    selection_energy,
)
from ._hierarchy import MIN_MEMBERS, hierarchy_seeds
from ._incremental import grow, keep_indices, point_stats, pooled, sample_of, separation
from ._primitive import nearest_centre
from ._significance import merge_insignificant

__all__ = ["ElasticClustering"]

_LOOKAHEAD = 3


class ElasticClustering(ClusterMixin, BaseEstimator):
    """Elastic clustering: cluster centres are the nodes of an elastic map.

    Each node is tied to the points of its cluster by springs (approximation
    energy ``U_X``, eq. 1) and repelled by every other node (stretching energy
    ``U_E = -lambda sum_{i<j} ||x_i - x_j||^2``, eq. 2). For a given number of
    nodes N the map is fitted by EM: assign every point to its nearest node,
    then solve the linear node equations ``(diag|kappa_i| - lambda L) x = C``
    (``L = N I - 1 1^T``, ``C_i`` the sum of cluster i), until the nodes stop
    moving or ``max_iter`` rounds. N grows one node at a time.

    Parameters
    ----------
    stretch : float, default=1.2
        Stretching constant lambda >= 0 (the paper's RAIL experiment uses 1.2).
    n_clusters : "auto" or int, default="auto"
        ``"auto"`` lets ``criterion`` choose N; an integer fixes it.
    criterion : {"auto", "hierarchy", "paper"}, default="auto"
        How N is chosen and how the node equations are solved.

        ``"hierarchy"`` judges whole partitions instead of one split at a
        time: it cuts the Ward tree of the points (of a regular sample of
        2,000 for larger data) at every depth, and keeps the cut with the
        most clusters whose every pair is ``min_separation`` apart by the
        same ``delta`` as ``"auto"``; groups of fewer than 3 points are
        outliers, not clusters (a single odd demonstration is not a skill)
        and join their nearest cluster. The elastic map is then fitted with
        that many nodes from the cut's means, as in ``"auto"``. It finds
        many small clusters (26 shapes of 7 demonstrations each) where
        ``"auto"`` stops because no split of the whole set in two is clean.

        ``"paper"`` reproduces the authors' algorithm: one node on a randomly
        chosen point, then each round a node is added at the *last* data point
        and EM is re-run from the previous nodes; the node system is solved by
        least squares exactly as written, even when it is singular or
        indefinite (a stretch larger than the smallest clusters: the nodes
        are then a saddle point of eq. 3, and for a huge stretch they
        collapse onto each other near the data mean); the larger
        map is kept while ``U_X + lambda sum_{i<j} ||x_i - x_j||^2`` falls.
        This energy grows with the number of points and the number of
        clusters found grows with it (4, 9, 15 clusters on the same 3 blobs at
        150, 1,500, 6,000 points with lambda = 0.4).

        ``"auto"`` makes N independent of the number of points and of the
        scale of the features. Nodes are added one at a time by splitting the
        most clearly bimodal cluster (2-means seeded along its principal axis)
        and re-running EM on all points. A map is *valid* when every pair of
        clusters i, j is at least ``min_separation`` apart, measured by
        ``delta_ij = g_ij / ((s_i + s_j) / 2) - SE``: the gap ``g_ij``
        between the cluster means (their distance less its sampling noise)
        in units of the clusters' standard deviations ``s_i, s_j`` along the
        line joining them, minus one standard error of that ratio. The
        search stops after 3 invalid maps in a row (three blobs on a line
        cannot be cut validly in two, so one invalid map is no reason to
        stop) and keeps the largest valid map (one node is always valid).
        ``delta`` is a ratio of lengths, hence scale-free, and of per-point
        averages, hence converging as points are added, where ``U_X`` grows
        without bound; the standard error vanishes for large clusters and
        only asks a few points (the tail of one blob) for a wider gap. For
        reference, a Gaussian cut in two gives ``delta`` = 2.65, a uniform
        slab 3.46, two equal Gaussians 4 sigma apart about 4: the default
        4.0 separates only clusters that are clearly apart, and close ones
        stay together, as the paper wants for "slight modifications of the
        same skill". Here lambda only shapes the nodes, and it is capped so
        that the repulsion softens no cluster's springs by more than 10 %
        (``diag|kappa| - lambda L >= 0.9 diag|kappa|``): eq. (3) then always
        has a minimum and a small cluster's node is not pushed off its own
        points. An emptied node is moved to the point farthest from its
        node. With few points per cluster in many dimensions (under ~20
        points with 10 or more features) ``delta`` is noisy and spurious
        splits become possible: reduce the dimension first (e.g.
        :class:`TrajectoryFeatures` keeps a few PCA components).
    max_clusters : int, optional
        Upper bound on N (default: the number of samples).
    min_separation : float, default=4.0
        Threshold on ``delta`` for ``criterion="auto"`` and ``"hierarchy"``.
    significance : float or None, default=0.01
        Level of the test that keeps two clusters apart (``"auto"`` and
        ``"hierarchy"`` with ``n_clusters="auto"``). A fixed threshold on
        ``delta`` is not enough for few points: 7 demonstrations of one
        letter can be cut so that ``delta`` is 5 or 50 by chance. So after
        the search, each cluster and its nearest neighbour (smallest
        ``delta``) are tested: their ``delta`` is compared with the ``delta``
        of the split ``"auto"`` makes of each of 200 draws of *one* Gaussian
        cluster with their union's size and sample covariance (SigClust's
        null), and the p-value is the fraction of draws split at least as
        cleanly. While some pair's p-value exceeds ``significance`` the pair
        with the largest is merged; then clusters of fewer than 3 members
        are odd demonstrations, not skills (as in ``"hierarchy"``), and their
        points join the nearest larger cluster; and the map is refitted from
        the merged means. One skill thus ends as one cluster however the
        search cut it. Clusters that are clearly apart have p-values at the
        floor, 1/201, and are not merged, so what a larger data set shows is
        kept. ``None`` keeps every cluster the search finds. Unions of more
        than 256 points are tested on a regular sample of 256.
    max_iter : int, default=20
        EM rounds per number of nodes (the authors use 20).
    tol : float, default=1e-4
        EM stops when the squared node displacement is below ``tol`` times
        the mean feature variance.
    random_state : int, RandomState instance or None, default=None
        Picks the point the first node starts on.

    Attributes
    ----------
    cluster_centers_ : ndarray of shape (n_clusters_, n_features)
        Node positions. Nodes that end with no points (possible in
        ``"paper"`` mode) are dropped.
    labels_ : ndarray of shape (n_samples,)
        Index of the nearest node of each training point (``predict(X)``);
        after :meth:`partial_fit`, the cluster each point of the batch joined.
    n_clusters_ : int
    energy_ : float
        ``U_X + lambda sum_{i<j} ||x_i - x_j||^2`` of the selected map.
    energy_path_ : ndarray of shape (n_tried,)
        The same energy for each number of nodes tried, in order.
    n_clusters_tried_ : ndarray of shape (n_tried,)
        The number of nodes of each entry of ``energy_path_``.
    separation_path_ : ndarray of shape (n_tried,)
        Smallest pairwise ``delta`` of each map tried (``inf`` for one node).
        With ``criterion="hierarchy"`` these three describe the cuts of the
        tree (number of clusters, ``nan`` energy, smallest ``delta``) and
        then the fitted map.
    cluster_sizes_ : ndarray of shape (n_clusters_,)
        Members of each cluster.
    separation_ : ndarray of shape (n_clusters_,)
        ``delta`` between each cluster and its nearest other cluster
        (``inf`` with one cluster): the evidence that it is a cluster of its own.
    p_values_ : ndarray of shape (n_clusters_,)
        The largest p-value of the tests of ``significance`` between each
        cluster and a nearest neighbour: the chance that one cluster of
        their joint size and shape splits as cleanly. ``nan`` where nothing
        was tested (one cluster, a fixed ``n_clusters``, ``"paper"``,
        ``significance=None``, or clusters made by an incremental
        :meth:`partial_fit`).
    n_iter_ : int
        EM rounds run for the selected map.
    n_samples_seen_ : int
        Points fitted: by ``fit`` and every ``partial_fit`` since.
    n_features_in_ : int

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = np.concatenate([rng.normal(c, 0.3, size=(50, 2)) for c in (0.0, 5.0, 10.0)])
    >>> model = ElasticClustering(random_state=0).fit(X)
    >>> model.n_clusters_
    3
    >>> int(model.predict([[5.1, 4.9]])[0]) == int(model.labels_[60])
    True
    """

    def __init__(self, *, stretch=1.2, n_clusters="auto", criterion="auto", max_clusters=None,
                 min_separation=4.0, significance=0.01, max_iter=20, tol=1e-4, random_state=None):
        self.stretch = stretch
        self.n_clusters = n_clusters
        self.criterion = criterion
        self.max_clusters = max_clusters
        self.min_separation = min_separation
        self.significance = significance
        self.max_iter = max_iter
        self.tol = tol
        self.random_state = random_state

    # -- validation -------------------------------------------------------------------------------
    def _params(self):
        if self.criterion not in ("auto", "hierarchy", "paper"):
            raise ValueError(f"criterion: expected 'auto', 'hierarchy' or 'paper', got {self.criterion!r}")
        if isinstance(self.n_clusters, str):
            if self.n_clusters != "auto":
                raise ValueError(f"n_clusters: expected 'auto' or an integer >= 1, got {self.n_clusters!r}")
            n_fixed = None
        else:
            n_fixed = check_positive(self.n_clusters, name="n_clusters", integer=True)
        cap = None if self.max_clusters is None else check_positive(
            self.max_clusters, name="max_clusters", integer=True)
        level = None if self.significance is None else check_positive(self.significance, name="significance")
        if level is not None and not level < 1.0:
            raise ValueError(f"significance: expected a level in (0, 1) or None, got {self.significance!r}")
        return {
            "stretch": check_positive(self.stretch, name="stretch", allow_zero=True),
            "n_fixed": n_fixed,
            "cap": cap,
            "min_sep": check_positive(self.min_separation, name="min_separation"),
            "level": level,
            "max_iter": check_positive(self.max_iter, name="max_iter", integer=True),
            "tol": check_positive(self.tol, name="tol", allow_zero=True),
        }

    def _check_X(self, X, *, reset: bool) -> np.ndarray:
        if scipy.sparse.issparse(X):
            raise TypeError("X: sparse input is not supported by ElasticClustering; pass a dense array")
        if np.iscomplexobj(X):
            raise ValueError("X: expected real numbers, got complex values (Complex data not supported)")
        shape = np.shape(X)
        if len(shape) == 1:
            raise ValueError(f"X: expected a 2-D array (n_samples, n_features), got 1-D with shape {shape}; "
                             "Reshape your data with X.reshape(-1, 1) for a single feature or "
                             "X.reshape(1, -1) for a single sample")
        if len(shape) == 2 and shape[1] == 0:
            raise ValueError(f"X: expected at least one feature, got 0 feature(s) (shape={shape}) while a "
                             "minimum of 1 is required.")
        X = check_array(X, name="X", ndim=2, min_samples=1)
        if reset:
            self.n_features_in_ = X.shape[1]
        elif X.shape[1] != self.n_features_in_:
            raise ValueError(f"X has {X.shape[1]} features, but {type(self).__name__} is expecting "
                             f"{self.n_features_in_} features as input")
        return X

    # -- EM for a fixed number of nodes -----------------------------------------------------------
    def _em(self, X, nodes, p, tol_abs, x_sq):
        nodes, n_iter = em_nodes(X, nodes, stretch=p["stretch"], max_iter=p["max_iter"], tol=tol_abs,
                                 paper=self.criterion == "paper", x_sq=x_sq)
        n = nodes.shape[0]
        labels, d2 = assign(X, nodes, x_sq)
        counts = np.bincount(labels, minlength=n)
        energy = selection_energy(float(d2.sum()), nodes, p["stretch"])
        return nodes, labels, energy, bool(np.all(counts > 0)), n_iter

    # -- growth of the map ------------------------------------------------------------------------
    def _grow(self, X, nodes, p, test_rng):
        # Work centred on the data: accurate distances, and everything else is translation-invariant.
        offset = X.mean(axis=0)
        nodes, labels, energy, n_iter, path = self._search(X - offset, nodes - offset, p)
        p_values = np.full(np.unique(labels).size, np.nan)
        if p["level"] is not None and p["n_fixed"] is None and self.criterion != "paper":
            nodes, labels, energy, n_iter, p_values = self._merge(X - offset, nodes, labels, energy, n_iter,
                                                                  path, p, test_rng)
        return nodes + offset, labels, energy, n_iter, path, p_values

    def _merge(self, X, nodes, labels, energy, n_iter, path, p, rng):
        """Merge the clusters the significance test cannot tell apart, then refit the map from their means.

        The tests judge the search's clusters, in which odd demonstrations
        are still clusters of their own (they would widen the spread of the
        cluster they join and hide its gap); they join their nearest cluster
        after the tests, as in ``"hierarchy"``, and the refit assigns every
        point to its nearest node. When nothing merges the map is the
        search's, unchanged.
        """
        kept, compact = np.unique(labels, return_inverse=True)
        merged, k, p_values = merge_insignificant(X, compact, kept.size, level=p["level"], rng=rng)
        if k == kept.size:
            return nodes, labels, energy, n_iter, p_values
        means = np.stack([X[merged == c].mean(axis=0) for c in range(k)])
        tol_abs = p["tol"] * float(np.mean(np.var(X, axis=0)))
        nodes, labels, energy, _, n_iter = self._em(X, means, p, tol_abs, np.einsum("ij,ij->i", X, X))
        path.append((nodes.shape[0], energy, closest_separation(X, labels, nodes.shape[0])))
        if np.unique(labels).size < k:  # a node the refit left without points (no p-value of its own)
            p_values = p_values[np.unique(labels)]
        return nodes, labels, energy, n_iter, p_values

    def _search(self, X, nodes, p):
        tol_abs = p["tol"] * float(np.mean(np.var(X, axis=0)))
        x_sq = np.einsum("ij,ij->i", X, X)
        m = X.shape[0]
        target = p["n_fixed"]
        if target is not None and target > m:
            raise ValueError(f"n_clusters: expected at most n_samples={m} clusters, got {target}")
        stop = min(m if p["cap"] is None else p["cap"], m) if target is None else target
        nodes, labels, energy, ok, n_iter = self._em(X, nodes, p, tol_abs, x_sq)
        path = [(nodes.shape[0], energy, closest_separation(X, labels, nodes.shape[0]))]
        if self.criterion == "paper":
            while nodes.shape[0] < stop:
                cand = np.vstack([nodes, X[-1:]])
                c_nodes, c_labels, c_energy, _, c_iter = self._em(X, cand, p, tol_abs, x_sq)
                path.append((cand.shape[0], c_energy, closest_separation(X, c_labels, cand.shape[0])))
                if target is None and not c_energy < energy:
                    break
                nodes, labels, energy, n_iter = c_nodes, c_labels, c_energy, c_iter
            return nodes, labels, energy, n_iter, path
        if target is not None and not ok:
            raise ValueError(f"X: has fewer distinct points than the {nodes.shape[0]} clusters kept")
        if self.criterion == "hierarchy" and target is None and nodes.shape[0] == 1 and m >= 2 * MIN_MEMBERS:
            seeds, cuts = hierarchy_seeds(X, min_separation=p["min_sep"], max_clusters=stop,
                                          rng=check_random_state(self.random_state))
            path += [(n_real, np.nan, sep) for _, n_real, sep in cuts]
            if seeds.shape[0] > 1:
                nodes, labels, energy, ok, n_iter = self._em(X, seeds, p, tol_abs, x_sq)
                path.append((nodes.shape[0], energy, closest_separation(X, labels, nodes.shape[0])))
            return nodes, labels, energy, n_iter, path
        best, failures = (nodes, labels, energy, n_iter), 0
        while nodes.shape[0] < stop:
            n = nodes.shape[0]
            sep, gain, seeds = local_splits(X, labels, n, by="gain" if target is not None else "separation")
            c = int(np.argmax(gain if target is not None else sep))
            if gain[c] <= 0.0:  # every cluster is a single repeated point
                if target is not None:
                    raise ValueError(f"n_clusters: X has only {n} distinct point(s), fewer than "
                                     f"n_clusters={target}")
                break
            cand = np.vstack([nodes[:c], seeds[c, :1], nodes[c + 1:], seeds[c, 1:]])
            nodes, labels, energy, ok, n_iter = self._em(X, cand, p, tol_abs, x_sq)
            min_sep = closest_separation(X, labels, n + 1)
            path.append((n + 1, energy, min_sep))
            if not ok:
                if target is not None:
                    raise ValueError(f"n_clusters: X has fewer distinct points than n_clusters={target}")
                break
            if target is not None or min_sep >= p["min_sep"]:
                best, failures = (nodes, labels, energy, n_iter), 0
            else:
                # A map that fails can lead to one that passes (three blobs on a line are not
                # separable in two), so look a few nodes ahead before giving up.
                failures += 1
                if failures >= _LOOKAHEAD:
                    break
        return (*best, path)

    def _record(self, nodes, labels, keep, energy, n_iter, path, pair_delta):
        """Set the fitted map from the search's result, keeping only the nodes ``keep``.

        The other nodes have no points (only in paper mode) and carry no
        cluster; ``labels`` are renumbered. ``pair_delta()`` is the ``delta``
        of every pair of kept clusters (it may read the renumbered ``labels_``),
        asked for only when there are two or more.
        """
        check_finite_result(nodes, name="ElasticClustering (cluster centres)")
        check_finite_result(energy, name="ElasticClustering (energy)")
        remap = np.full(nodes.shape[0], -1)
        remap[keep] = np.arange(keep.size)
        self.cluster_centers_ = nodes[keep]
        self.labels_ = remap[labels].astype(np.intp)
        self.n_clusters_ = int(keep.size)
        self.energy_ = float(energy)
        self.n_iter_ = int(n_iter)
        self.n_clusters_tried_ = np.array([q[0] for q in path], dtype=np.intp)
        self.energy_path_ = np.array([q[1] for q in path], dtype=float)
        self.separation_path_ = np.array([q[2] for q in path], dtype=float)
        if self.n_clusters_ > 1:
            delta = pair_delta()
            np.fill_diagonal(delta, np.inf)
            self.separation_ = delta.min(axis=1)
        else:
            self.separation_ = np.full(1, np.inf)

    def _store(self, X, nodes, labels, energy, n_iter, path, p_values):
        self._record(nodes, labels, np.unique(labels), energy, n_iter, path,
                     lambda: pairwise_separation(X - X.mean(axis=0), self.labels_, self.n_clusters_))
        self.p_values_ = p_values
        self.cluster_sizes_ = np.bincount(self.labels_, minlength=self.n_clusters_).astype(np.intp)
        self._lo, self._hi = X.min(axis=0), X.max(axis=0)  # for partial_fit's round-off floor of a spread
        self.n_samples_seen_ = int(X.shape[0])
        capacity = _incremental.SAMPLE_SIZE
        if self.cluster_sizes_.max() <= capacity:
            # Each cluster's sample would hold all its members: keep the points (in the order they came,
            # which fit depends on), so that partial_fit can give exactly what fit on all of them gives.
            self._seen, self._seen_labels, self._stats, self._samples = X, self.labels_.copy(), None, None
        else:
            # What the incremental partial_fit needs, of a size independent of the number of points.
            self._seen = self._seen_labels = None
            self._stats = point_stats(X, self.labels_, self.n_clusters_)
            self._samples = sample_of(X, self.labels_, self._keys.random(X.shape[0]), self.n_clusters_,
                                      size=capacity)
        return self

    def _fit_points(self, X, p, step: str):
        """What ``fit`` does on the checked points ``X`` (kept, not copied); ``step`` names errors."""
        rng = check_random_state(self.random_state)
        start = X[rng.randint(X.shape[0])][None, :]
        self._keys = np.random.default_rng(rng.randint(2 ** 31 - 1))  # partial_fit's sampling keys
        # the significance test's draws: a stream of their own, drawn last so the others are as before
        test_rng = np.random.default_rng(rng.randint(2 ** 31 - 1))
        with numerical_errors(step):
            return self._store(X, *self._grow(X, start, p, test_rng))

    def _renumber(self, index):
        """Give cluster ``i`` the index ``index[i]`` (a permutation) in every attribute and in the state."""
        order = np.argsort(index)
        self.cluster_centers_ = self.cluster_centers_[order]
        self.cluster_sizes_, self.separation_ = self.cluster_sizes_[order], self.separation_[order]
        self.p_values_ = self.p_values_[order]
        self.labels_ = index[self.labels_]
        if self._seen is not None:
            self._seen_labels = self.labels_.copy()
        else:
            self._stats, self._samples = self._stats.take(order), [self._samples[i] for i in order]

    def _refit(self, X, p):
        """``partial_fit`` while the model holds every point seen: ``fit`` on them and ``X``, indices kept."""
        refit = type(self)(**self.get_params(deep=False))  # the same random_state: fit's stream
        refit._fit_points(np.vstack([self._seen, X]), p, "ElasticClustering.partial_fit")
        n_before = self._seen.shape[0]
        refit._renumber(keep_indices(self._seen_labels, refit.labels_[:n_before], self.n_clusters_,
                                     refit.n_clusters_))
        refit.labels_ = refit.labels_[n_before:].copy()
        self.__dict__.update(vars(refit))  # only now: a refused batch changes nothing
        return self

    # -- public API -------------------------------------------------------------------------------
    def fit(self, X, y=None):
        """Fit the elastic map to ``X``, choosing the number of clusters.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : ignored

        Returns
        -------
        self

        Examples
        --------
        >>> ElasticClustering(n_clusters=2).fit([[0.0], [0.1], [5.0], [5.1]]).n_clusters_
        2
        """
        p = self._params()
        X = self._check_X(X, reset=True)
        return self._fit_points(X.copy(), p, "ElasticClustering.fit")

    def partial_fit(self, X, y=None):
        """Add a batch of points to a fitted model, in memory bounded by its clusters, not the points seen.

        While no cluster has more than 1,000 members the model holds every
        point seen, in the order they came, and a call is ``fit`` on them and
        the batch: it gives what ``fit`` on everything gives with the same
        ``random_state`` (earlier points may change cluster, clusters may
        merge or vanish). A cluster that persists keeps its index: refit and
        earlier clusters are paired by the earlier points they share, most
        first; new clusters take the indices left free, then are appended.

        Once a cluster has more members, each cluster is kept as sufficient
        statistics (count, mean, scatter matrix) and a uniform sample of at
        most 1,000 of its members, and calls are incremental. The batch is
        assigned to the nearest nodes and EM runs on it, each node update
        counting the earlier members of its cluster through their
        statistics. Then, as in ``criterion="auto"`` (also for
        ``"hierarchy"``), the cluster with the most clearly separated split
        is split and EM re-run, while the new cluster is at least
        ``min_separation`` from every other (judged on the statistics, so the
        number of clusters does not depend on how many points were seen);
        ``"paper"`` adds a node at the batch's last point while the energy
        falls. A fixed ``n_clusters`` only moves the nodes. An unfitted model
        is fitted on the batch.

        What incremental calls give up against refitting all the points:
        earlier points are never reassigned to another cluster (their
        statistics stay with the cluster they joined, so the result depends
        on the order of the batches); a split divides a cluster's earlier
        members as its sample divides (estimated statistics once it has more
        than 1,000); clusters are never merged or removed; and small batches
        of few points per cluster in many dimensions miss splits a refit
        finds (see ``docs/scaling.md``). Memory is ``O(n_clusters_ * (1000 +
        n_features) * n_features)`` plus the batch, in both regimes.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : ignored

        Returns
        -------
        self
            ``labels_`` then holds the batch's clusters, ``cluster_sizes_``
            every point seen, ``n_samples_seen_`` their number; the paths
            describe the maps tried in this call (a refit's as ``fit``'s; an
            incremental call's separation: the smallest ``delta`` of a
            cluster new in this call).

        Examples
        --------
        >>> model = ElasticClustering().fit([[0.0], [0.1], [0.2]])
        >>> model.partial_fit([[9.0], [9.1], [9.2]]).n_clusters_
        2
        >>> model.cluster_sizes_.tolist(), model.n_samples_seen_
        ([3, 3], 6)
        """
        if not hasattr(self, "cluster_centers_"):
            return self.fit(X)
        p = self._params()
        X = self._check_X(X, reset=False)
        if self._seen is not None:
            return self._refit(X, p)
        lo, hi = np.minimum(self._lo, X.min(axis=0)), np.maximum(self._hi, X.max(axis=0))

        def scale_of(offset):  # the largest absolute coordinate of every point seen, centred on offset
            return float(np.max(np.maximum(np.abs(hi - offset), np.abs(lo - offset))))

        with numerical_errors("ElasticClustering.partial_fit"):
            nodes, labels, stats, samples, energy, n_iter, path = grow(
                X, self._keys.random(X.shape[0]), self._stats, self._samples, self.cluster_centers_, p,
                criterion=self.criterion, scale_of=scale_of)
            keep = np.flatnonzero(stats.counts > 0)  # a node left without points (paper mode) is dropped
            kept = stats.take(keep)

            def pair_delta():
                centre = pooled(kept).means[0]
                return separation(kept.shifted(centre), scale_of(centre))

            self._record(nodes, labels, keep, energy, n_iter, path, pair_delta)
            self.p_values_ = np.full(self.n_clusters_, np.nan)  # an incremental call tests nothing
            self._stats = kept
            self._samples = [samples[i] for i in keep]
            self.cluster_sizes_ = np.rint(kept.counts).astype(np.intp)  # estimates after some splits
            self._lo, self._hi = lo, hi
            self.n_samples_seen_ += int(X.shape[0])
        return self

    def predict(self, X):
        """Index of the nearest node of each point.

        Examples
        --------
        >>> model = ElasticClustering(n_clusters=2).fit([[0.0], [0.1], [5.0], [5.1]])
        >>> model.predict([[4.0]]).tolist() == model.predict([[5.0]]).tolist()
        True
        """
        check_is_fitted(self, "cluster_centers_")
        X = self._check_X(X, reset=False)
        with numerical_errors("ElasticClustering.predict"):
            return nearest_centre(X, self.cluster_centers_)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.sparse = False
        return tags
