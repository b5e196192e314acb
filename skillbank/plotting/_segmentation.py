"""Figures of segmentation results (the paper's Fig. 3 panels).

All functions draw on a fresh :class:`matplotlib.figure.Figure` (no pyplot
global state), write it to ``path`` and return that path.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
from matplotlib.backend_bases import FigureCanvasBase
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from ..io import atomic_output
from ..segmentation import SegmentationResult

__all__ = ["figure_path", "plot_jerk_profile", "plot_segments"]

_PALETTE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
    "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
)  # matplotlib's tab10
_DPI = 150
#: Units of the streams the readers name, by ROS's convention (REP 103: SI units), which every reader of
#: robot data follows; other streams (a gripper, a position of unknown scale) are "as recorded".
STREAM_UNITS = {"joints": "rad", "force": "N", "torque": "N m"}


def _colour(i: int) -> str:
    return _PALETTE[i % len(_PALETTE)]


def plural(n: int, word: str) -> str:
    """``"1 segment"``, ``"3 segments"``.

    Examples
    --------
    >>> plural(1, "segment"), plural(0, "keypoint"), plural(3, "primitive")
    ('1 segment', '0 keypoints', '3 primitives')
    """
    return f"{n} {word}{'' if n == 1 else 's'}"


def unit_text(name: str, unit: str | None = None) -> str:
    """``"(unit)"`` of stream ``name``: ``unit`` when given, else its known unit, else "(as recorded)".

    Examples
    --------
    >>> unit_text("force"), unit_text("position", "m"), unit_text("gripper")
    ('(N)', '(m)', '(as recorded)')
    """
    unit = unit or STREAM_UNITS.get(name)
    return f"({unit})" if unit else "(as recorded)"


def _check_result(result) -> SegmentationResult:
    if not isinstance(result, SegmentationResult):
        raise ValueError(f"result: expected a SegmentationResult, got {type(result).__name__}")
    return result


def _check_segmented_stream(result: SegmentationResult, stream):
    names = list(result.streams)
    if not names:
        raise ValueError("result: expected at least one segmented stream, got none")
    if stream is None:
        return result.streams[names[0]]
    if stream not in result.streams:
        raise ValueError(f"stream: expected one of the segmented streams {names}, got {stream!r}")
    return result.streams[stream]


def figure_path(path, *, name: str = "path") -> Path:
    """The file a figure written to ``path`` really goes to.

    The extension names the format (``.png``, ``.pdf``, ``.svg``, ...); a name
    without one gets ``.png``, as matplotlib would add, so ``"out/fig"`` and
    a folder ``"out"`` are written to ``out/fig.png`` and ``out.png``.

    Raises
    ------
    ValueError
        If the extension is not a format matplotlib writes (``name`` names the argument).

    Examples
    --------
    >>> figure_path("fig").name, figure_path("fig.PDF").name
    ('fig.png', 'fig.PDF')
    >>> figure_path("fig.txt", name="plot")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: plot: expected a figure file name ending in one of .avif, ..., got 'fig.txt'
    """
    path = Path(path)
    suffix = path.suffix.lower()[1:]
    if not suffix:
        return path.with_name(path.name.rstrip(".") + ".png")
    formats = sorted(FigureCanvasBase.get_supported_filetypes())
    if suffix not in formats:
        raise ValueError(f"{name}: expected a figure file name ending in one of "
                         f"{', '.join('.' + f for f in formats)} (or no extension for .png), "
                         f"got {str(path)!r}")
    return path


def _titles(fig: Figure) -> list:
    """The figure's title and every axes' titles, with the width each may take (in pixels)."""
    out = [(fig._suptitle, fig.bbox.width)] if fig._suptitle is not None else []
    for ax in fig.axes:
        # an axes' title may span its own axes (and no more: beyond, it runs over its neighbours')
        width = max(ax.get_position().width * fig.bbox.width, 0.25 * fig.bbox.width)
        out += [(t, width) for t in (ax.title, ax._left_title, ax._right_title)]
    return [(t, w) for t, w in out if t.get_visible() and t.get_text()]


def wrap_titles(fig: Figure) -> None:
    """Wrap every title wider than the room it has, so that no title widens the saved figure.

    Saved with ``bbox_inches="tight"``, a figure grows to hold its widest
    text: one long title made a 12-inch figure 2,516 px wide. Each line of a
    title too wide is refilled at the number of characters that fits, measured
    with the figure's own renderer, until it fits.
    """
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    renderer = canvas.get_renderer()
    for text, room in _titles(fig):
        for _ in range(4):  # refilling shortens lines; a few rounds settle any font's widths
            width = text.get_window_extent(renderer).width
            if width <= room:
                break
            lines = text.get_text().split("\n")
            chars = max(12, int(max(len(line) for line in lines) * room / width) - 1)
            text.set_text("\n".join(textwrap.fill(line, chars) or line for line in lines))


def legend_beside(ax, **kwargs):
    """The legend of ``ax`` where it hides no data: beside a 3-D axes, at the emptiest corner of a 2-D one.

    A 3-D axes has no free corner (its panes fill the box and ``loc="best"``
    does not apply to it), so its legend goes to the right of the axes; the
    figure's constrained layout makes room for it.
    """
    if getattr(ax, "name", "") == "3d":
        return ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, **kwargs)
    return ax.legend(loc="best", **kwargs)


def _save(fig: Figure, path) -> Path:
    """Write ``fig`` (parents created) and return the file written; every plotting module saves here.

    Titles are wrapped first (:func:`wrap_titles`).
    """
    path = figure_path(path)
    wrap_titles(fig)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path, name="plot") as tmp:  # whole or not at all; never onto a FIFO or a device
        fig.savefig(tmp, dpi=_DPI, bbox_inches="tight")
    return path


def _scaled(curve: np.ndarray) -> np.ndarray:
    curve = np.asarray(curve, dtype=float)
    top = float(np.max(curve)) if curve.size else 0.0
    return curve / top if top > 0 else curve


def _labels_from_cuts(n: int, cuts) -> np.ndarray:
    marks = np.zeros(n, dtype=int)
    cuts = np.asarray(cuts, dtype=int)
    cuts = cuts[(cuts > 0) & (cuts < n)]
    np.add.at(marks, cuts, 1)
    return np.cumsum(marks)


def _runs(labels: np.ndarray) -> list[tuple[int, int, int]]:
    """``(label, start, stop)`` of each run of equal labels (stop exclusive)."""
    edges = np.flatnonzero(np.diff(labels)) + 1
    starts = np.concatenate(([0], edges))
    stops = np.concatenate((edges, [labels.size]))
    return [(int(labels[a]), int(a), int(b)) for a, b in zip(starts, stops, strict=True)]


def _draw_profile(ax, t, profile, cuts, *, markersize: float = 3.0) -> None:
    """Profile line + points coloured by the segments between ``cuts``."""
    labels = _labels_from_cuts(t.size, cuts)
    for label, a, b in _runs(labels):
        stop = min(b + 1, t.size)  # join to the next segment's first sample
        ax.plot(t[a:stop], profile[a:stop], color=_colour(label), lw=1.2)
        ax.plot(t[a:b], profile[a:b], ls="none", marker="o", ms=markersize, color=_colour(label))
    for c in cuts:
        ax.axvline(t[int(c)], color="0.3", ls="--", lw=1.0)
    ax.set_xlim(t[0], t[-1])
    if profile.size and np.all(np.isfinite(profile)):
        lo, hi = min(0.0, float(profile.min())), max(1.0, float(profile.max()))
        pad = 0.04 * (hi - lo)
        ax.set_ylim(lo - pad, hi + pad)


def _draw_segmented_path(ax, P, result: SegmentationResult, *, lw: float, point_size: float,
                         start_size: float) -> list[int]:
    """Draw the path ``P`` (2 or 3 columns) coloured by segment, its keypoints and its start.

    Returns the segment labels drawn, in order.
    """
    labels = []
    for label, a, b in _runs(result.labels):
        stop = min(b + 1, P.shape[0])  # join to the next segment's first sample
        ax.plot(*P[a:stop].T, color=_colour(label), lw=lw, solid_capstyle="round")
        labels.append(label)
    kp = np.asarray(result.keypoints, dtype=int)
    if kp.size:
        extra = {"depthshade": False} if P.shape[1] == 3 else {}
        ax.scatter(*P[kp].T, color="k", s=point_size, zorder=5, **extra)
    ax.plot(*P[:1].T, ls="none", marker="^", color="0.2", ms=start_size)
    return labels


def plot_jerk_profile(result, path, *, stream=None) -> Path:
    """Plot one stream's normalised windowed jerk profile, coloured by its segments.

    Parameters
    ----------
    result : SegmentationResult
    path : str or path-like
        Output image file; parent directories are created.
    stream : str, optional
        A segmented stream (default: the first one).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        If ``result`` is not a SegmentationResult or ``stream`` was not segmented.

    Examples
    --------
    >>> plot_jerk_profile(result, "figs/jerk.png", stream="position")  # doctest: +SKIP
    PosixPath('figs/jerk.png')
    """
    result = _check_result(result)
    seg = _check_segmented_stream(result, stream)
    t = result.demonstration.t
    fig = Figure(figsize=(7.0, 4.0))
    ax = fig.add_subplot()
    _draw_profile(ax, t, np.asarray(seg.profile, dtype=float), seg.changepoints)
    ax.set_xlabel("Time [s]")
    ax.set_ylabel("Normalised windowed jerk")
    ax.set_title(f"Jerk profile: {seg.name}")
    return _save(fig, path)


def _draw_stream_below(ax, t, Y, result: SegmentationResult, name: str) -> None:
    """One stream against time, each column coloured by segment, with the keypoints as lines.

    A contact stream is shown as its magnitude (the norm over its columns):
    a contact's onset is where the magnitude rises, whatever the direction.
    """
    Y = np.asarray(Y, dtype=float).reshape(t.size, -1)
    if Y.shape[1] > 1:
        Y = np.linalg.norm(Y, axis=1)[:, None]
        ax.set_ylabel(f"|{name}|\n{unit_text(name)}", fontsize="small")
    else:
        ax.set_ylabel(f"{name}\n{unit_text(name)}", fontsize="small")
    for label, a, b in _runs(result.labels):
        stop = min(b + 1, t.size)
        ax.plot(t[a:stop], Y[a:stop, 0], color=_colour(label), lw=1.3)
    support = result.keypoint_support
    for i, k in enumerate(np.asarray(result.keypoints, dtype=int)):
        # solid where this stream is among the keypoint's main witnesses (at least half the
        # strongest stream's evidence there), dotted where others carried it
        here = support[i] if i < len(support) else {}
        backed = bool(here) and here.get(name, 0.0) >= 0.5 * max(here.values())
        ax.axvline(t[k], color="k", ls="-" if backed else ":", lw=1.0 if backed else 0.8, alpha=0.7)
    ax.set_xlim(t[0], t[-1])


def plot_segments(result, path, *, stream: str = "position", dims=None, invert_y: bool = False,
                  below=(), unit: str | None = None) -> Path:
    """Plot a stream's trajectory coloured by segment, in 2-D or 3-D.

    Parameters
    ----------
    result : SegmentationResult
    path : str or path-like
        Output image file; parent directories are created.
    stream : str, default="position"
        Any stream of the demonstration (it need not have been segmented).
    dims : {2, 3}, optional
        Plot the first two or three columns. Default: 3 when the stream has at
        least three columns, else 2.
    invert_y : bool, default=False
        Negate the second column, for data in screen coordinates (y down).
    below : sequence of str, default=()
        Streams drawn under the path against time (e.g. ``("force",
        "gripper")``), coloured by segment; a multi-column stream as its
        magnitude. Keypoints are solid lines where that stream is among their
        main witnesses (at least half the strongest stream's evidence),
        dotted where others carried them.

    unit : str, optional
        The stream's unit, written on the path's axes (e.g. ``"m"``); not
        given: the stream's known unit (``STREAM_UNITS``), else "as recorded".
        The streams below are labelled with their known units the same way.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        If ``result`` is not a SegmentationResult, ``stream`` or a stream in
        ``below`` is unknown, or ``dims`` is not 2 or 3 or exceeds the
        stream's columns.

    Examples
    --------
    >>> plot_segments(result, "figs/r.png", invert_y=True)  # doctest: +SKIP
    PosixPath('figs/r.png')
    """
    result = _check_result(result)
    demo = result.demonstration
    if stream not in demo.streams:
        raise ValueError(f"stream: expected one of the demonstration's streams {demo.stream_names}, "
                         f"got {stream!r}")
    Y = np.asarray(demo[stream], dtype=float)
    n_cols = Y.shape[1]
    if dims is None:
        dims = 3 if n_cols >= 3 else 2
    if isinstance(dims, bool) or dims not in (2, 3):
        raise ValueError(f"dims: expected 2 or 3, got {dims!r}")
    if dims > n_cols:
        raise ValueError(f"dims: expected at most the {n_cols} columns of stream {stream!r}, got {dims}")
    below = [below] if isinstance(below, str) else list(below)
    for name in below:
        if name not in demo.streams:
            raise ValueError(f"below: expected streams of the demonstration {demo.stream_names}, "
                             f"got {name!r}")
    P = Y[:, :dims].copy()
    if invert_y:
        P[:, 1] = -P[:, 1]

    size = (6.0, 6.0) if dims == 2 else (7.0, 6.5)
    # constrained layout: each panel's axis labels get their room, none is clipped by the panel below
    fig = Figure(figsize=(size[0] + 1.6, size[1] + 1.2 * len(below)), layout="constrained")
    grid = fig.add_gridspec(1 + len(below), 1, height_ratios=[size[1] / 1.6] + [1.0] * len(below))
    ax = fig.add_subplot(grid[0], projection="3d" if dims == 3 else None)
    shared = None
    for i, name in enumerate(below):
        sub = fig.add_subplot(grid[1 + i], sharex=shared)
        shared = shared or sub
        _draw_stream_below(sub, demo.t, demo[name], result, name)
        if i < len(below) - 1:
            sub.tick_params(labelbottom=False)
        else:
            sub.set_xlabel("Time [s]")
    labels = _draw_segmented_path(ax, P, result, lw=2.5, point_size=30, start_size=7)
    handles = [Line2D([], [], color=_colour(label), lw=3, label=f"Segment {label + 1}") for label in labels]
    if result.keypoints.size:
        handles.append(Line2D([], [], ls="none", marker="o", color="k", label="Keypoints"))
    handles.append(Line2D([], [], ls="none", marker="^", color="0.2", ms=7, label="Start"))
    tail = " " + unit_text(stream, unit)
    if dims == 2:
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(f"{stream}[0]{tail}")
        ax.set_ylabel(f"-{stream}[1]{tail}" if invert_y else f"{stream}[1]{tail}")
    else:
        span = np.ptp(P, axis=0)
        ax.set_box_aspect(np.where(span > 0, span, 1.0) / max(float(span.max()), 1e-12) + 0.05)
        ax.set_xlabel(f"{stream}[0]{tail}")
        ax.set_ylabel(f"-{stream}[1]{tail}" if invert_y else f"{stream}[1]{tail}")
        ax.set_zlabel(f"{stream}[2]{tail}")
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.set_major_locator(MaxNLocator(5))  # a short axis gets a few legible ticks, not a crowd
    # beside the axes, not on them: a 3-D axes has no free corner ("best" does not apply to it)
    fig.legend(handles=handles, loc="outside right upper", fontsize="small")
    ax.set_title(f"{plural(result.n_segments, 'segment')} of {stream}")
    return _save(fig, path)
