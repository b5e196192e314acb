"""The figure of a planned task: the path in 3-D coloured by step, with the scene's objects and obstacles."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure

from ._editing import _extent, _obstacle, axis_labels
from ._segmentation import _save, legend_beside

__all__ = ["draw_plan", "plot_plan"]


def draw_plan(ax, result, scene, *, demos=None, legend: bool = True, unit: str | None = None) -> None:
    """Draw a plan's trajectory on 3-D axes: one colour per step, objects labelled, obstacles as wireframes.

    Parameters
    ----------
    ax : 3-D matplotlib axes
    result : skillbank.planning.PlanResult
    scene : skillbank.planning.Scene
    demos : dict, optional
        Primitive id -> Demonstration: the primitives the steps used, drawn thin and grey.
    legend : bool, default=True
        Name the steps and every kind of marker (start, step goals, objects, obstacles, primitives).
    unit : str, optional
        The positions' unit, on the axes (e.g. ``"m"``; not given: "as recorded").
    """
    Y = result.trajectory["position"]
    if Y.shape[1] != 3:
        raise ValueError(f"result: expected a 3-D path, got {Y.shape[1]}-D positions")
    points = [Y]
    shown = [pid for pid in sorted({i for s in result.steps for i in s.used}) if demos and pid in demos]
    for k, pid in enumerate(shown):
        ax.plot(*demos[pid]["position"].T, color="#a8a8a8", linewidth=0.8,
                label="primitives used" if k == 0 else None)
    cmap = colormaps["viridis" if len(result.steps) > 10 else "tab10"]
    colours = []
    for k, step in enumerate(result.steps):
        colour = cmap(k / max(len(result.steps) - 1, 1) if len(result.steps) > 10 else k % 10)
        part = Y[step.start:step.stop]
        name = " ".join([step.action, *step.args])
        ax.plot(*part.T, color=colour, linewidth=2.0, label=f"{k + 1}. ({name})")
        colours.append(colour)
    # the goals after all the steps, so the legend lists the steps together
    for k, (step, colour) in enumerate(zip(result.steps, colours, strict=True)):
        ax.scatter(*step.goal, color=colour, marker="x", s=30, label="step goal" if k == 0 else None)
    placed = [(name, obj) for name, obj in scene.objects.items() if obj.position is not None]
    for k, (name, obj) in enumerate(placed):
        ax.scatter(*obj.position, color="black", marker="o", s=18, label="object" if k == 0 else None)
        ax.text(*obj.position, f" {name}", fontsize=8)
        points.append(obj.position[None])
    for k, ob in enumerate(scene.obstacles.values()):
        _obstacle(ax, ob, True, label="obstacle" if k == 0 else None)
        points.append(np.vstack(ob.bounds()))
    ax.scatter(*Y[0], color="black", marker="^", s=30, label="start")
    _extent(ax, np.vstack(points), True)
    axis_labels(ax, unit)
    if legend:
        legend_beside(ax, fontsize=7)


def plot_plan(result, scene, path, *, demos=None, title=None, unit: str | None = None) -> Path:
    """Write the figure of a planned task (see :func:`draw_plan`; ``unit`` as there); returns the file.

    Examples
    --------
    >>> import os, tempfile
    >>> from skillbank.planning import PlanResult, PlanStep, scene_from_dict
    >>> from skillbank import Demonstration
    >>> t = np.linspace(0.0, 1.0, 20)
    >>> traj = Demonstration(t, {"position": np.c_[t, t, 0 * t]})
    >>> step = PlanStep("press", ("b1",), "press", 0, 20, [1], np.array([1.0, 1, 0]), None, "lte", 0.0, 0.0,
    ...                 False)
    >>> scene = scene_from_dict({"objects": {"b1": {"type": "button", "position": [1, 1, 0]}},
    ...                          "obstacles": ["sphere:0.5,0.2,0,0.1"], "goal": ["(pressed b1)"]})
    >>> res = PlanResult([("press", ("b1",))], [step], traj, False, 0.0, {})
    >>> plot_plan(res, scene, os.path.join(tempfile.mkdtemp(), "plan.png")).suffix
    '.png'
    """
    fig = Figure(figsize=(6.5, 6.0), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    draw_plan(ax, result, scene, demos=demos, unit=unit)
    ax.set_title(title or f"plan of {len(result.steps)} step(s)")
    return _save(fig, path)
