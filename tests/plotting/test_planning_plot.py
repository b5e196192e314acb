"""plot_plan: every kind of marker of a planned task is named in the legend, the axes carry the unit."""

from __future__ import annotations

import numpy as np

from skillbank import Demonstration
from skillbank.planning import PlanResult, PlanStep, scene_from_dict
from skillbank.plotting import plot_plan


def test_legend_names_every_marker_and_axes_their_unit(tmp_path, drawn):
    t = np.linspace(0.0, 1.0, 20)
    traj = Demonstration(t, {"position": np.c_[t, t, 0 * t]})
    step = PlanStep("press", ("b1",), "press", 0, 20, [1], np.array([1.0, 1, 0]), None, "lte", 0.0, 0.0,
                    False)
    scene = scene_from_dict({"objects": {"b1": {"type": "button", "position": [1, 1, 0]}},
                             "obstacles": ["sphere:0.5,0.2,0,0.1"], "goal": ["(pressed b1)"]})
    result = PlanResult([("press", ("b1",))], [step], traj, False, 0.0, {})
    plot_plan(result, scene, tmp_path / "plan.png", demos={1: traj}, unit="m")
    ax = drawn[-1].axes[0]
    names = [t.get_text() for t in ax.get_legend().get_texts()]
    assert names == ["primitives used", "1. (press b1)", "step goal", "object", "obstacle", "start"]
    assert [ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()] == ["x (m)", "y (m)", "z (m)"]
