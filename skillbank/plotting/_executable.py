"""Figure of an executable reproduction: the pose path with orientation triads, and the joint curves."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from ..core import Demonstration, quaternion_to_matrix
from ._editing import _OBSTACLE, _extent, _obstacle
from ._segmentation import _save, legend_beside

__all__ = ["plot_executable"]

#: Colours of the tool frame's x, y and z axes (the usual red, green, blue).
_AXES = ("tab:red", "tab:green", "tab:blue")


def plot_executable(trajectory, path, *, demos=(), constraints=None, n_frames: int = 12,
                    title: str | None = None) -> Path:
    """Draw a reproduction a robot executes: its pose path and, beside it, its joints over time.

    Left, in 3-D: the position path, the tool frame's axes (x red, y green,
    z blue) at ``n_frames`` samples evenly spaced in time, the demonstrations
    it was adapted from in grey, and the constraints' start, goal and
    obstacles, each named in the legend. Right: each joint angle against time
    (when the trajectory has a ``joints`` stream) and the gripper on a second
    axis when it moves (a constant gripper is named in the legend instead).

    Parameters
    ----------
    trajectory : Demonstration
        With ``position``; ``orientation``, ``joints`` and ``gripper`` are drawn
        where present (``ReuseResult.trajectory``).
    path : str or path-like
        Output image file; parent directories are created.
    demos : sequence of array-like, optional
        Position paths drawn in grey for comparison.
    constraints : Constraints, optional
    n_frames : int, default=12
    title : str, optional

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        If ``trajectory`` is not a Demonstration with a 3-D ``position`` stream.

    Examples
    --------
    >>> plot_executable(result.trajectory, "reach.png")  # doctest: +SKIP
    PosixPath('reach.png')
    """
    if not isinstance(trajectory, Demonstration) or "position" not in trajectory.streams:
        raise ValueError(f"trajectory: expected a Demonstration with a 'position' stream, got "
                         f"{type(trajectory).__name__}")
    P = np.asarray(trajectory["position"], dtype=float)
    if P.shape[1] != 3:
        raise ValueError(f"trajectory: expected a 3-D position stream, got {P.shape[1]} dimensions")
    joints = "joints" in trajectory.streams
    fig = Figure(figsize=(12.0 if joints else 6.5, 5.5), layout="constrained")
    ax = fig.add_subplot(1, 2 if joints else 1, 1, projection="3d")
    ax.plot(*P.T, color="k", lw=2.0)
    points = [P]
    if "orientation" in trajectory.streams:
        at = np.unique(np.linspace(0, P.shape[0] - 1, max(2, int(n_frames))).round().astype(int))
        R = quaternion_to_matrix(trajectory["orientation"][at])
        # triads a tenth of the path's extent long: visible, and short enough not to hide the path
        length = 0.1 * max(float(np.ptp(P, axis=0).max()), 1e-9)
        for k, colour in enumerate(_AXES):
            ends = P[at] + length * R[:, :, k]
            for a, b in zip(P[at], ends, strict=True):
                ax.plot(*np.stack([a, b]).T, color=colour, lw=1.2)
            points.append(ends)
    markers = []
    if constraints is not None:
        for name, marker in (("start", "^"), ("goal", "*")):
            value = getattr(constraints, name, None)
            if value is not None:
                ax.scatter(*np.asarray(value, dtype=float)[:3], marker=marker, s=80, color="tab:purple",
                           depthshade=False)
                markers.append(Line2D([], [], ls="none", marker=marker, ms=8, color="tab:purple", label=name))
        for ob in constraints.obstacles:
            _obstacle(ax, ob, True)
            points.append(np.concatenate(ob.outline()))
        if constraints.obstacles:
            markers.append(Patch(facecolor="none", edgecolor=_OBSTACLE, label="obstacle"))
    _extent(ax, np.concatenate(points), True)
    box = np.array([ax.get_xlim3d(), ax.get_ylim3d(), ax.get_zlim3d()])
    for d in demos:
        # the box is the reproduction's; a 3-D axes does not clip, so the demonstrations' samples outside
        # it (a press at another button) are left out rather than drawn past the panes
        D = np.array(d["position"] if isinstance(d, Demonstration) else d, dtype=float)[:, :3]
        D[~np.all((D >= box[:, 0]) & (D <= box[:, 1]), axis=1)] = np.nan
        ax.plot(*D.T, color="0.7", lw=0.8)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    handles = [Line2D([], [], color="k", lw=2, label="reproduction")]
    if demos:
        handles.append(Line2D([], [], color="0.7", label="demonstrations"))
    handles += [Line2D([], [], color=c, label=f"tool {a}") for c, a in zip(_AXES, "xyz", strict=True)
                if "orientation" in trajectory.streams]
    legend_beside(ax, handles=handles + markers, fontsize="small")
    ax.set_title("pose path and tool frames")
    if joints:
        jx = fig.add_subplot(1, 2, 2)
        names = trajectory.metadata.get("joint_names") or [f"joint {k}" for k in range(6)]
        Q = trajectory["joints"]
        for k in range(Q.shape[1]):
            jx.plot(trajectory.t, Q[:, k], label=str(names[k]) if k < len(names) else f"joint {k}")
        jx.set_xlabel("time (s)")
        jx.set_ylabel("joint angle (rad)")
        jx.set_title("joint trajectory")
        if "gripper" in trajectory.streams:
            G = np.asarray(trajectory["gripper"], dtype=float)[:, 0]
            if np.ptp(G) > 0:
                gx = jx.twinx()
                gx.plot(trajectory.t, G, color="k", ls="--", lw=1.0)
                gx.set_ylabel("gripper (as recorded)")
                jx.plot([], [], color="k", ls="--", lw=1.0, label="gripper (right axis)")
            else:  # a constant gripper gets a line of the legend, not an axis of its own
                jx.plot([], [], ls="none", label=f"gripper held at {G[0]:.3g}")
        # under the axes: six joint curves (and a gripper on the twin axis, which loc="best" does not
        # see) leave no corner free
        jx.legend(fontsize="small", loc="upper center", bbox_to_anchor=(0.5, -0.12), borderaxespad=0.0,
                  ncol=3)
    if title:
        fig.suptitle(title, fontsize="medium")
    return _save(fig, path)
