"""The RAIL clustering experiment: the paper's numbers exactly, and the unsupervised default."""

from __future__ import annotations

import json

import numpy as np
import pytest

from skillbank.experiments._rail import (
    composition,
    count_misclustered,
    rail_experiment,
    run_rail_experiment,
)

FOUR = ("reaching", "pushing", "pressing", "writing")


@pytest.fixture(scope="module")
def rail(data_dir):
    return data_dir / "rail"


@pytest.fixture(scope="module")
def paper(rail):
    return run_rail_experiment(rail, mode="paper")


@pytest.fixture(scope="module")
def default(rail):
    return run_rail_experiment(rail, mode="default")


def _rows(table):
    return sorted(map(tuple, table))


def test_composition_and_misclustered_known_answers():
    labels = [0, 0, 0, 1, 1, 2]
    classes = [0, 0, 1, 1, 1, 2]
    assert composition(labels, classes).tolist() == [[2, 1, 0], [0, 2, 0], [0, 0, 1]]
    assert count_misclustered(labels, classes) == 1
    # A single cluster misclusters everything outside the largest class.
    assert count_misclustered([0] * 6, classes) == 3
    with pytest.raises(ValueError, match=r"labels: expected one label per demo \(6\), got 5"):
        composition(labels[:5], classes)


def test_paper_mode_reproduces_elastic_clusters(paper):
    assert paper["n_demos"] == 150
    assert paper["class_counts"] == [60, 60, 30]
    el = paper["elastic"]
    assert el["n_clusters"] == 3
    assert _rows(el["composition"]) == _rows([[60, 20, 0], [0, 40, 0], [0, 0, 30]])
    assert el["misclustered"] == 20
    assert el["misclustered_fraction"] == pytest.approx(20 / 150)


def test_paper_mode_reproduces_agglomerative_clusters(paper):
    agg = paper["agglomerative"]
    assert agg["n_clusters"] == 3
    assert _rows(agg["composition"]) == _rows([[16, 54, 0], [0, 0, 30], [44, 6, 0]])
    assert agg["misclustered"] == 22


def test_paper_mode_is_independent_of_the_seed(rail):
    out = run_rail_experiment(rail, mode="paper", random_state=3)
    assert out["elastic"]["misclustered"] == 20 and out["agglomerative"]["misclustered"] == 22


def test_default_mode_finds_three_clusters_and_beats_the_paper(default):
    el = default["elastic"]
    assert el["n_clusters"] == 3
    assert el["misclustered"] < 20
    assert el["ari"] > 0.8
    # Each class dominates exactly one cluster.
    table = np.array(el["composition"])
    assert sorted(table.argmax(axis=1).tolist()) == [0, 1, 2]
    agg = default["agglomerative"]
    assert agg["n_clusters"] == el["n_clusters"]  # taken from elastic clustering, no labels
    assert agg["misclustered"] < 20


def test_four_classes_with_adjusted_rand_index(rail):
    out = run_rail_experiment(rail, mode="default", classes=FOUR)
    assert out["n_demos"] == 209
    assert out["class_counts"] == [60, 60, 59, 30]
    assert out["elastic"]["n_clusters"] == 4
    assert out["elastic"]["ari"] > 0.8
    assert np.array(out["elastic"]["composition"]).sum() == 209
    paper4 = run_rail_experiment(rail, mode="paper", classes=",".join(FOUR))
    assert paper4["agglomerative"]["n_clusters"] == 4
    assert -1.0 <= paper4["elastic"]["ari"] <= 1.0


def test_paper_representatives_are_loaded_when_their_class_is_not_clustered(rail):
    out = run_rail_experiment(rail, mode="paper", classes=("reaching", "pushing"))
    assert out["n_demos"] == 120
    assert np.array(out["elastic"]["composition"]).shape[1] == 2


def test_result_is_json_ready_with_timing(rail, data_dir):
    # The shared data folder (holding rail/) is accepted as well.
    result = rail_experiment(data_dir, mode="paper")
    summary = result.summary()
    doc = json.loads(json.dumps(summary))
    assert set(doc["timing"]) == {"load_s", "features_s", "elastic_s", "agglomerative_s", "total_s"}
    assert doc["timing"]["total_s"] >= doc["timing"]["load_s"] > 0
    assert result.features.shape == (150, 3)
    assert len(result.trajectories) == 150 and result.trajectories[0].shape == (1000, 3)
    # Paper features are min-max normalised per column.
    assert np.allclose(result.features.min(axis=0), 0.0) and np.allclose(result.features.max(axis=0), 1.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"mode": "fast"}, r"mode: expected one of \['default', 'paper'\], got 'fast'"),
        ({"classes": ("reaching", "jumping")}, r"classes: expected names among .*got \['jumping'\]"),
        ({"classes": ("reaching",)}, r"classes: expected at least two different classes"),
        ({"classes": ("reaching", "Reaching")}, r"classes: expected at least two different classes"),
        ({"classes": 3}, r"classes: expected a list of class names, got 3"),
    ],
)
def test_bad_arguments(rail, kwargs, match):
    with pytest.raises(ValueError, match=match):
        run_rail_experiment(rail, **kwargs)


def test_missing_folder(tmp_path):
    with pytest.raises(ValueError, match=r"data_dir: expected a folder holding the RAIL dataset"):
        run_rail_experiment(tmp_path / "nowhere")
    with pytest.raises(ValueError, match=r"expected a sub-folder for class 'reaching'"):
        run_rail_experiment(tmp_path)
