"""Figures read at a glance (issue 44, item 6): each figure is rendered and what it shows is checked.

The probability is drawn on its own scale with the segmenter's threshold and
a title that agrees; counts are pluralised; no axis label is clipped by a
neighbouring panel; units are named where known; legends sit where they hide
no data; a long title is wrapped instead of widening the figure; members
drawn over each other are said to be identical.
"""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from mpl_toolkits.mplot3d import proj3d

import skillbank
from skillbank.core import Constraints
from skillbank.io import load_rail
from skillbank.plotting import (
    plot_cluster_comparison,
    plot_edit,
    plot_executable,
    plot_keypoint_probability,
    plot_reuse,
    plot_segment_grid,
    plot_segmentation_summary,
    plot_segments,
    plot_skills,
)
from skillbank.plotting._segmentation import _DPI
from skillbank.plotting._summary import threshold
from skillbank.segmentation import segment
from skillbank.segmentation._segmenter import KEYPOINT_PROBABILITY

from .conftest import three_streams


@pytest.fixture(scope="module")
def push(data_dir):
    """A RAIL push: its keypoint curve has peaks, all under the threshold (no keypoint)."""
    return segment(load_rail(data_dir / "rail", classes=["pushing"])[0])


@pytest.fixture(scope="module")
def cut():
    """A 3-D path with corners, a force that steps and a gripper that closes: keypoints from all three."""
    return segment(three_streams(), window=16)


def _renderer(fig):
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas.get_renderer()


def _probability_axes(fig):
    return next(ax for ax in fig.axes if ax.get_ylabel().startswith("keypoint"))


def _lines(ax, label):
    return [line for line in ax.get_lines() if line.get_label() == label]


# -- the keypoint probability ------------------------------------------------------------------------
@pytest.mark.parametrize("plot", [plot_keypoint_probability, plot_segmentation_summary])
def test_a_push_without_keypoints_shows_its_peaks_under_the_threshold(push, tmp_path, drawn, plot):
    assert push.combine == "evidence" and push.keypoints.size == 0
    top = float(push.probability.max())
    assert 0.05 < top < KEYPOINT_PROBABILITY  # peaks, none a keypoint: the case the old figure hid
    plot(push, tmp_path / "p.png")
    fig = drawn[-1]
    ax = _probability_axes(fig)
    combined, = _lines(ax, "combined")
    np.testing.assert_array_equal(combined.get_ydata(), push.probability)  # its own scale, not 1.0
    level, = _lines(ax, f"threshold {KEYPOINT_PROBABILITY:g}")
    assert np.all(np.asarray(level.get_ydata()) == KEYPOINT_PROBABILITY)
    assert ax.get_ylim()[0] <= 0.0 and ax.get_ylim()[1] >= 1.0 and "scaled" not in ax.get_ylabel()
    title = " ".join(fig._suptitle.get_text().split())  # (a title may be wrapped)
    assert "1 segment, no keypoint" in title and f"{top:.2f}" in title and "threshold 0.5" in title
    assert "threshold 0.5" in [t.get_text() for legend in fig.legends for t in legend.get_texts()]


def test_keypoints_are_the_peaks_above_the_threshold_the_title_counts(cut, tmp_path, drawn):
    assert threshold(cut) == KEYPOINT_PROBABILITY and cut.keypoints.size >= 2
    plot_keypoint_probability(cut, tmp_path / "p.png")
    fig = drawn[-1]
    ax = _probability_axes(fig)
    combined, = _lines(ax, "combined")
    assert np.all(np.asarray(combined.get_ydata())[cut.keypoints] > KEYPOINT_PROBABILITY)
    title = " ".join(fig._suptitle.get_text().split())
    assert title.startswith(f"Keypoint probability: {cut.n_segments} segments, "
                            f"{cut.keypoints.size} keypoints at ")
    assert title.count(",") == cut.keypoints.size  # one time per keypoint drawn


