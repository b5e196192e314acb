"""Several segmented 2-D trajectories side by side, for comparing demonstrations."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ._segmentation import _check_result, _draw_segmented_path, _save, plural

__all__ = ["plot_segment_grid"]


def plot_segment_grid(results, path, *, stream: str = "position", invert_y: bool = False,
                      titles=None) -> Path:
    """Plot the first two columns of ``stream`` of each result, coloured by segment, in one row.

    Parameters
    ----------
    results : sequence of SegmentationResult
    path : str or path-like
        Output image file; parent directories are created.
    stream : str, default="position"
    invert_y : bool, default=False
        Negate the second column, for data in screen coordinates (y down).
    titles : sequence of str, optional
        One per result; default "<n> segments" ("1 segment").

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    >>> plot_segment_grid([r0, r1, r2], "figs/r_all.png", invert_y=True)  # doctest: +SKIP
    PosixPath('figs/r_all.png')
    """
    results = [_check_result(r) for r in results]
    if not results:
        raise ValueError("results: expected at least one SegmentationResult, got none")
    if titles is not None and len(titles) != len(results):
        raise ValueError(f"titles: expected {len(results)} titles, got {len(titles)}")
    for r in results:
        demo = r.demonstration
        if stream not in demo.streams or demo[stream].shape[1] < 2:
            raise ValueError(f"stream: expected a stream with at least 2 columns in every result, "
                             f"got {stream!r} in one with streams {demo.stream_names}")
    fig = Figure(figsize=(3.2 * len(results), 3.6))
    axes = fig.subplots(1, len(results), squeeze=False)[0]
    for i, (ax, r) in enumerate(zip(axes, results, strict=True)):
        P = np.asarray(r.demonstration[stream], dtype=float)[:, :2].copy()
        if invert_y:
            P[:, 1] = -P[:, 1]
        _draw_segmented_path(ax, P, r, lw=2.2, point_size=22, start_size=6)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(titles[i] if titles is not None else plural(r.n_segments, "segment"), fontsize="small")
    return _save(fig, path)
