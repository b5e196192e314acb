"""Figures of a primitive library: its skills one panel each, and a skill reused under new constraints.

Drawn on a fresh :class:`matplotlib.figure.Figure` with constrained layout
(no pyplot state), written to a file.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..core import Constraints, Sphere, ViaPoint
from ..core._validation import check_array
from ._editing import _REPRO, _extent, _markers, _obstacle, axis_labels
from ._segmentation import _colour, _save, legend_beside, plural

__all__ = ["plot_skills", "plot_reuse"]

_STORED = "#1f77b4"  # the stored primitives: a colour of their own, never the reproduction's red
_ADAPTED = "#404040"
_FLAT = 1e-9  # a path whose z varies less than this (in its unit) is drawn on its plane
# Two paths closer than this fraction of their panel's extent are drawn as one line (a panel is a few
# hundred pixels wide: 0.2 % is under a pixel).
_SAME_LINE = 2e-3


def n_distinct(paths: list[np.ndarray], extent: float) -> int:
    """How many different lines ``paths`` make on a panel ``extent`` wide: paths of one length whose
    samples are all within ``_SAME_LINE * extent`` of each other are drawn as one.

    Examples
    --------
    >>> s = np.linspace(0.0, 1.0, 5)[:, None]
    >>> n_distinct([s, s + 1e-9, 2 * s], 2.0)
    2
    """
    tol = _SAME_LINE * max(float(extent), 1e-300)
    seen: list[np.ndarray] = []
    for Y in paths:
        if not any(Y.shape == Z.shape and float(np.max(np.abs(Y - Z))) <= tol for Z in seen):
            seen.append(Y)
    return len(seen)


def count_text(paths: list[np.ndarray], extent: float, word: str | None = "primitive") -> str:
    """``"3 primitives"``, and what the eye cannot count: ``"3 primitives (identical)"``,
    ``"5 primitives (2 distinct)"`` when some are drawn over each other (``word=None``: the number
    alone, ``"3, identical"``).

    Examples
    --------
    >>> s = np.linspace(0.0, 1.0, 5)[:, None]
    >>> count_text([s, s, s], 1.0), count_text([s, s, 2 * s], 2.0), count_text([s], 1.0)
    ('3 primitives (identical)', '3 primitives (2 distinct)', '1 primitive')
    >>> count_text([s, s], 1.0, None), count_text([s, 2 * s], 2.0, None)
    ('2, identical', '2')
    """
    distinct = n_distinct(paths, extent)
    note = "" if distinct == len(paths) else "identical" if distinct == 1 else f"{distinct} distinct"
    if word is None:
        return f"{len(paths)}, {note}" if note else f"{len(paths)}"
    return plural(len(paths), word) + (f" ({note})" if note else "")


def _paths(paths, name: str) -> list[np.ndarray]:
    out = [check_array(Y, name=f"{name}[{k}]", ndim=2) for k, Y in enumerate(paths)]
    for k, Y in enumerate(out):
        if Y.shape[1] not in (2, 3):
            raise ValueError(f"{name}[{k}]: expected 2-D or 3-D positions, got {Y.shape[1]} columns")
    return out


def _planar(paths: list[np.ndarray]) -> bool:
    """Whether every path lies in one plane z = constant (or is 2-D already)."""
    if all(Y.shape[1] == 2 for Y in paths):
        return True
    stacked = np.concatenate([Y[:, 2] for Y in paths if Y.shape[1] == 3])
    return bool(np.ptp(stacked) < _FLAT)


def _flat_constraints(c: Constraints) -> Constraints:
    """The x-y part of constraints on a plane z = constant."""
    ends = {k: None if getattr(c, k) is None else getattr(c, k)[:2] for k in ("start", "goal")}
    via = [ViaPoint(v.position[:2], index=v.index, phase=v.phase) for v in c.via]
    # a sphere's section by the plane is a circle; other shapes are not drawn on a flat panel
    return Constraints(**ends, via=via, obstacles=[Sphere(ob.center[:2], ob.radius) for ob in c.obstacles
                                                   if isinstance(ob, Sphere)])


def plot_skills(skills, path, *, unit: str | None = "m", columns: int = 4, title: str | None = None) -> Path:
    """Draw each skill's primitives in a panel of its own, each at its own scale.

    A skill whose primitives lie in one plane z = constant (a letter drawn on
    a table) is drawn flat in x-y; the others in 3-D. Each panel has equal
    scales on its axes, ticks and units, so a 4 cm letter and a 40 cm reach
    are both legible, and says how large the skill is.

    Parameters
    ----------
    skills : dict of str to sequence of array-like (n_steps, 2 or 3)
        Each skill's name (the panel title) and its primitives' positions.
    path : str or path-like
        Output image file; parent directories are created.
    unit : str or None, default="m"
        The positions' unit, written on the axes (None: "as recorded").
    columns : int, default=4
        Panels per row.
    title : str, optional

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    ValueError
        If there is no skill, a skill has no primitive, or a primitive is not 2-D or 3-D.

    Examples
    --------
    >>> import numpy as np, os, tempfile
    >>> s = np.linspace(0.0, 1.0, 20)
    >>> skills = {"line": [np.c_[s, s, 0 * s]], "lift": [np.c_[s, 0 * s, s]]}
    >>> plot_skills(skills, os.path.join(tempfile.mkdtemp(), "skills.png")).suffix
    '.png'
    """
    if not isinstance(skills, dict) or not skills:
        raise ValueError(f"skills: expected a dict of skill name to primitives, got {skills!r:.60}")
    groups = {str(k): _paths(v, f"skills[{k!r}]") for k, v in skills.items()}
    for name, paths in groups.items():
        if not paths:
            raise ValueError(f"skills[{name!r}]: expected at least one primitive, got none")
    n_cols = max(1, min(int(columns), len(groups)))
    n_rows = -(-len(groups) // n_cols)
    fig = Figure(figsize=(3.6 * n_cols, 3.5 * n_rows + 0.4), layout="constrained")
    for k, (name, paths) in enumerate(groups.items()):
        flat = _planar(paths)
        ax = fig.add_subplot(n_rows, n_cols, k + 1, projection=None if flat else "3d")
        drawn = [Y[:, :2] if flat else (Y if Y.shape[1] == 3 else np.c_[Y, np.zeros(len(Y))]) for Y in paths]
        for Y in drawn:
            ax.plot(*Y.T, color=_colour(k), lw=0.9)
        stacked = np.concatenate(drawn)
        _extent(ax, stacked, not flat)
        if not flat:  # constrained layout does not see a 3-D axis' labels: a smaller box keeps them in
            ax.set_box_aspect((1, 1, 1), zoom=0.85)
        axis_labels(ax, unit)
        ax.tick_params(labelsize="x-small")
        size = float(np.ptp(stacked, axis=0).max())
        across = f"{size:.2g} {unit} across" if unit else f"{size:.2g} across"
        where = f", z = {paths[0][0, 2]:.3g}" if flat and paths[0].shape[1] == 3 else ""
        ax.set_title(f"{name}\n{count_text(drawn, size)}, {across}{where}", fontsize="small")
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def plot_reuse(reproduction, path, *, stored, candidates=(), constraints=None, skill: str = "skill",
               method: str = "", unit: str | None = "m", title: str | None = None) -> Path:
    """Draw a skill's stored primitives beside the reproduction made from the best of them.

    Left: the stored primitives with the new task (start, goal, obstacles),
    nothing drawn over them. Right: the candidates adapted by LTE (grey) and
    the reproduction (red) with the same task. A skill on a plane
    z = constant is drawn flat in x-y.

    Parameters
    ----------
    reproduction : array-like of shape (n_steps, 2 or 3)
    path : str or path-like
    stored : sequence of array-like
        The skill's stored primitives' positions.
    candidates : sequence of array-like, default=()
        The adapted primitives the representation was fitted on.
    constraints : Constraints, optional
    skill, method : str
        Named in the panel titles.
    unit : str or None, default="m"
    title : str, optional
        Wrapped over the panels.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> import numpy as np, os, tempfile
    >>> s = np.linspace(0.0, 1.0, 20)
    >>> out = plot_reuse(np.c_[s, s, s], os.path.join(tempfile.mkdtemp(), "reuse.png"),
    ...                  stored=[np.c_[s, s, 0.5 * s]], constraints=Constraints(goal=[1.0, 1.0, 1.0]))
    >>> out.suffix
    '.png'
    """
    R = _paths([reproduction], "reproduction")[0]
    stored, candidates = _paths(stored, "stored"), _paths(candidates, "candidates")
    c = Constraints() if constraints is None else constraints
    flat = _planar([R, *stored, *candidates])
    if flat:
        R, stored, candidates = R[:, :2], [Y[:, :2] for Y in stored], [Y[:, :2] for Y in candidates]
        dims = {p.shape[0] for p in (c.start, c.goal) if p is not None} | {v.n_dims for v in c.via}
        c = _flat_constraints(c) if 3 in dims or c.obstacles else c
    fig = Figure(figsize=(11.0, 5.2), layout="constrained")
    # the count of each kind says when some are drawn over each other (identical members look like one)
    extent = float(np.ptp(np.concatenate([R, *stored, *candidates]), axis=0).max())
    panels = [(stored, _STORED, f"stored primitives ({count_text(stored, extent, None)})",
               f"the {len(stored)} stored primitives of '{skill}' and the new task", False),
              (candidates, _ADAPTED, f"adapted by LTE ({count_text(candidates, extent, None)})",
               f"{len(candidates)} best adapted by LTE, then {method or 'reproduced'}", True)]
    for k, (paths, colour, label, heading, show_reproduction) in enumerate(panels):
        ax = fig.add_subplot(1, 2, k + 1, projection=None if flat else "3d")
        points = [R, *paths]
        if show_reproduction:
            ax.plot(*R.T, color=_REPRO, lw=2.2, label="reproduction")
        # the primitives over the reproduction, thin and dashed on the right, so neither hides the other
        for j, Y in enumerate(paths):
            ax.plot(*Y.T, color=colour, lw=1.0, ls="--" if show_reproduction else "-", alpha=0.9,
                    label=label if j == 0 else None, zorder=3)
        for j, ob in enumerate(c.obstacles):
            _obstacle(ax, ob, not flat, label="obstacle" if j == 0 else None)
            points.append(np.stack(ob.bounds()))
        _markers(ax, c, R[0], points)
        _extent(ax, np.concatenate(points), not flat)
        axis_labels(ax, unit)
        legend_beside(ax, fontsize="small")
        ax.set_title(heading, fontsize="medium")
    if title:
        fig.suptitle("\n".join(textwrap.wrap(title, 100)), fontsize="medium")
    return _save(fig, path)
