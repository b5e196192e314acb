"""ElasticClustering.partial_fit: incremental, in memory that does not grow with the points seen."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.metrics import adjusted_rand_score

from skillbank.clustering import ElasticClustering
from skillbank.clustering._em import em_nodes, pairwise_separation
from skillbank.clustering._incremental import (
    SAMPLE_SIZE,
    Sample,
    _blank,
    _em,
    merge,
    point_stats,
    pooled,
    separation,
)

CENTRES = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [10.0, 10.0, 5.0]])


def blobs(n, *, seed=0, centres=CENTRES, sort=False):
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, len(centres), n)
    if sort:  # the skills arrive one after another
        labels = np.sort(labels)
    return centres[labels] + rng.normal(size=(n, centres.shape[1])), labels


def stream(X, batch, **params):
    model = ElasticClustering(random_state=0, **params)
    seen = []
    for i in range(0, X.shape[0], batch):
        model.partial_fit(X[i:i + batch])
        seen.append(model.labels_)
    return model, np.concatenate(seen)


def state_bytes(model) -> int:
    """Bytes of every array the model keeps between calls, except the last batch's labels."""
    total = 0
    for name, value in vars(model).items():
        if name == "labels_":
            continue
        for part in (value if isinstance(value, (list, tuple)) else [value]):
            for array in (part if isinstance(part, tuple) else [part]):
                total += getattr(array, "nbytes", 0)
    return total


