"""Figures of trajectory editing: a demonstration, its reproduction, the constraints and obstacles.

Drawn on a fresh :class:`matplotlib.figure.Figure` (no pyplot state) and
written to a file; :func:`draw_edit` draws the same picture on an existing
axes (2-D, or 3-D with ``projection="3d"``) for galleries.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Polygon

from ..core import Constraints, Demonstration
from ..core._validation import check_array
from ._segmentation import _save, legend_beside

__all__ = ["draw_edit", "plot_edit"]

_DEMO, _OTHER, _REPRO, _OBSTACLE = "#7f7f7f", "#a8a8a8", "#d62728", "#1f77b4"


def _path(Y, name: str) -> np.ndarray:
    if isinstance(Y, Demonstration):
        if "position" not in Y.streams:
            raise ValueError(f"{name}: expected a Demonstration with a 'position' stream, "
                             f"got streams {Y.stream_names}")
        Y = Y["position"]
    return check_array(Y, name=name, ndim=2)


def _is_3d(ax) -> bool:
    return getattr(ax, "name", "") == "3d"


def _line(ax, Y, **kw):
    return ax.plot(*Y.T, **kw)


def _obstacle(ax, ob, three_d: bool, label: str | None = None):
    """Draw any obstacle from its outline: a filled polygon in 2-D, a wireframe in 3-D.

    ``label`` names its first piece, so the legend has one "obstacle" entry however it is drawn.
    """
    lines = ob.outline()
    if not three_d:
        for k, poly in enumerate(lines):
            ax.add_patch(Polygon(poly, closed=True, facecolor=_OBSTACLE, alpha=0.25, edgecolor=_OBSTACLE,
                                 label=label if k == 0 else None))
        return
    for k, line in enumerate(lines):
        ax.plot(*line.T, color=_OBSTACLE, alpha=0.5, linewidth=0.6, label=label if k == 0 else None)


def _markers(ax, c: Constraints, start, points: list) -> None:
    """Start (square; ``start`` when the constraints leave it free), goal (star), via-points (diamonds)."""
    markers = [("start", c.start if c.start is not None else np.asarray(start, dtype=float), "s"),
               ("goal", c.goal, "*")]
    markers += [("via-point" if k == 0 else None, v.position, "D") for k, v in enumerate(c.via)]
    for label, p, marker in markers:
        if p is not None:
            ax.plot(*p[:, None], marker=marker, color="black", markersize=7 if marker != "*" else 11,
                    linestyle="none", label=label, zorder=5)
            points.append(p[None])


def axis_labels(ax, unit: str | None) -> None:
    """Name the axes x, y (and z) with ``unit`` in brackets; "as recorded" when the unit is not known."""
    tail = f" ({unit})" if unit else " (as recorded)"
    ax.set_xlabel("x" + tail)
    ax.set_ylabel("y" + tail)
    if _is_3d(ax):
        ax.set_zlabel("z" + tail)


def _extent(ax, points: np.ndarray, three_d: bool):
    """Equal scale on every axis around ``points`` (obstacles included)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    half = 0.55 * max(float((hi - lo).max()), 1e-12)
    mid = 0.5 * (lo + hi)
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    if three_d:
        ax.set_zlim(mid[2] - half, mid[2] + half)
        ax.set_box_aspect((1, 1, 1))
    else:
        ax.set_aspect("equal", adjustable="box")


