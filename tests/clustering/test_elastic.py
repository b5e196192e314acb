"""ElasticClustering: the automatic criterion, the paper's algorithm, degenerate inputs."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.clustering import ElasticClustering, _incremental

CENTRES = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]])


def blobs(n, *, seed=0, centres=CENTRES, sd=1.0):
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, len(centres), n)
    return centres[labels] + sd * rng.normal(size=(n, centres.shape[1])), labels


def purity(labels, truth):
    return sum(np.bincount(truth[labels == c]).max() for c in np.unique(labels)) / truth.size


# -- the automatic criterion ----------------------------------------------------------------------

@pytest.mark.parametrize("n", [150, 1_500, 15_000])
@pytest.mark.parametrize("scale", [1.0, 1000.0])
def test_auto_finds_three_blobs_at_any_size_and_scale(n, scale):
    X, truth = blobs(n)
    model = ElasticClustering(random_state=0, stretch=0.4).fit(X * scale)
    assert model.n_clusters_ == 3
    assert purity(model.labels_, truth) > 0.99
    np.testing.assert_allclose(np.sort(model.cluster_centers_[:, 0] / scale), [0.0, 0.0, 10.0], atol=0.5)


def test_auto_is_exactly_scale_invariant():
    X, _ = blobs(600, seed=3)
    a = ElasticClustering(random_state=1).fit(X)
    b = ElasticClustering(random_state=1).fit(X * 1000.0 + 5e4)
    np.testing.assert_array_equal(a.labels_, b.labels_)
    np.testing.assert_allclose(a.separation_path_, b.separation_path_, rtol=1e-6)


def test_auto_passes_through_an_unseparable_split():
    # Four blobs on a line: the two-cluster map (two blobs against two) is not valid, yet the
    # search goes on and finds the four-cluster map.
    line = np.array([[0.0, 0.0], [12.0, 0.0], [24.0, 0.0], [36.0, 0.0]])
    X, truth = blobs(1_200, centres=line)
    model = ElasticClustering(random_state=0).fit(X)
    assert model.n_clusters_ == 4
    assert model.separation_path_[1] < model.min_separation <= model.separation_path_[3]
    assert purity(model.labels_, truth) == 1.0


@pytest.mark.parametrize("kind", ["gaussian", "uniform"])
def test_auto_keeps_one_cluster_for_unimodal_data(kind):
    rng = np.random.default_rng(0)
    X = rng.normal(size=(2_000, 3)) if kind == "gaussian" else rng.uniform(size=(2_000, 2))
    assert ElasticClustering(random_state=0).fit(X).n_clusters_ == 1


def test_min_separation_merges_close_clusters():
    X, _ = blobs(1_200, centres=np.array([[0.0, 0.0], [6.0, 0.0], [40.0, 0.0]]))
    assert ElasticClustering(random_state=0, min_separation=4.0).fit(X).n_clusters_ == 3
    assert ElasticClustering(random_state=0, min_separation=8.0).fit(X).n_clusters_ == 2


def test_fixed_number_of_clusters():
    X, truth = blobs(300)
    model = ElasticClustering(n_clusters=3, random_state=0).fit(X)
    assert model.n_clusters_ == 3 and model.cluster_centers_.shape == (3, 3)
    assert purity(model.labels_, truth) > 0.99
    assert ElasticClustering(n_clusters=5, random_state=0).fit(X).n_clusters_ == 5


def test_max_clusters_caps_the_search():
    X, _ = blobs(300)
    assert ElasticClustering(max_clusters=2, random_state=0).fit(X).n_clusters_ == 2


def test_deterministic_for_a_random_state_and_predict_matches_labels():
    X, _ = blobs(500, seed=7)
    a = ElasticClustering(random_state=3).fit(X)
    b = ElasticClustering(random_state=3).fit(X)
    np.testing.assert_array_equal(a.labels_, b.labels_)
    np.testing.assert_array_equal(a.cluster_centers_, b.cluster_centers_)
    np.testing.assert_array_equal(a.predict(X), a.labels_)
    assert a.energy_ == a.energy_path_[list(a.n_clusters_tried_).index(a.n_clusters_)]


def test_stretch_pushes_nodes_apart_but_not_the_count():
    X, _ = blobs(150)
    loose = ElasticClustering(random_state=0, stretch=0.0).fit(X)
    tight = ElasticClustering(random_state=0, stretch=5.0).fit(X)
    assert loose.n_clusters_ == tight.n_clusters_ == 3

    def spread(m):
        c = m.cluster_centers_
        return np.sum((c - c.mean(axis=0)) ** 2)

    assert spread(tight) > spread(loose)


# -- partial_fit ----------------------------------------------------------------------------------

def test_partial_fit_grows_the_library():
    X, truth = blobs(600)
    model = ElasticClustering(random_state=0).fit(X[truth != 2])
    assert model.n_clusters_ == 2
    model.partial_fit(X[truth == 2])
    assert model.n_clusters_ == 3
    assert model.labels_.shape == (int(np.sum(truth == 2)),)  # the batch's clusters
    np.testing.assert_array_equal(model.predict(X[truth == 2]), model.labels_)


def test_partial_fit_never_removes_clusters_and_fits_when_unfitted(monkeypatch):
    # Samples of 10 members: the model is incremental at once. (While it holds every point, partial_fit
    # is fit on all of them and may merge clusters: tests/clustering/test_incremental.py.)
    monkeypatch.setattr(_incremental, "SAMPLE_SIZE", 10)
    X, _ = blobs(300)
    model = ElasticClustering(random_state=0).partial_fit(X)
    assert model.n_clusters_ == 3
    # Points that fill the gaps would make the blobs inseparable, but clusters are never removed.
    rng = np.random.default_rng(1)
    model.partial_fit(rng.uniform(-2.0, 12.0, size=(300, 3)) * [1.0, 1.0, 0.0])
    assert model.n_clusters_ >= 3


def test_partial_fit_paper_mode_adds_a_node_at_the_new_last_point(monkeypatch):
    monkeypatch.setattr(_incremental, "SAMPLE_SIZE", 10)  # incremental at once, as above
    X, _ = blobs(90)
    model = ElasticClustering(criterion="paper", stretch=0.4, random_state=0).fit(X)
    n_before = model.n_clusters_
    model.partial_fit(np.full((5, 3), 100.0))
    assert model.n_clusters_ >= n_before
    # The far-away points get a node of their own (pushed beyond them by the stretching).
    new = model.labels_[-5:]
    assert np.all(new == new[0]) and np.sum(model.labels_ == new[0]) == 5


# -- the paper's algorithm ------------------------------------------------------------------------

def _loop_paper(X, stretch, first, max_iter=20, tol=1e-4):
    """Algorithm 1 as written, with Python loops; nodes grow at the last point."""
    tol_abs = tol * np.mean(np.var(X, axis=0))

    def em(nodes):
        for _ in range(max_iter):
            n = len(nodes)
            A = np.zeros((n, n))
            C = np.zeros((n, X.shape[1]))
            for i in range(n):
                for j in range(i, n):
                    A[i, i] -= stretch
                    A[j, j] -= stretch
                    A[i, j] += stretch
                    A[j, i] += stretch
            for z in X:
                a = int(np.argmin([np.linalg.norm(z - x) for x in nodes]))
                A[a, a] += 1.0
                C[a] += z
            new = np.linalg.lstsq(A, C, rcond=None)[0]
            moved = np.sum((new - nodes) ** 2)
            nodes = new
            if moved <= tol_abs:
                break
        u_x = sum(min(np.sum((z - x) ** 2) for x in nodes) for z in X)
        pairs = [(i, j) for i in range(len(nodes)) for j in range(i + 1, len(nodes))]
        u_e = sum(np.sum((nodes[i] - nodes[j]) ** 2) for i, j in pairs)
        return nodes, u_x + stretch * u_e

    nodes, energy = em(X[first][None, :])
    path = [energy]
    while len(nodes) < len(X):
        cand, e = em(np.vstack([nodes, X[-1:]]))
        path.append(e)
        if not e < energy:
            break
        nodes, energy = cand, e
    return nodes, path


@pytest.mark.parametrize("seed", [0, 1])
def test_paper_mode_matches_the_algorithm_written_with_loops(seed):
    X, _ = blobs(60, seed=seed)
    model = ElasticClustering(criterion="paper", stretch=0.4, random_state=seed).fit(X)
    first = np.random.RandomState(seed).randint(X.shape[0])
    nodes, path = _loop_paper(X, 0.4, first)
    np.testing.assert_allclose(model.energy_path_, path, rtol=1e-9)
    np.testing.assert_allclose(model.cluster_centers_, nodes, rtol=1e-9, atol=1e-9)


def test_paper_mode_count_grows_with_the_number_of_points():
    # The authors' weakness that "auto" fixes: more points, more clusters, same 3 blobs.
    small = ElasticClustering(criterion="paper", stretch=0.4, random_state=0).fit(blobs(150)[0])
    large = ElasticClustering(criterion="paper", stretch=0.4, random_state=0).fit(blobs(1_500)[0])
    assert large.n_clusters_ > small.n_clusters_ >= 2
    assert np.all(np.diff(small.energy_path_[:-1]) < 0) and small.energy_path_[-1] >= small.energy_path_[-2]
