"""Figures of the keypoint evidence: each stream's signal, the keypoint curves and who supported each cut.

Drawn on a fresh :class:`matplotlib.figure.Figure` with constrained layout
(no pyplot state), written to a file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ..segmentation import SegmentationResult
from ..segmentation._segmenter import KEYPOINT_PROBABILITY
from ._segmentation import (
    _check_result,
    _check_segmented_stream,
    _colour,
    _runs,
    _save,
    _scaled,
    plural,
    unit_text,
)

__all__ = ["plot_keypoint_probability", "plot_segmentation_summary"]

# The streams' curves get colours of their own (matplotlib's Dark2), so that a colour in the
# stream panels always means a segment (tab10, as in plot_segments) and never a stream.
_STREAM_PALETTE = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02", "#a6761d", "#666666")
_KEYPOINT = "crimson"
_THRESHOLD = "0.45"


def _stream_colour(i: int) -> str:
    return _STREAM_PALETTE[i % len(_STREAM_PALETTE)]


def _signal(result: SegmentationResult, seg) -> tuple[np.ndarray, str]:
    """What a stream's changepoints were found on, and its axis label.

    A motion stream's changepoints come from its windowed jerk profile; a
    contact stream's from the steps of its magnitude; a discrete stream's from
    its switches: each panel shows the curve that was read, named as such.
    """
    if seg.kind == "motion":
        typical = seg.params.get("normalize", "robust") == "robust"
        scale = "typical" if typical else "max"
        return np.asarray(seg.profile, dtype=float), f"{seg.name} jerk\n(1 = {scale})"
    Y = np.asarray(result.demonstration[seg.name], dtype=float).reshape(result.demonstration.n_steps, -1)
    if seg.kind == "contact" or Y.shape[1] > 1:
        return np.linalg.norm(Y, axis=1), f"|{seg.name}|\n{unit_text(seg.name)}"
    return Y[:, 0], f"{seg.name}\n{unit_text(seg.name)}"


def _draw_signal(ax, t, y, labels, changepoints) -> None:
    """``y`` against time, coloured by the final segments, with the stream's own changepoints dashed."""
    for label, a, b in _runs(labels):
        stop = min(b + 1, t.size)  # join to the next segment's first sample
        ax.plot(t[a:stop], y[a:stop], color=_colour(label), lw=1.4)
    for c in changepoints:
        ax.axvline(t[int(c)], color="0.35", ls="--", lw=0.9)
    finite = y[np.isfinite(y)]
    if finite.size:
        lo, hi = float(finite.min()), float(finite.max())
        pad = 0.08 * (hi - lo) if hi > lo else 0.5
        ax.set_ylim(lo - pad, hi + pad)


def threshold(result: SegmentationResult) -> float | None:
    """The combined probability a keypoint must exceed, or None when the segmenter used none.

    With ``combine="evidence"`` (the default) and ``mode="deterministic"`` a
    keypoint is a mode of the combined probability above
    ``KEYPOINT_PROBABILITY`` (one half). ``mode="sampling"`` draws keypoints
    from the curve and ``combine="product"`` thresholds the number of
    agreeing streams, not this curve.
    """
    if result.combine == "evidence" and result.mode == "deterministic":
        return KEYPOINT_PROBABILITY
    return None


def _draw_probability(ax, result: SegmentationResult) -> None:
    """Each stream's keypoint curve (thin) and the combined one (thick black), with the keypoint threshold.

    With ``combine="evidence"`` the curves are probabilities, drawn on their
    own 0..1 scale, so a peak under the threshold is seen to be one. The
    product rule's combined curve is a distribution over the samples (its
    values sum to 1) and its stream curves sit on a floor: those are scaled
    to a maximum of 1 and the axis says so.
    """
    t = result.demonstration.t
    true_scale = result.combine == "evidence"
    scale = (lambda y: np.asarray(y, dtype=float)) if true_scale else _scaled
    for i, seg in enumerate(result.streams.values()):
        ax.plot(t, scale(seg.probability), lw=1.0, alpha=0.85, color=_stream_colour(i), label=seg.name)
    ax.plot(t, scale(result.probability), lw=2.4, color="k", label="combined")
    level = threshold(result)
    if level is not None:
        ax.axhline(level, color=_THRESHOLD, ls="--", lw=1.0, label=f"threshold {level:g}")
    ax.set_ylim(-0.03, 1.05)
    ax.set_ylabel("keypoint\nprobability" if true_scale else "keypoint\nprobability\n(scaled to max 1)",
                  fontsize="small")


def _draw_support(ax, result: SegmentationResult) -> None:
    """Which streams supported each keypoint: one row per stream, a dot sized by its evidence.

    Stream names are the rows' tick labels, horizontal beside the axis, so they
    never cross a curve or another label, however many streams saw a cut.
    """
    t = result.demonstration.t
    names = list(result.streams)
    row = {name: k for k, name in enumerate(names)}
    for k, support in zip(np.asarray(result.keypoints, dtype=int), result.keypoint_support, strict=True):
        for name, evidence in support.items():
            ax.scatter(t[k], row[name], s=12 + 60 * float(evidence), color=_stream_colour(row[name]),
                       zorder=3)
    ax.set_yticks(range(len(names)), names, fontsize="small")
    ax.set_ylim(len(names) - 0.5, -0.5)  # first stream on top, as in the panels above
    ax.set_ylabel("support", fontsize="small")
    ax.grid(axis="y", color="0.9", lw=0.6)


