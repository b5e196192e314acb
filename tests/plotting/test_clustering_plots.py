"""Clustering figures are written as PNG files, and bad input is refused."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from skillbank.experiments import plot_rail_experiment, rail_experiment
from skillbank.plotting._clustering import _display_order, plot_cluster_comparison

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _is_png(path) -> bool:
    data = path.read_bytes()
    return len(data) > 1000 and data[:8] == PNG_MAGIC


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(0)
    X = np.concatenate([rng.normal(c, 0.2, size=(10, 3)) for c in (0.0, 2.0, 4.0)])
    t = np.linspace(0.0, 1.0, 30)
    trajs = [np.column_stack([t, k * t, t ** 2]) for k in np.repeat([0.0, 1.0, 2.0], 10)]
    classes = np.repeat(["a", "b", "c"], 10)
    return X, trajs, classes


def test_display_order_lines_clusters_up_with_classes():
    labels = np.array([2, 2, 2, 0, 0, 1])
    classes = np.array([0, 0, 0, 1, 1, 0])
    # Clusters 2 (3 of class 0) and 1 (1 of class 0) come first, bigger first, then cluster 0.
    assert _display_order(labels, classes).tolist() == [2, 1, 0]
    assert _display_order(labels, None).tolist() == [2, 0, 1]


def test_features_only(tmp_path, data):
    X, _, _ = data
    path = plot_cluster_comparison(X, np.arange(30) // 10, tmp_path / "sub" / "f.png")
    assert path == tmp_path / "sub" / "f.png" and _is_png(path)


@pytest.mark.parametrize("n_features", [1, 2, 5])
def test_any_number_of_features(tmp_path, data, n_features):
    X = np.tile(data[0], (1, 2))[:, :n_features]
    assert _is_png(plot_cluster_comparison(X, {"k": np.arange(30) % 2}, tmp_path / "f.png"))


def test_with_trajectories_truth_and_many_clusters(tmp_path, data):
    X, trajs, classes = data
    labelings = {"one": np.arange(30) // 10, "many": np.arange(30) % 9}
    path = plot_cluster_comparison(X, labelings, tmp_path / "t.png", trajectories=trajs, classes=classes,
                                   max_clusters_shown=4, title="demo")
    assert _is_png(path)
    flat = [Y[:, :2] for Y in trajs]
    assert _is_png(plot_cluster_comparison(X, labelings, tmp_path / "t2.png", trajectories=flat))


def test_rail_figure(tmp_path, data_dir):
    result = rail_experiment(data_dir / "rail", mode="paper")
    assert _is_png(plot_rail_experiment(result, tmp_path / "rail.png"))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"labelings": np.zeros(5)}, r"labelings\['clusters'\]: expected 30 labels, one per sample"),
        ({"labelings": {}}, r"labelings: expected at least one clustering, got none"),
        ({"classes": np.zeros(3)}, r"classes: expected 30 labels"),
        ({"trajectories": [np.zeros((4, 3))] * 2}, r"trajectories: expected 30, one per sample, got 2"),
        ({"features": np.zeros(30)}, r"features: expected a 2-D array"),
    ],
)
def test_bad_input(tmp_path, data, kwargs, match):
    X, _, _ = data
    args = {"features": X, "labelings": np.zeros(30, dtype=int), **kwargs}
    with pytest.raises(ValueError, match=match):
        plot_cluster_comparison(args.pop("features"), args.pop("labelings"), tmp_path / "x.png", **args)


def test_rail_figure_needs_a_result(tmp_path):
    with pytest.raises(ValueError, match=r"result: expected a RailExperimentResult, got dict"):
        plot_rail_experiment({}, tmp_path / "x.png")


def test_trajectory_panels_have_ticks_units_and_no_cut_label(tmp_path, data, drawn):
    X, trajs, classes = data
    plot_cluster_comparison(X, np.arange(30) // 10, tmp_path / "t.png", trajectories=trajs, classes=classes,
                            unit="m")
    fig = drawn[-1]
    scatter, *panels = fig.axes[:4]
    assert scatter.get_zlabel() == "feature 3"
    for ax in panels:
        assert [ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()] == ["x (m)", "y (m)", "z (m)"]
        assert all(t.get_text() for t in ax.get_xticklabels())  # tick values shown
    # every 3-D panel's axis labels lie inside its own cell: none is drawn under a neighbour
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    for ax in fig.axes:
        others = [o.get_window_extent(renderer) for o in fig.axes if o is not ax]
        for label in (ax.xaxis.label, ax.yaxis.label, ax.zaxis.label):
            box = label.get_window_extent(renderer)
            assert not any(box.overlaps(o) for o in others), label.get_text()
