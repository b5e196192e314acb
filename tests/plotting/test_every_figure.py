"""Every figure the package draws, checked the same way (issue 44, item 6).

Each public ``plot_*`` is rendered on small known inputs; then every axis
label, title, tick label and legend is inside the figure's canvas (nothing
cut at an edge), the saved image is at most 2,000 px wide, and no legend
covers a sample of a 2-D line or the panes of a 3-D axes.
"""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

import skillbank
from skillbank.core import Constraints
from skillbank.planning import PlanResult, PlanStep, scene_from_dict
from skillbank.plotting import (
    plot_cluster_comparison,
    plot_composed,
    plot_edit,
    plot_executable,
    plot_jerk_profile,
    plot_keypoint_probability,
    plot_plan,
    plot_reuse,
    plot_segment_grid,
    plot_segmentation_summary,
    plot_segments,
    plot_simulation,
    plot_skills,
)
from skillbank.segmentation import segment
from skillbank.simulation import SimulationResult

from .conftest import three_streams

S = np.linspace(0.0, 1.0, 40)
PATH = np.c_[S, 0.5 * S, 0.2 + 0.1 * np.sin(np.pi * S)]


def _cut():
    return segment(three_streams(), window=16)


def _simulation(out):
    t = np.linspace(0.0, 2.0, 200)
    result = SimulationResult(2.0, 1.0, 0.0, 0.0, [], {"b1": {"pressed": True, "peak_force": 8.0, "t": 1.0}},
                              {}, {}, t_=t, tool_=np.c_[t, t, t] / 4, tool_ref_=np.c_[t, t, t] / 4,
                              button_force_={"b1": np.where(t > 0.9, 8.0, 0.0)})
    scene = scene_from_dict({"objects": {"b1": {"type": "button", "position": [0.5, 0.5, 0.5],
                                                "orientation": [0.0, 1.0, 0.0, 0.0]}},
                             "obstacles": [], "init": ["(free b1)"], "goal": ["(pressed b1)"]})
    return plot_simulation(result, scene, out, title="a press")


def _composed(out):
    episode = {"path": PATH.tolist(), "step_starts": [0, 20],
               "steps": [{"action": "pick", "args": ["a"], "ok": True},
                         {"action": "place", "args": ["a", "b"], "ok": True}],
               "plan": ["(pick a)", "(place a b)"], "objects": {"a": [0.1, 0.05, 0.2]},
               "end_objects": {"a": [0.9, 0.45, 0.2]}, "success": True, "seed": 0}
    return plot_composed(episode, out, title="unload")


def _plan(out):
    t = np.linspace(0.0, 1.0, 20)
    traj = skillbank.Demonstration(t, {"position": np.c_[t, t, 0 * t]})
    step = PlanStep("press", ("b1",), "press", 0, 20, [1], np.array([1.0, 1, 0]), None, "lte", 0.0, 0.0,
                    False)
    scene = scene_from_dict({"objects": {"b1": {"type": "button", "position": [1, 1, 0]}},
                             "obstacles": ["sphere:0.5,0.2,0,0.1"], "goal": ["(pressed b1)"]})
    result = PlanResult([("press", ("b1",))], [step], traj, False, 0.0, {})
    return plot_plan(result, scene, out, demos={1: traj}, unit="m",
                     title="four new buttons pressed in the code's order around a post, " * 3)


FIGURES = {
    "segments 3-D": lambda out: plot_segments(_cut(), out, dims=3, unit="m", below=("force", "gripper")),
    "segments 2-D": lambda out: plot_segments(_cut(), out, dims=2, unit="m"),
    "summary": lambda out: plot_segmentation_summary(_cut(), out),
    "probability": lambda out: plot_keypoint_probability(_cut(), out),
    "jerk": lambda out: plot_jerk_profile(_cut(), out),
    "grid": lambda out: plot_segment_grid([_cut(), _cut()], out),
    "skills": lambda out: plot_skills({"reach": [PATH, PATH + 0.1], "press": [PATH[::-1]]}, out),
    "clusters": lambda out: plot_cluster_comparison(
        np.r_[np.zeros((3, 2)), np.ones((3, 2)) * 5], {"elastic": [0, 0, 0, 1, 1, 1]}, out,
        trajectories=[PATH] * 3 + [PATH[::-1]] * 3),
    "edit": lambda out: plot_edit(PATH + 0.05, out, demo=PATH, constraints=Constraints(goal=PATH[-1] + 0.05)),
    "reuse": lambda out: plot_reuse(PATH[:, :2] + 0.1, out, stored=[PATH[:, :2]], candidates=[PATH[:, :2]],
                                    constraints=Constraints(goal=PATH[-1, :2] + 0.1)),
    "executable": lambda out: plot_executable(
        skillbank.Demonstration(S, {"position": PATH, "joints": np.tile(S[:, None], (1, 6))}), out,
        demos=[PATH], constraints=Constraints(goal=PATH[-1])),
    "simulation": _simulation,
    "composed": _composed,
    "plan": _plan,
}


@pytest.mark.parametrize("name", list(FIGURES))
def test_every_text_is_inside_the_canvas_and_the_image_is_bounded(name, tmp_path, drawn):
    out = FIGURES[name](tmp_path / "f.png")
    fig = drawn[-1]
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    box = fig.bbox
    texts = [fig._suptitle] if fig._suptitle is not None else []
    legends = list(fig.legends)
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        axes = [ax.xaxis, ax.yaxis] + ([ax.zaxis] if ax.name == "3d" else [])
        texts += [ax.title] + [a.label for a in axes]
        # the ticks drawn: those in the view (get_ticklabels also lists the locator's ticks beyond it)
        # (a 3-D axis places its tick labels while it draws, so they are checked on 2-D axes only)
        texts += [tick.label1 for a in axes for tick in a._update_ticks() if tick.label1.get_visible()] \
            if ax.name != "3d" else []
        legends += [ax.get_legend()] if ax.get_legend() is not None else []
    texts = [t for t in texts if t.get_visible() and t.get_text()]
    assert texts
    for artist in texts + legends:
        extent = artist.get_window_extent(renderer)
        where = artist.get_text() if hasattr(artist, "get_text") else "legend"
        assert box.x0 - 1 <= extent.x0 and extent.x1 <= box.x1 + 1, where
        assert box.y0 - 1 <= extent.y0 and extent.y1 <= box.y1 + 1, where
    assert mpimg.imread(out).shape[1] <= 2000


@pytest.mark.parametrize("name", list(FIGURES))
def test_no_legend_covers_a_sample(name, tmp_path, drawn):
    FIGURES[name](tmp_path / "f.png")
    fig = drawn[-1]
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    boxes = [legend.get_window_extent(renderer) for legend in fig.legends]
    boxes += [ax.get_legend().get_window_extent(renderer) for ax in fig.axes if ax.get_legend() is not None]
    for ax in fig.axes:
        if ax.name == "3d":  # no corner of a 3-D axes is free: every legend is beside it, off the panes
            assert not any(box.overlaps(ax.get_window_extent(renderer)) for box in boxes), name
            continue
        for line in ax.get_lines():
            x, y = (np.asarray(v, dtype=float) for v in line.get_data())
            if not x.size:
                continue  # a legend-only entry
            xy = line.get_transform().transform(np.column_stack([x, y]))  # (axvline: y in axes units)
            for box in boxes:
                inside = (xy[:, 0] > box.x0) & (xy[:, 0] < box.x1) & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1)
                assert not inside.any(), (name, line.get_label())
