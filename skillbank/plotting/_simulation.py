"""The figure of a simulation: the tool path with contacts marked, and the force on each button over time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ._editing import _extent, _obstacle, axis_labels
from ._segmentation import _save, legend_beside

__all__ = ["plot_simulation"]


def plot_simulation(result, scene, path, *, title=None) -> Path:
    """Write the figure of a :class:`~skillbank.simulation.SimulationResult`; returns the file.

    Left: the simulated tool path in 3-D (metres) with the commanded one, the scene's obstacles and
    objects, and a cross where each unintended contact started. Right: the robot's force on each button
    (N) against time (s), with the time it first counted as pressed.

    Examples
    --------
    >>> import os, tempfile
    >>> from skillbank.simulation import SimulationResult
    >>> from skillbank.planning import Scene
    >>> t = np.linspace(0.0, 1.0, 50)
    >>> res = SimulationResult(1.0, 10.0, 0.0, 0.0, [], {}, {}, {}, t_=t, tool_=np.c_[t, t, t],
    ...                        tool_ref_=np.c_[t, t, t])
    >>> out = plot_simulation(res, Scene(objects={}, obstacles={}, init=[], goal=[]),
    ...                       os.path.join(tempfile.mkdtemp(), "sim.png"))
    >>> out.name
    'sim.png'
    """
    fig = Figure(figsize=(13, 5.2), layout="constrained")
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    Y, R = np.asarray(result.tool_), np.asarray(result.tool_ref_)
    ax.plot(*R.T, color="#a8a8a8", linewidth=1.0, linestyle="--", label="commanded tool path")
    ax.plot(*Y.T, color="tab:blue", linewidth=1.6, label="simulated tool path")
    ax.scatter(*Y[0], color="black", marker="^", s=30, label="start")
    points = [Y]
    for k, ob in enumerate(scene.obstacles.values()):
        _obstacle(ax, ob, True, label="obstacle" if k == 0 else None)
        points.append(np.vstack(ob.bounds()))
    placed = [(name, obj) for name, obj in scene.objects.items() if obj.position is not None]
    for k, (name, obj) in enumerate(placed):
        pressed = result.buttons.get(name, {}).get("pressed")
        colour = {True: "tab:green", False: "tab:red"}.get(pressed, "black")
        ax.scatter(*obj.position, color=colour, marker="o", s=22, label="object" if k == 0 else None)
        ax.text(*obj.position, f" {name}", fontsize=8)
        points.append(np.asarray(obj.position, float)[None])
    where = [np.asarray(p) for p in result.contact_points_]
    if where:
        P = np.vstack(where)
        ax.scatter(*P.T, color="tab:red", marker="x", s=60, linewidths=2, label="unintended contact")
        for p, c in zip(P, result.contacts, strict=True):
            ax.text(*p, f" {c['robot_body']}-{c['other']} {c['t']:.2f} s", fontsize=7, color="tab:red")
    _extent(ax, np.vstack(points), True)
    axis_labels(ax, "m")
    legend_beside(ax, fontsize=7)
    ax.set_title("tool path")
    ax2 = fig.add_subplot(1, 2, 2)
    t = np.asarray(result.t_)
    for name, force in result.button_force_.items():
        line, = ax2.plot(t, force, linewidth=1.2, label=name)
        pressed_at = result.buttons[name]["t"]
        if pressed_at is not None:
            ax2.axvline(pressed_at, color=line.get_color(), linestyle=":", linewidth=1.0)
    if not result.button_force_:
        ax2.text(0.5, 0.5, "no buttons in the scene", ha="center", va="center", transform=ax2.transAxes)
    else:
        ax2.plot([], [], color="black", linestyle=":", label="first pressed")
        legend_beside(ax2, fontsize=8)
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("robot force on the button (N)")
    ax2.set_title("button forces")
    ax2.set_xlim(0.0, max(float(t[-1]) if t.size else 1.0, 1e-9))
    if title:
        fig.suptitle(title)
    return _save(fig, path)
