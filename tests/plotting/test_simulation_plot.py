"""The simulation figure read at a glance (issue 44, item 6): marker colours the legend explains,
the press force drawn with each button's peak, a force still high at the end not cut by the frame.

The result is built by hand (no physics): b1 pressed with a peak of 7.9 N,
b2 pushed to 71.7 N right at the end of the run, a crate that is no button.
"""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np
import pytest
from matplotlib.colors import to_rgba

from skillbank.planning import scene_from_dict
from skillbank.plotting import plot_simulation
from skillbank.simulation import PRESS_FORCE, SimulationResult

from .test_glance import _renderer

DOWN = [0.0, 1.0, 0.0, 0.0]


@pytest.fixture
def wall(tmp_path, drawn):
    t = np.linspace(0.0, 11.0, 1101)
    tool = np.c_[np.linspace(-0.6, -0.3, t.size), np.zeros(t.size), 0.1 + 0.0 * t]
    b1 = np.where(np.abs(t - 4.0) < 0.3, 7.9, 0.0)
    b2 = np.where(t > 10.8, 71.7 * (t - 10.8) / 0.2, 0.0)  # still rising when the run ends
    result = SimulationResult(11.0, 1.0, 0.0, 0.0, [], {
        "b1": {"pressed": True, "peak_force": 7.9, "t": 3.9},
        "b2": {"pressed": False, "peak_force": 71.7, "t": None}}, {}, {},
        t_=t, tool_=tool, tool_ref_=tool, button_force_={"b1": b1, "b2": b2})
    scene = scene_from_dict({
        "objects": {"b1": {"type": "button", "position": [-0.6, 0.0, 0.0], "orientation": DOWN},
                    "b2": {"type": "button", "position": [-0.3, 0.0, 0.0], "orientation": DOWN},
                    "crate": {"type": "object", "position": [-0.4, 0.3, 0.1]}},
        "obstacles": [], "init": ["(free b1)", "(free b2)"], "goal": ["(pressed b1)"]})
    out = plot_simulation(result, scene, tmp_path / "sim.png", title="two presses")
    # a legend under the force panel, not beside it: the figure keeps its width
    assert mpimg.imread(out).shape[1] <= 2000
    return drawn[-1], result


def _rgba(colour):
    return tuple(np.round(to_rgba(colour), 3))


def test_every_marker_colour_is_the_one_its_legend_entry_shows(wall):
    fig, _ = wall
    ax = fig.axes[0]
    legend = ax.get_legend()
    shown = {text.get_text(): _rgba(handle.get_facecolor()[0])
             for text, handle in zip(legend.get_texts(), legend.legend_handles, strict=True)
             if hasattr(handle, "get_facecolor")}
    start, b1, b2, crate = ax.collections  # drawn in this order: the start, then the scene's objects
    kinds = {"button, pressed": b1, "button, not pressed": b2, "object": crate}
    for label, marker in kinds.items():
        assert shown[label] == _rgba(marker.get_facecolor()[0]), label
    assert _rgba(crate.get_facecolor()[0]) == _rgba("black")  # the crate is black and said to be an object
    assert len(set(shown[label] for label in kinds)) == 3  # three colours, three meanings


def test_the_force_panel_names_the_press_force_and_each_peak(wall):
    fig, _ = wall
    ax = fig.axes[1]
    labels = [text.get_text() for text in ax.get_legend().get_texts()]
    assert "b1 (peak 7.9 N)" in labels
    assert f"b2 (peak 71.7 N: against its end stop, past {1.5 * PRESS_FORCE:.3g} N)" in labels
    level, = [line for line in ax.get_lines() if line.get_label() == f"press force {PRESS_FORCE:g} N"]
    assert np.all(np.asarray(level.get_ydata()) == PRESS_FORCE)


def test_a_force_at_the_end_is_inside_the_frame_and_the_end_is_drawn(wall):
    fig, result = wall
    ax = fig.axes[1]
    renderer = _renderer(fig)
    frame = ax.get_window_extent(renderer)
    b2 = next(line for line in ax.get_lines() if line.get_label().startswith("b2"))
    x_end, _ = ax.transData.transform((b2.get_xdata()[-1], b2.get_ydata()[-1]))
    assert x_end < frame.x1 - 5  # pixels of margin: the curve visibly stops before the edge
    end, = [line for line in ax.get_lines() if line.get_label() == "end of the simulation"]
    assert np.all(np.asarray(end.get_xdata()) == result.t_[-1])


def test_the_legends_cover_no_data_and_every_label_is_in_the_canvas(wall):
    fig, _ = wall
    renderer = _renderer(fig)
    for ax in fig.axes:
        box = ax.get_legend().get_window_extent(renderer)
        assert not box.overlaps(ax.get_window_extent(renderer))  # beside its axes
        assert fig.bbox.x0 <= box.x0 and box.x1 <= fig.bbox.x1
        assert fig.bbox.y0 <= box.y0 and box.y1 <= fig.bbox.y1
        labels = [ax.xaxis.label, ax.yaxis.label, ax.title] + ([ax.zaxis.label] if ax.name == "3d" else [])
        for label in labels:
            extent = label.get_window_extent(renderer)
            assert fig.bbox.x0 <= extent.x0 and extent.x1 <= fig.bbox.x1, label.get_text()
            assert fig.bbox.y0 <= extent.y0 and extent.y1 <= fig.bbox.y1, label.get_text()
