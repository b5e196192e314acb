"""Tests for skillbank.plotting: segmentation figures are written as PNG files."""

from __future__ import annotations

import numpy as np
import pytest

import skillbank
import skillbank.io
from skillbank.plotting import (
    plot_jerk_profile,
    plot_keypoint_probability,
    plot_segmentation_summary,
    plot_segments,
)
from skillbank.plotting._segmentation import _colour
from skillbank.segmentation import segment

from .conftest import three_streams

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _is_png(path) -> bool:
    data = path.read_bytes()
    return len(data) > 1000 and data[:8] == PNG_MAGIC


@pytest.fixture(scope="module")
def result():
    return segment(three_streams(), ["position", "force"], window=16)


def test_segmentation_has_keypoints(result):
    assert result.n_segments > 1


@pytest.mark.parametrize("stream", [None, "position", "force"])
def test_plot_jerk_profile(result, tmp_path, stream):
    out = plot_jerk_profile(result, tmp_path / "nested" / "jerk.png", stream=stream)
    assert out == tmp_path / "nested" / "jerk.png"
    assert _is_png(out)


def test_plot_keypoint_probability(result, tmp_path):
    out = plot_keypoint_probability(result, str(tmp_path / "prob.png"))
    assert _is_png(out)


@pytest.mark.parametrize(
    ("stream", "dims", "invert_y"),
    [("position", None, False), ("position", 2, True), ("position", 3, False), ("force", None, False)],
)
def test_plot_segments(result, tmp_path, stream, dims, invert_y):
    out = plot_segments(result, tmp_path / "seg.png", stream=stream, dims=dims, invert_y=invert_y)
    assert _is_png(out)


def test_plot_segments_unsegmented_stream(result, tmp_path):
    # any stream of the demonstration can be drawn, not only segmented ones
    assert "gripper" not in result.streams
    with pytest.raises(ValueError, match="dims"):
        plot_segments(result, tmp_path / "g.png", stream="gripper")


@pytest.mark.parametrize("stream", [None, "force", ["position", "force"]])
def test_plot_segmentation_summary(result, tmp_path, stream):
    out = plot_segmentation_summary(result, tmp_path / "summary.png", stream=stream)
    assert _is_png(out)


@pytest.mark.parametrize(
    "plot", [plot_jerk_profile, plot_keypoint_probability, plot_segments, plot_segmentation_summary]
)
def test_rejects_non_result(plot, tmp_path):
    with pytest.raises(ValueError, match="result.*SegmentationResult"):
        plot({"keypoints": []}, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("plot", [plot_jerk_profile, plot_segments, plot_segmentation_summary])
def test_rejects_unknown_stream(result, plot, tmp_path):
    with pytest.raises(ValueError, match=r"stream.*'position'.*'nope'"):
        plot(result, tmp_path / "x.png", stream="nope")


def test_jerk_profile_rejects_unsegmented_stream(result, tmp_path):
    with pytest.raises(ValueError, match="segmented streams"):
        plot_jerk_profile(result, tmp_path / "x.png", stream="gripper")


@pytest.mark.parametrize(
    ("stream", "dims", "match"),
    [("position", 4, "expected 2 or 3"), ("position", 1, "expected 2 or 3"), ("position", True, "2 or 3"),
     ("force", 3, "at most the 2 columns")],
)
def test_plot_segments_rejects_bad_dims(result, tmp_path, stream, dims, match):
    with pytest.raises(ValueError, match=match):
        plot_segments(result, tmp_path / "x.png", stream=stream, dims=dims)


def test_real_handwriting_r(data_dir, tmp_path):
    demo = skillbank.io.read_handwriting_h5(data_dir / "seed" / "r_shape.h5", group="normalized", index=3)
    res = segment(demo, window=16, min_size=64, threshold=0.16)
    paths = [
        plot_jerk_profile(res, tmp_path / "r_changepoints.png"),
        plot_keypoint_probability(res, tmp_path / "r_probability.png"),
        plot_segments(res, tmp_path / "r_segmented.png", invert_y=True),
        plot_segmentation_summary(res, tmp_path / "r_summary.png"),
    ]
    assert all(_is_png(p) for p in paths)


def test_single_segment_without_keypoints(tmp_path):
    t = np.linspace(0.0, 1.0, 300)
    res = segment(skillbank.Demonstration.from_array(np.zeros((300, 3)), t))
    assert res.n_segments == 1
    for plot in (plot_jerk_profile, plot_keypoint_probability, plot_segments, plot_segmentation_summary):
        assert _is_png(plot(res, tmp_path / f"{plot.__name__}.png"))


def test_plot_segment_grid(result, tmp_path):
    from skillbank.plotting import plot_segment_grid

    path = plot_segment_grid([result, result], tmp_path / "grid.png", titles=["a", "b"], invert_y=True)
    assert _is_png(path)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"results": []}, r"results: expected at least one SegmentationResult, got none"),
        ({"titles": ["only one", "two", "three"]}, r"titles: expected 1 titles, got 3"),
        ({"stream": "force_x"}, r"stream: expected a stream with at least 2 columns"),
        ({"results": [object()]}, r"result: expected a SegmentationResult, got object"),
    ],
)
def test_plot_segment_grid_rejects(result, tmp_path, kwargs, match):
    from skillbank.plotting import plot_segment_grid

    args = {"results": [result], **kwargs}
    with pytest.raises(ValueError, match=match):
        plot_segment_grid(args.pop("results"), tmp_path / "g.png", **args)