def draw_edit(ax, reproduction, *, demo=None, demos=(), constraints=None, legend=True):
    """Draw a reproduction with its demonstration(s), constraints and obstacles on ``ax``.

    Parameters
    ----------
    ax : matplotlib Axes
        2-D axes for 2-D trajectories, 3-D axes (``projection="3d"``) for 3-D ones.
    reproduction : array-like of shape (n_steps, n_dims) or Demonstration
    demo : array-like or Demonstration, optional
        The demonstration the reproduction adapts (drawn dashed grey).
    demos : sequence of array-like or Demonstration, default=()
        Further demonstrations (e.g. all those a ProMP learned from), drawn thin.
    constraints : Constraints, optional
        Start (square), goal (star), via-points (diamonds) and obstacles
        (shaded). Without a start, the square marks where the reproduction begins.
    legend : bool, default=True

    Returns
    -------
    ax

    Examples
    --------
    >>> import numpy as np
    >>> from matplotlib.figure import Figure
    >>> from skillbank.core import Constraints, Sphere
    >>> s = np.linspace(0.0, 1.0, 50)
    >>> ax = Figure().add_subplot()
    >>> _ = draw_edit(ax, np.c_[s, s], demo=np.c_[s, 0 * s],
    ...               constraints=Constraints(goal=[1, 1], obstacles=[Sphere([0.5, 0.0], 0.1)]))
    """
    R = _path(reproduction, "reproduction")
    n_dims = R.shape[1]
    if n_dims not in (2, 3):
        raise ValueError(f"reproduction: expected a 2-D or 3-D trajectory to draw, got {n_dims} dimensions")
    three_d = _is_3d(ax)
    if three_d != (n_dims == 3):
        raise ValueError(f"ax: expected {'3-D' if n_dims == 3 else '2-D'} axes for {n_dims}-D trajectories, "
                         f"got {'3-D' if three_d else '2-D'} axes")
    others = [_path(d, f"demos[{k}]") for k, d in enumerate(demos)]
    D = None if demo is None else _path(demo, "demo")
    for name, Y in [(f"demos[{k}]", Y) for k, Y in enumerate(others)] + [("demo", D)]:
        if Y is not None and Y.shape[1] != n_dims:
            raise ValueError(f"{name}: expected {n_dims} dimensions like the reproduction, got {Y.shape[1]}")
    c = Constraints() if constraints is None else constraints
    if not isinstance(c, Constraints):
        raise ValueError(f"constraints: expected a skillbank Constraints, got {type(c).__name__}")
    c.check_dims(n_dims)
    points = [R] + others + ([D] if D is not None else [])
    for k, Y in enumerate(others):
        _line(ax, Y, color=_OTHER, linewidth=0.8, label="demonstrations" if k == 0 else None)
    if D is not None:
        _line(ax, D, color=_DEMO, linestyle="--", linewidth=1.2, label="demonstration")
    _line(ax, R, color=_REPRO, linewidth=1.8, label="reproduction")
    for k, ob in enumerate(c.obstacles):
        _obstacle(ax, ob, three_d, label="obstacle" if k == 0 else None)
        points.append(np.stack(ob.bounds()))
    # the start is marked even when the constraints leave it free: where the reproduction begins
    _markers(ax, c, R[0], points)
    _extent(ax, np.concatenate(points), three_d)
    if legend:
        legend_beside(ax, fontsize="small")
    return ax


def plot_edit(reproduction, path, *, demo=None, demos=(), constraints=None, title=None,
              unit: str | None = None) -> Path:
    """Write a figure of a reproduction, its demonstration(s), constraints and obstacles.

    Parameters
    ----------
    reproduction : array-like of shape (n_steps, 2 or 3) or Demonstration
    path : str or path-like
        Output image; the format follows the extension (``.png``, ``.pdf``, ``.svg``; none
        adds ``.png``). Parent folders are created.
    demo, demos, constraints
        As in :func:`draw_edit`.
    title : str, optional
    unit : str, optional
        The positions' unit, written on the axes (e.g. ``"m"``); when not given
        the axes say "as recorded".

    Returns
    -------
    pathlib.Path
        The file written (see :func:`figure_path`).

    Examples
    --------
    >>> import numpy as np, os, tempfile
    >>> s = np.linspace(0.0, 1.0, 50)
    >>> out = plot_edit(np.c_[s, s, s], os.path.join(tempfile.mkdtemp(), "edit.png"), demo=np.c_[s, s, 0 * s])
    >>> out.suffix
    '.png'
    """
    n_dims = _path(reproduction, "reproduction").shape[1]
    fig = Figure(figsize=(6.0, 5.5), layout="constrained")
    ax = fig.add_subplot(projection="3d" if n_dims == 3 else None)
    draw_edit(ax, reproduction, demo=demo, demos=demos, constraints=constraints)
    if title:
        ax.set_title(title)
    axis_labels(ax, unit)
    return _save(fig, path)
