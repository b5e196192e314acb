"""The figure of a simulation: the tool path with contacts marked, and the force on each button over time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..simulation import PRESS_FORCE
from ._editing import _extent, _obstacle, axis_labels
from ._segmentation import _save, legend_beside

__all__ = ["plot_simulation"]

#: A button's spring pushes back 1.5 x its press force at full travel (skillbank.simulation's buttons);
#: more than that is the tool pushing the button against its end stop.
END_STOP = 1.5
#: The colour of an object's marker and what it says; one legend entry per kind drawn.
_KINDS = {True: ("tab:green", "button, pressed"), False: ("tab:red", "button, not pressed"),
          None: ("black", "object")}


def peak_label(name: str, peak: float, press_force: float = PRESS_FORCE) -> str:
    """A button's legend entry: its name and peak force, and why a peak far above the press force can be.

    Examples
    --------
    >>> peak_label("b1", 7.93, 7.0)
    'b1 (peak 7.93 N)'
    >>> peak_label("b2", 71.7, 7.0)
    'b2 (peak 71.7 N: against its end stop, past 10.5 N)'
    """
    said = f"{name} (peak {peak:.3g} N"
    if peak > END_STOP * press_force:
        said += f": against its end stop, past {END_STOP * press_force:.3g} N"
    return said + ")"


def plot_simulation(result, scene, path, *, title=None, press_force: float = PRESS_FORCE) -> Path:
    """Write the figure of a :class:`~skillbank.simulation.SimulationResult`; returns the file.

    Left: the simulated tool path in 3-D (metres) with the commanded one, the scene's obstacles and
    objects (a button green when pressed, red when not; other objects black), and a cross where each
    unintended contact started. Right: the robot's force on each button (N) against time (s), with the
    time it first counted as pressed, the force that presses it (``press_force``, dashed), each
    button's peak in the legend (noting a peak past the spring's force at full travel, 1.5 x
    ``press_force``: the tool pushed the button against its end stop) and the end of the simulation
    (dotted, with a margin after it, so a force still rising at the end is seen to be cut there).

    Parameters
    ----------
    press_force : float, default=skillbank.simulation.PRESS_FORCE
        The force (N) the simulation's buttons needed (``simulate(..., press_force=)``).

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
    said = set()
    for name, obj in placed:
        pressed = result.buttons.get(name, {}).get("pressed")
        colour, kind = _KINDS[None if pressed is None else bool(pressed)]
        ax.scatter(*obj.position, color=colour, marker="o", s=22, label=None if kind in said else kind)
        said.add(kind)
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
        force = np.asarray(force, float)
        line, = ax2.plot(t, force, linewidth=1.2, label=peak_label(name, float(force.max(initial=0.0)),
                                                                   press_force))
        pressed_at = result.buttons[name]["t"]
        if pressed_at is not None:
            ax2.axvline(pressed_at, color=line.get_color(), linestyle=":", linewidth=1.0)
    end = max(float(t[-1]) if t.size else 1.0, 1e-9)
    if not result.button_force_:
        ax2.text(0.5, 0.5, "no buttons in the scene", ha="center", va="center", transform=ax2.transAxes)
    else:
        ax2.axhline(press_force, color="0.4", linestyle="--", linewidth=0.8,
                    label=f"press force {press_force:.3g} N")
        ax2.plot([], [], color="black", linestyle=":", label="first pressed")
        ax2.axvline(end, color="black", linestyle=(0, (1, 3)), linewidth=0.8, label="end of the simulation")
        # under the axes: the forces span the whole time axis, from 0 N to their peaks, so no corner is free
        ax2.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), borderaxespad=0.0, fontsize=8, ncol=2)
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("robot force on the button (N)")
    ax2.set_title("button forces")
    ax2.set_xlim(0.0, 1.04 * end)  # a margin: a force still high at the end is seen to stop with the run
    if title:
        fig.suptitle(title)
    return _save(fig, path)