@pytest.fixture(scope="module")
def multikind(result):
    """All three kinds: motion (position), contact (force, its changepoints not the keypoints), discrete."""
    return segment(result.demonstration, window=16)


def _data_lines(ax):
    """The curves of a panel, without the vertical lines that mark changepoints and keypoints."""
    return [line for line in ax.get_lines() if np.ptp(np.asarray(line.get_xdata(), dtype=float)) > 0]


def test_summary_panels_name_what_each_kind_was_read_from(multikind, tmp_path, drawn):
    assert {s.kind for s in multikind.streams.values()} == {"motion", "contact", "discrete"}
    plot_segmentation_summary(multikind, tmp_path / "s.png")
    fig = drawn[-1]
    labels = [ax.get_ylabel() for ax in fig.axes]
    # one panel per stream, then the keypoint curves and the support rows
    assert len(labels) == len(multikind.streams) + 2
    assert "jerk" in labels[0] and "position" in labels[0] and "typical" in labels[0]
    assert labels[1].startswith("|force|") and "jerk" not in labels[1]
    assert labels[2].startswith("gripper") and "jerk" not in labels[2]
    # a contact panel shows the force's magnitude, a discrete one the gripper's value
    force = np.linalg.norm(multikind.demonstration["force"], axis=1)
    drawn_force = np.concatenate([line.get_ydata()[:-1] for line in _data_lines(fig.axes[1])[:-1]]
                                 + [_data_lines(fig.axes[1])[-1].get_ydata()])
    np.testing.assert_allclose(drawn_force, force)


def test_summary_colours_follow_the_final_segments(multikind, tmp_path, drawn):
    force = multikind.streams["force"]
    assert force.changepoints.tolist() != multikind.keypoints.tolist()  # else the test could not fail
    plot_segmentation_summary(multikind, tmp_path / "s.png")
    fig = drawn[-1]
    expected = [_colour(k) for k in range(multikind.n_segments)]
    for ax in fig.axes[:len(multikind.streams)]:
        lines = _data_lines(ax)
        assert [line.get_color() for line in lines] == expected
        # each run starts at its segment's first sample
        starts = [float(line.get_xdata()[0]) for line in lines]
        np.testing.assert_allclose(starts[1:], multikind.demonstration.t[multikind.keypoints])


@pytest.mark.parametrize("plot", [plot_segmentation_summary, plot_keypoint_probability])
def test_support_rows_name_each_keypoints_streams(multikind, tmp_path, drawn, plot):
    plot(multikind, tmp_path / "p.png")
    fig = drawn[-1]
    support = fig.axes[-1]
    assert [t.get_text() for t in support.get_yticklabels()] == list(multikind.streams)
    dots = np.concatenate([c.get_offsets() for c in support.collections])
    t = multikind.demonstration.t
    want = sorted((float(t[k]), list(multikind.streams).index(name))
                  for k, s in zip(multikind.keypoints, multikind.keypoint_support, strict=True) for name in s)
    assert sorted(map(tuple, dots.tolist())) == want
    assert not any(ax.texts for ax in fig.axes)  # no rotated labels over the curves
    names = [t.get_text() for legend in fig.legends for t in legend.get_texts()]
    assert {*multikind.streams, "combined", "keypoint"} <= set(names)
    assert fig.axes[-1].get_xlabel() == "Time [s]"


def test_three_button_summary_has_no_colliding_labels(data_dir, tmp_path, drawn, collisions):
    demo = skillbank.io.read_robot_h5(data_dir / "seed" / "three_button_pressing_demo.h5")
    res = segment(demo)
    plot_segmentation_summary(res, tmp_path / "s.png")
    plot_keypoint_probability(res, tmp_path / "p.png")
    for fig in drawn:
        assert collisions(fig) == []
    ylabels = [ax.get_ylabel() for ax in drawn[0].axes]
    assert [label for label in ylabels if "jerk" in label] == [
        f"{name} jerk\n(1 = typical)" for name in ("joints", "position", "orientation")]


def test_plot_segments_draws_streams_below_the_path(result, tmp_path):
    import matplotlib.image as mpimg

    plain = plot_segments(result, tmp_path / "plain.png", dims=3)
    out = plot_segments(result, tmp_path / "below.png", dims=3, below=("force", "gripper"))
    assert _is_png(out)
    # two time panels under the path make the figure taller, by about 1.2 in each
    h_plain, h_below = mpimg.imread(plain).shape[0], mpimg.imread(out).shape[0]
    assert 1.25 < h_below / h_plain < 1.6
    assert _is_png(plot_segments(result, tmp_path / "one.png", dims=2, below="gripper"))


def test_plot_segments_below_names_an_unknown_stream(result, tmp_path):
    with pytest.raises(ValueError, match=r"below: expected streams of the demonstration .*got 'wrench'"):
        plot_segments(result, tmp_path / "x.png", below=("force", "wrench"))
    assert not (tmp_path / "x.png").exists()


def test_plot_segments_axes_have_units(result, tmp_path, drawn):
    plot_segments(result, tmp_path / "s.png", dims=3, unit="m", below=("force",))
    path, force = drawn[-1].axes
    assert [path.get_xlabel(), path.get_ylabel(), path.get_zlabel()] == [
        "position[0] (m)", "position[1] (m)", "position[2] (m)"]
    # a force is in newtons (ROS's SI convention, which the readers follow), not "as recorded"
    assert force.get_ylabel() == "|force|\n(N)" and force.get_xlabel() == "Time [s]"
    plot_segments(result, tmp_path / "flat.png", dims=2, invert_y=True)
    assert drawn[-1].axes[0].get_ylabel() == "-position[1] (as recorded)"