def test_the_product_rule_has_no_threshold_on_its_curve(cut, tmp_path, drawn):
    product = segment(cut.demonstration, ["position", "force"], window=16, combine="product")
    assert threshold(product) is None
    plot_keypoint_probability(product, tmp_path / "p.png")
    ax = _probability_axes(drawn[-1])
    assert not [line for line in ax.get_lines() if line.get_label().startswith("threshold")]
    assert "scaled to max 1" in ax.get_ylabel()  # a distribution over the samples, scaled, and said so


# -- words -------------------------------------------------------------------------------------------
def test_one_segment_is_singular(push, tmp_path, drawn):
    plot_segment_grid([push, push], tmp_path / "g.png")
    assert [ax.get_title() for ax in drawn[-1].axes] == ["1 segment", "1 segment"]
    plot_segments(push, tmp_path / "s.png")
    assert drawn[-1].axes[0].get_title() == "1 segment of position"


def test_units_where_known(cut, tmp_path, drawn):
    plot_segmentation_summary(cut, tmp_path / "s.png")
    labels = {ax.get_ylabel().split("\n")[0]: ax.get_ylabel() for ax in drawn[-1].axes}
    assert labels["|force|"] == "|force|\n(N)"  # ROS's SI units, which the readers follow
    assert labels["gripper"] == "gripper\n(as recorded)"  # a gripper's scale is the robot's own
    plot_segments(cut, tmp_path / "p.png", unit="m", below=("force", "gripper"))
    ylabels = [ax.get_ylabel() for ax in drawn[-1].axes]
    assert ylabels[1:] == ["|force|\n(N)", "gripper\n(as recorded)"]


# -- layout ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("dims", [2, 3])
def test_axis_labels_are_inside_the_canvas_and_off_the_panels_below(cut, tmp_path, drawn, dims):
    plot_segments(cut, tmp_path / "s.png", dims=dims, unit="m", below=("force", "gripper"))
    fig = drawn[-1]
    renderer = _renderer(fig)
    path, *below = fig.axes
    labels = [path.xaxis.label, path.yaxis.label] + ([path.zaxis.label] if dims == 3 else [])
    labels += [ax.yaxis.label for ax in below] + [below[-1].xaxis.label]
    canvas = fig.bbox
    for label in labels:
        box = label.get_window_extent(renderer)
        assert canvas.x0 <= box.x0 and box.x1 <= canvas.x1 and canvas.y0 <= box.y0 and box.y1 <= canvas.y1, \
            label.get_text()
    for label in labels[:3 if dims == 3 else 2]:  # the path's labels clear the time panels under it
        box = label.get_window_extent(renderer)
        assert not any(box.overlaps(ax.get_window_extent(renderer)) for ax in below), label.get_text()


def _reach(bend=0.0, n=50):
    s = np.linspace(0.0, 1.0, n)
    return np.c_[s, 0.5 * s, 0.2 + bend * np.sin(np.pi * s)]


def _three_d_legend_clear_of_its_axes(fig, ax, legend):
    renderer = _renderer(fig)
    box = legend.get_window_extent(renderer)
    assert not box.overlaps(ax.get_window_extent(renderer))
    assert fig.bbox.x0 <= box.x0 and box.x1 <= fig.bbox.x1  # and it is in the figure


def test_legends_of_3d_axes_are_beside_them(cut, tmp_path, drawn):
    plot_segments(cut, tmp_path / "s.png", dims=3)
    fig = drawn[-1]
    _three_d_legend_clear_of_its_axes(fig, fig.axes[0], fig.legends[0])
    plot_edit(_reach(0.3), tmp_path / "e.png", demo=_reach(), constraints=Constraints(goal=[1.0, 0.5, 0.2]))
    fig = drawn[-1]
    _three_d_legend_clear_of_its_axes(fig, fig.axes[0], fig.axes[0].get_legend())
    t = np.linspace(0.0, 1.0, 50)
    plot_executable(skillbank.Demonstration(t, {"position": _reach(0.3)}), tmp_path / "x.png",
                    demos=[_reach()], constraints=Constraints(goal=[1.0, 0.5, 0.2]))
    fig = drawn[-1]
    _three_d_legend_clear_of_its_axes(fig, fig.axes[0], fig.axes[0].get_legend())


