"""The figure of a plan carried out in a robosuite scene: the chained tool path, step by step, over the
objects where they started and where they ended."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ._segmentation import _save, legend_beside

__all__ = ["plot_composed"]


def plot_composed(episode: dict, path, *, title=None) -> Path:
    """Write the figure of one episode of :func:`skillbank.simulation.execute_plan` (run with
    ``paths=True``); returns the file.

    Left: the tool path seen from above (x, y in metres), one colour per plan step, each object's
    position at rest before the first step (circle) and at the end (cross, joined by an arrow).
    Right: the tool's height (m) against time (s), with the steps' starts. The legend lists the steps in
    the order they were carried out; the title says when that is not the first plan: a replan, or the
    moves the goal leaves free ordered in the world before each step.

    Examples
    --------
    >>> import os, tempfile
    >>> ep = {"path": [[0, 0, 1], [0.1, 0, 0.9], [0.2, 0.1, 0.9]], "step_starts": [0, 1],
    ...       "steps": [{"action": "pick", "args": ["a"], "ok": True},
    ...                 {"action": "place", "args": ["a", "b"], "ok": True}],
    ...       "objects": {"a": [0.1, 0.0, 0.8]}, "facts": {"end": []}, "success": True, "seed": 0,
    ...       "end_objects": {"a": [0.2, 0.1, 0.85]}}
    >>> plot_composed(ep, os.path.join(tempfile.mkdtemp(), "plan.png")).name
    'plan.png'
    """
    P = np.asarray(episode["path"], float).reshape(-1, 3)
    starts = list(episode.get("step_starts", [])) + [len(P)]
    steps = episode["steps"][:len(starts) - 1]
    fig = Figure(figsize=(12, 5.2), layout="constrained")
    top, side = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    colours = [f"C{k % 10}" for k in range(len(steps))]
    t = np.arange(len(P)) / 20.0
    if len(P) and starts[0] > 0:
        top.plot(P[:starts[0] + 1, 0], P[:starts[0] + 1, 1], color="#a8a8a8", linewidth=1.0)
        side.plot(t[:starts[0] + 1], P[:starts[0] + 1, 2], color="#a8a8a8", linewidth=1.0)
    for k, (st, colour) in enumerate(zip(steps, colours, strict=True)):
        a, b = starts[k], min(starts[k + 1] + 1, len(P))
        name = f"{k + 1}. ({' '.join([st['action'], *st['args']])})" + ("" if st.get("ok") else " failed")
        top.plot(P[a:b, 0], P[a:b, 1], color=colour, linewidth=1.6, label=name)
        side.plot(t[a:b], P[a:b, 2], color=colour, linewidth=1.6, label=name)
        side.axvline(t[a] if a < len(t) else t[-1], color=colour, linewidth=0.6, linestyle=":")
    end = episode.get("end_objects", {})
    for name, p in episode.get("objects", {}).items():
        top.plot(p[0], p[1], "o", color="black", markersize=6, markerfacecolor="none")
        top.annotate(name, (p[0], p[1]), textcoords="offset points", xytext=(4, 4), fontsize=8)
        if name in end:
            q = end[name]
            top.plot(q[0], q[1], "x", color="black", markersize=7)
            top.annotate("", xy=(q[0], q[1]), xytext=(p[0], p[1]),
                         arrowprops={"arrowstyle": "->", "color": "#606060", "linewidth": 0.8})
    top.plot([], [], "o", color="black", markerfacecolor="none", label="object at the start")
    top.plot([], [], "x", color="black", label="object at the end")
    top.set_xlabel("x (m)")
    top.set_ylabel("y (m)")
    top.set_aspect("equal", adjustable="datalim")
    top.set_title("tool path from above, by plan step")
    legend_beside(top, fontsize=7)
    side.set_xlabel("time (s)")
    side.set_ylabel("tool height z (m)")
    side.set_title("tool height")
    verdict = "success" if episode.get("success") else \
        f"failure: {episode.get('failure', {}).get('reason', '?')}"
    carried = [f"({' '.join([st['action'], *st['args']])})" for st in steps]
    replans = int(episode.get("replans") or 0)
    # the legend lists the steps carried out; a title that quoted the first plan disagreed with it
    if replans:
        verdict += (f", replanned {replans} time{'s' if replans != 1 else ''}: the legend lists the steps "
                    "carried out")
    elif carried != list(episode.get("plan", carried))[:len(carried)]:
        # no replan: the moves the goal leaves free were ordered in the world before each step (tallest
        # first), which "replanned" misnamed
        verdict += ", steps in the order the world chose (the legend's), not the plan's"
    fig.suptitle(f"{title or 'plan in simulation'}: {verdict}")
    return _save(fig, path)