# -- sufficient statistics -------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(8))
def test_separation_from_statistics_is_that_of_the_points(seed):
    rng = np.random.default_rng(seed)
    n, d, k = int(rng.integers(2, 300)), int(rng.integers(1, 6)), int(rng.integers(1, 7))
    X = rng.normal(size=(n, d)) * rng.uniform(0.1, 10.0, d)
    labels = rng.integers(0, k, n)
    if seed % 2:
        labels[: n // 2] = 0  # uneven clusters, some maybe empty or single
    X -= X.mean(axis=0)
    expected = pairwise_separation(X, labels, k)
    got = separation(point_stats(X, labels, k), float(np.abs(X).max()))
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_merged_and_pooled_statistics_are_exact(seed):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(500, 4)) * 100.0 + 5e4  # far from the origin: the update must stay accurate
    labels = rng.integers(0, 3, 500)
    part = rng.random(500) < 0.3
    whole = point_stats(X, labels, 3)
    m = merge(point_stats(X[part], labels[part], 3), point_stats(X[~part], labels[~part], 3))
    np.testing.assert_array_equal(m.counts, whole.counts)
    np.testing.assert_allclose(m.means, whole.means, rtol=1e-12)
    np.testing.assert_allclose(m.scatter, whole.scatter, rtol=1e-8)
    one = pooled(whole)
    Z = X - X.mean(axis=0)
    np.testing.assert_allclose(one.means[0], X.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(one.scatter[0], Z.T @ Z, rtol=1e-8)


# -- one EM loop for fit and partial_fit -----------------------------------------------------------

@pytest.mark.parametrize("criterion", ["auto", "paper"])
@pytest.mark.parametrize("seed", range(3))
def test_em_from_an_empty_prior_is_the_em_of_fit(criterion, seed):
    # partial_fit's EM counts earlier members through their statistics; with none it must be fit's EM
    # to the bit: the same nodes, labels and rounds (its energy is summed from statistics: to round-off).
    X, _ = blobs(400, seed=seed)
    X -= X.mean(axis=0)
    start = X[np.random.default_rng(seed).choice(X.shape[0], 6, replace=False)]
    start[4:] = start[3]  # ties go to node 3: nodes 4 and 5 start empty, so the empty-node rule runs too
    # A tolerance that stops "auto" while the nodes still move a little: the stopping rule counts too.
    model = ElasticClustering(criterion=criterion, stretch=0.4, tol=1e-3)
    p = model._params()
    tol = p["tol"] * float(np.mean(np.var(X, axis=0)))
    x_sq = np.einsum("ij,ij->i", X, X)
    nodes, labels, e, ok, n_iter = model._em(X, start, p, tol, x_sq)
    paper = criterion == "paper"
    i_nodes, i_labels, stats, i_e, i_ok, i_iter = _em(X, x_sq, _blank(6, 3), start, p, tol, paper)
    assert n_iter > 1 and (i_iter, i_ok) == (n_iter, ok)
    np.testing.assert_array_equal(i_nodes, nodes)
    np.testing.assert_array_equal(i_labels, labels)
    np.testing.assert_array_equal(stats.counts, np.bincount(labels, minlength=6))
    assert i_e == pytest.approx(e, rel=1e-12)


def test_em_counts_earlier_members_and_stops_when_empty_nodes_outnumber_the_points():
    X = np.array([[0.0], [1.0], [10.0], [11.0]])
    # No stretch: a node is the mean of its members, two earlier ones summing to 5 included.
    nodes, n_iter = em_nodes(X, np.array([[0.0], [10.0]]), stretch=0.0, max_iter=20, tol=0.0, paper=False,
                             prior_counts=np.array([2.0, 0.0]), prior_sums=np.array([[5.0], [0.0]]))
    assert nodes.ravel().tolist() == [1.5, 10.5] and n_iter == 2
    # One point for two nodes with no members: nowhere to move both, so they stay where they are.
    start = np.array([[0.0], [1.0], [2.0], [2.5]])
    nodes, n_iter = em_nodes(np.array([[3.0]]), start, stretch=0.0, max_iter=20, tol=0.0, paper=False,
                             prior_counts=np.array([4.0, 0.0, 0.0, 0.0]), prior_sums=np.zeros((4, 1)))
    np.testing.assert_array_equal(nodes, start)
    assert n_iter == 1


def test_sample_is_uniform_and_bounded():
    # Bottom-k sampling: at most `size` points, each member kept with the same chance.
    rng = np.random.default_rng(0)
    q = Sample(np.zeros((0, 1)), np.zeros(0), 1.0)
    for start in range(0, 20_000, 1_000):
        q = q.add(np.arange(start, start + 1_000, dtype=float)[:, None], rng.random(1_000), size=500)
    assert q.points.shape == (500, 1) and np.all(q.keys < q.tau)
    # early and late members equally represented (binomial sd ~ 11 for 250 expected)
    assert abs(int(np.sum(q.points < 10_000)) - 250) < 50


# -- the clusterer ---------------------------------------------------------------------------------

@pytest.mark.parametrize("sort", [False, True])
def test_streamed_blobs_match_a_full_refit(sort):
    X, truth = blobs(20_000, sort=sort)
    full = ElasticClustering(random_state=0).fit(X)
    model, seen = stream(X, 1_000)
    assert model.n_clusters_ == full.n_clusters_ == 4
    assert adjusted_rand_score(full.labels_, model.predict(X)) > 0.999
    # the clusters points were given when they arrived, too: cluster ids are kept across batches
    assert adjusted_rand_score(truth, seen) > 0.999
    assert model.n_samples_seen_ == 20_000 and model.cluster_sizes_.sum() == 20_000


def test_a_cluster_keeps_its_id_when_a_batch_splits_it():
    # Skills one after another: the batch where one ends and the next begins splits a cluster; the side
    # with its earlier members keeps its id, so the clusters given on arrival stay consistent.
    centres = np.random.default_rng(0).uniform(-10.0, 10.0, size=(4, 3))
    X, truth = blobs(20_000, seed=1, centres=centres, sort=True)
    model, seen = stream(X, 1_000)
    assert model.n_clusters_ == 4
    assert adjusted_rand_score(truth, seen) > 0.999


@pytest.mark.parametrize("n", [4_000, 80_000])
def test_number_of_clusters_does_not_grow_with_the_points_seen(n):
    X, _ = blobs(n, seed=1)
    assert stream(X, 2_000)[0].n_clusters_ == 4
    rng = np.random.default_rng(2)
    assert stream(rng.normal(size=(n, 3)), 2_000)[0].n_clusters_ == 1  # one Gaussian is never cut


def test_memory_does_not_grow_with_the_points_seen():
    X, _ = blobs(60_000, seed=3)
    model = ElasticClustering(random_state=0).fit(X[:1_000])
    for i in range(1_000, 10_000, 1_000):
        model.partial_fit(X[i:i + 1_000])
    early = state_bytes(model)
    for i in range(10_000, 60_000, 1_000):
        model.partial_fit(X[i:i + 1_000])
    assert model.n_samples_seen_ == 60_000 and model.n_clusters_ == 4
    d = X.shape[1]
    bound = model.n_clusters_ * (SAMPLE_SIZE * (d + 1) + d * d + d + 1) * 8 + 4096
    assert state_bytes(model) <= bound
    assert state_bytes(model) == early  # every cluster's sample was already full


def test_clusters_merged_while_small_are_split_later():
    # Twenty points of three blobs in a line are one cluster; as points arrive, the earlier members'
    # sample lets the cluster split (a split that kept every earlier member on one side could not).
    line = np.array([[0.0, 0.0], [6.0, 0.0], [12.0, 0.0]])
    X, truth = blobs(6_000, centres=line, seed=5)
    model = ElasticClustering(random_state=0).partial_fit(X[:20])
    assert model.n_clusters_ == 1
    for i in range(20, 6_000, 100):
        model.partial_fit(X[i:i + 100])
    assert model.n_clusters_ == 3
    assert adjusted_rand_score(truth, model.predict(X)) > 0.98


def test_a_new_skill_gets_a_new_cluster_and_old_ids_stay():
    X, truth = blobs(4_000, seed=5)
    model = ElasticClustering(random_state=0).fit(X[truth != 3])
    assert model.n_clusters_ == 3
    sizes = model.cluster_sizes_.copy()
    centres = model.cluster_centers_.copy()
    new = X[truth == 3]
    model.partial_fit(new)
    assert model.n_clusters_ == 4
    np.testing.assert_array_equal(model.cluster_sizes_[:3], sizes)
    np.testing.assert_allclose(model.cluster_centers_[:3], centres, atol=0.05)
    assert model.labels_.shape == (new.shape[0],) and np.all(model.labels_ == 3)
    np.testing.assert_array_equal(model.predict(new), model.labels_)


def test_statistics_count_every_point_once_and_stretch_is_kept():
    X, _ = blobs(3_000, seed=6)
    model, seen = stream(X, 300, stretch=0.0)
    # with no stretching a node is the mean of its members, here each point as assigned on arrival
    for c in range(model.n_clusters_):
        np.testing.assert_allclose(model.cluster_centers_[c], X[seen == c].mean(axis=0), atol=1e-9)
    np.testing.assert_array_equal(model.cluster_sizes_, np.bincount(seen))


def test_fixed_number_of_clusters_and_paper_mode():
    X, _ = blobs(2_000, seed=7)
    assert stream(X, 500, n_clusters=2)[0].n_clusters_ == 2
    model = ElasticClustering(criterion="paper", stretch=0.4, random_state=0).fit(X[:90])
    before = model.n_clusters_
    model.partial_fit(np.full((5, 3), 100.0))
    assert model.n_clusters_ == before + 1  # a node at the batch's last point, which then has its own cluster
    assert np.all(model.labels_ == before) and model.cluster_sizes_[before] == 5


def test_reproducible_and_unfitted_model_is_fitted():
    X, _ = blobs(3_000, seed=8)
    a, la = stream(X, 250)
    b, lb = stream(X, 250)
    np.testing.assert_array_equal(la, lb)
    np.testing.assert_array_equal(a.cluster_centers_, b.cluster_centers_)
    fitted = ElasticClustering(random_state=0).fit(X[:250])
    first = ElasticClustering(random_state=0).partial_fit(X[:250])
    np.testing.assert_array_equal(fitted.cluster_centers_, first.cluster_centers_)


def test_bad_batches():
    model = ElasticClustering(random_state=0).fit(blobs(100)[0])
    with pytest.raises(ValueError, match=r"X has 2 features, but ElasticClustering is expecting 3"):
        model.partial_fit(np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"X: expected finite values, got 1 non-finite value"):
        model.partial_fit([[0.0, 1.0, np.inf]])
    with pytest.raises(ValueError, match=r"X: expected at least 1 samples, got 0"):
        model.partial_fit(np.zeros((0, 3)))
    assert model.n_samples_seen_ == 100  # a refused batch changes nothing