def _keypoint_lines(axes, result: SegmentationResult) -> None:
    t = result.demonstration.t
    for ax in axes:
        for k in result.keypoints:
            ax.axvline(t[int(k)], color=_KEYPOINT, ls=":", lw=1.2)


def _title(result: SegmentationResult) -> str:
    """What the figure shows, in words that agree with it: a peak under the threshold is named as such."""
    if not result.keypoints.size:
        level = threshold(result)
        top = float(np.max(result.probability)) if result.probability.size else 0.0
        if level is not None and top > 0.0:
            return f"1 segment, no keypoint (highest probability {top:.2f}, under the threshold {level:g})"
        return "1 segment, no keypoint"
    times = ", ".join(f"{x:.2f}" for x in result.keypoint_times)
    return f"{plural(result.n_segments, 'segment')}, {plural(result.keypoints.size, 'keypoint')} at {times} s"


def _legend_handles(result: SegmentationResult, *, changepoints: bool) -> list:
    handles = [Line2D([], [], color=_stream_colour(i), lw=1.0, label=name)
               for i, name in enumerate(result.streams)]
    handles.append(Line2D([], [], color="k", lw=2.4, label="combined"))
    level = threshold(result)
    if level is not None:
        handles.append(Line2D([], [], color=_THRESHOLD, ls="--", lw=1.0, label=f"threshold {level:g}"))
    if changepoints:
        handles.append(Line2D([], [], color="0.35", ls="--", lw=0.9, label="stream's changepoint"))
    handles.append(Line2D([], [], color=_KEYPOINT, ls=":", lw=1.2, label="keypoint"))
    return handles


def plot_keypoint_probability(result, path) -> Path:
    """Plot each stream's keypoint curve, the combined keypoint probability and each keypoint's support.

    With ``combine="evidence"`` (the default) the curves are drawn on their
    0..1 scale with the segmenter's threshold dashed (keypoints are the peaks
    above it); the product rule's curves are scaled to a maximum of 1. Stream
    curves are thin lines, the
    combined curve is thick and black, keypoints are dotted vertical lines;
    under it, one row per stream marks the keypoints that stream supported,
    a larger dot for more evidence.

    Parameters
    ----------
    result : SegmentationResult
    path : str or path-like
        Output image file; parent directories are created.

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    >>> plot_keypoint_probability(result, "figs/probability.png")  # doctest: +SKIP
    PosixPath('figs/probability.png')
    """
    result = _check_result(result)
    t = result.demonstration.t
    n = len(result.streams)
    fig = Figure(figsize=(8.0, 3.4 + 0.22 * n), layout="constrained")
    ax, support = fig.subplots(2, 1, sharex=True, height_ratios=[3.0, 0.4 + 0.22 * n])
    _draw_probability(ax, result)
    _draw_support(support, result)
    _keypoint_lines([ax, support], result)
    ax.set_xlim(t[0], t[-1])
    support.set_xlabel("Time [s]")
    fig.legend(handles=_legend_handles(result, changepoints=False), loc="outside right center",
               fontsize="small")
    fig.suptitle(f"Keypoint probability: {_title(result)}")
    return _save(fig, path)


def plot_segmentation_summary(result, path, *, stream=None) -> Path:
    """Plot what each stream's changepoints were found on, the keypoint curves and each keypoint's support.

    One panel per segmented stream (stacked, shared time axis): a motion
    stream's windowed jerk profile, a contact stream's magnitude, a discrete
    stream's value, coloured by the final segments (as in
    :func:`plot_segments`), with dashed lines at that stream's own
    changepoints. Then the keypoint curves, and one row per stream marking the
    keypoints it supported. Keypoints are dotted lines across all panels.

    Parameters
    ----------
    result : SegmentationResult
    path : str or path-like
        Output image file; parent directories are created.
    stream : str or list of str, optional
        Only these segmented streams' panels (default: all).

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    >>> plot_segmentation_summary(result, "figs/summary.png")  # doctest: +SKIP
    PosixPath('figs/summary.png')
    """
    result = _check_result(result)
    if stream is None:
        names = list(result.streams)
    else:
        names = [stream] if isinstance(stream, str) else list(stream)
    segs = [_check_segmented_stream(result, name) for name in names]
    t = result.demonstration.t
    n = len(result.streams)
    heights = [1.3] * len(segs) + [1.6, 0.4 + 0.22 * n]
    fig = Figure(figsize=(9.0, sum(heights) + 1.0), layout="constrained")
    axes = fig.subplots(len(heights), 1, sharex=True, height_ratios=heights)
    labels = result.labels
    for ax, seg in zip(axes, segs, strict=False):
        y, ylabel = _signal(result, seg)
        _draw_signal(ax, t, y, labels, seg.changepoints)
        ax.set_ylabel(ylabel, fontsize="small")
    _draw_probability(axes[-2], result)
    _draw_support(axes[-1], result)
    _keypoint_lines(axes, result)
    axes[-1].set_xlim(t[0], t[-1])
    axes[-1].set_xlabel("Time [s]")
    segments = [Line2D([], [], color=_colour(k), lw=2.0, label=f"segment {k + 1}")
                for k in range(result.n_segments)]
    fig.legend(handles=_legend_handles(result, changepoints=True) + segments, loc="outside right center",
               fontsize="small")
    fig.suptitle(f"Segmentation: {_title(result)}")
    fig.align_ylabels(axes)
    return _save(fig, path)
