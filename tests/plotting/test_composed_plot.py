"""plot_composed read at a glance (issue 44, item 6): the legend lists the steps carried out, in order,
the title says when that is not the first plan, and a long title does not widen the figure."""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np

from skillbank.plotting import plot_composed
from skillbank.plotting._segmentation import _DPI


def _episode(steps, plan, replans=0):
    n = 20 * len(steps)
    s = np.linspace(0.0, 1.0, n)
    return {"path": np.c_[0.2 * s, -0.3 + 0.5 * s, 0.9 + 0.1 * np.sin(6 * s)].tolist(),
            "step_starts": list(range(0, n, 20)), "steps": steps, "plan": plan, "replans": replans,
            "objects": {"Milk": [0.1, -0.3, 0.85], "Can": [0.12, -0.28, 0.85]},
            "end_objects": {"Milk": [0.2, 0.15, 0.85]}, "success": False,
            "failure": {"reason": "dropped"}, "seed": 101}


def _step(action, *args):
    return {"action": action, "args": list(args), "ok": True}


def test_the_legend_lists_the_steps_carried_out_and_the_title_says_replanned(tmp_path, drawn):
    steps = [_step("pick", "Can"), _step("place", "Can", "Can_place"), _step("pick", "Milk")]
    plan = ["(pick Milk)", "(place Milk Milk_place)", "(pick Can)", "(place Can Can_place)"]
    plot_composed(_episode(steps, plan, replans=1), tmp_path / "u.png", title="robosuite:PickPlace, seed 101")
    fig = drawn[-1]
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert legend[:3] == ["1. (pick Can)", "2. (place Can Can_place)", "3. (pick Milk)"]
    title = " ".join(fig._suptitle.get_text().split())
    assert title == ("robosuite:PickPlace, seed 101: failure: dropped, replanned 1 time: "
                     "the legend lists the steps carried out")


def test_an_order_chosen_in_the_world_is_not_called_a_replan(tmp_path, drawn):
    # the goal left the order free: the moves were taken in the world's order, with no replan
    steps = [_step("pick", "Milk"), _step("place", "Milk", "Milk_place")]
    plan = ["(pick Can)", "(place Can Can_place)", "(pick Milk)", "(place Milk Milk_place)"]
    plot_composed(_episode(steps, plan), tmp_path / "u.png", title="robosuite:PickPlace, seed 101")
    title = " ".join(drawn[-1]._suptitle.get_text().split())
    assert title == ("robosuite:PickPlace, seed 101: failure: dropped, steps in the order the world chose "
                     "(the legend's), not the plan's")
    assert "replanned" not in title


def test_a_plan_carried_out_as_planned_says_nothing_more(tmp_path, drawn):
    steps = [_step("pick", "Milk"), _step("place", "Milk", "Milk_place")]
    plan = ["(pick Milk)", "(place Milk Milk_place)", "(pick Can)"]  # stopped after two steps, as planned
    plot_composed(_episode(steps, plan), tmp_path / "u.png")
    assert drawn[-1]._suptitle.get_text() == "plan in simulation: failure: dropped"


def test_a_long_title_is_wrapped_within_the_figure(tmp_path):
    steps = [_step("pick", "Milk"), _step("place", "Milk", "Milk_place")]
    long = "experiment unload, seed 0: " + " ".join(f"(pick T{k}) (place T{k} Bin{k})" for k in range(14))
    episode = _episode(steps, ["(pick Milk)", "(place Milk Milk_place)"])
    out = plot_composed(episode, tmp_path / "u.png", title=long)
    assert mpimg.imread(out).shape[1] <= 1.1 * 12 * _DPI  # the figure's 12 in, not the title's 2,500 px