def test_a_2d_legend_covers_no_sample_of_a_line(tmp_path, drawn):
    s = np.linspace(0.0, 1.0, 40)
    stored = [np.c_[s, np.sin(2.0 * s) + k * 0.05] for k in range(3)]
    plot_reuse(np.c_[s, np.sin(2.0 * s) + 0.3], tmp_path / "r.png", stored=stored, candidates=stored[:2],
               constraints=Constraints(goal=[1.0, 1.2]))
    fig = drawn[-1]
    renderer = _renderer(fig)
    for ax in fig.axes:
        box = ax.get_legend().get_window_extent(renderer)
        for line in ax.get_lines():
            xy = ax.transData.transform(np.column_stack([line.get_xdata(), line.get_ydata()]))
            inside = (xy[:, 0] > box.x0) & (xy[:, 0] < box.x1) & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1)
            assert not inside.any(), line.get_label()


def test_a_3d_legend_hides_no_sample_of_a_line(cut, tmp_path, drawn):
    plot_segments(cut, tmp_path / "s.png", dims=3)
    fig = drawn[-1]
    renderer = _renderer(fig)
    ax = fig.axes[0]
    box = fig.legends[0].get_window_extent(renderer)
    for line in ax.get_lines():
        x, y, z = (np.asarray(v, dtype=float) for v in line.get_data_3d())
        px, py, _ = proj3d.proj_transform(x, y, z, ax.get_proj())
        xy = ax.transData.transform(np.column_stack([px, py]))
        inside = (xy[:, 0] > box.x0) & (xy[:, 0] < box.x1) & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1)
        assert not inside.any(), line.get_label()


@pytest.mark.parametrize("where", ["suptitle", "axes"])
def test_a_long_title_is_wrapped_not_widening_the_figure(tmp_path, where):
    rng = np.random.default_rng(0)
    X = np.vstack([rng.normal(size=(10, 2)), rng.normal(size=(10, 2)) + 6.0])
    long = "a library recorded in the lab on a long afternoon, " * 8
    if where == "suptitle":
        out = plot_cluster_comparison(X, {"elastic": np.repeat([0, 1], 10)}, tmp_path / "c.png", title=long)
        width_in = 2.9 + 0.6
    else:
        s = np.linspace(0.0, 1.0, 20)
        out = plot_skills({long: [np.c_[s, s]]}, tmp_path / "k.png")
        width_in = 3.6
    height, width = mpimg.imread(out).shape[:2]
    # bbox_inches="tight" may trim or add a margin, never the title's 2,000 px
    assert width <= 1.1 * width_in * _DPI


# -- what the eye cannot count -------------------------------------------------------------------------
def test_members_drawn_over_each_other_are_said_identical(tmp_path, drawn):
    s = np.linspace(0.0, 1.0, 30)
    pick = np.c_[s, s ** 2, 0.1 * s]
    place = [np.c_[s, 1 - s, 0.2 * s], np.c_[s, 1 - s ** 2, 0.3 * s]]
    plot_skills({"pick": [pick, pick.copy(), pick + 1e-9], "place": place}, tmp_path / "k.png")
    titles = [ax.get_title() for ax in drawn[-1].axes]
    assert titles[0].split("\n")[1].startswith("3 primitives (identical), ")
    assert titles[1].split("\n")[1].startswith("2 primitives, ")
    plot_skills({"pick": [pick, pick, place[0]]}, tmp_path / "m.png")
    assert drawn[-1].axes[0].get_title().split("\n")[1].startswith("3 primitives (2 distinct), ")
    features = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [5.0, 5.0], [5.1, 5.0], [5.0, 5.2]])
    plot_cluster_comparison(features, {"elastic": [0, 0, 0, 1, 1, 1]}, tmp_path / "c.png",
                            trajectories=[pick, pick, pick, *place, pick])
    titles = [ax.get_title() for ax in drawn[-1].axes[1:]]
    assert titles == ["cluster 0 (3 identical)", "cluster 1 (3)"]
