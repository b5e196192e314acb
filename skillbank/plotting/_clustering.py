"""Figures of clustering results (the paper's Fig. 4): features and trajectories per cluster.

Drawn on a fresh :class:`matplotlib.figure.Figure` (no pyplot state) and
written to a file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from ..core._validation import check_array
from ._library import n_distinct
from ._segmentation import _save

__all__ = ["plot_cluster_comparison"]

# Red, green, blue first, as in the paper's figure; then matplotlib's tab10.
_PALETTE = ("#e41a1c", "#2ca02c", "#1f3fd6", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
            "#bcbd22", "#17becf")
_MAX_POINTS = 200  # per drawn trajectory; plenty for a thumbnail
_ZOOM = 0.82  # 3-D panels drawn a little smaller than their cell, so no axis label is cut off


def _colour(i: int) -> str:
    return _PALETTE[int(i) % len(_PALETTE)]


def _as_labels(labels, n: int, name: str) -> np.ndarray:
    arr = np.asarray(labels)
    if arr.ndim != 1 or arr.shape[0] != n:
        raise ValueError(f"{name}: expected {n} labels, one per sample, got shape {arr.shape}")
    _, codes = np.unique(arr, return_inverse=True)
    return codes.astype(np.intp)


def _display_order(labels: np.ndarray, classes: np.ndarray | None) -> np.ndarray:
    """Cluster ids sorted by majority class then size, so cluster j lines up with class j."""
    ids = np.unique(labels)
    sizes = np.bincount(labels)[ids]
    if classes is None:
        return ids[np.lexsort((ids, -sizes))]
    table = np.zeros((labels.max() + 1, classes.max() + 1), dtype=np.intp)
    np.add.at(table, (labels, classes), 1)
    major = table[ids].argmax(axis=1)
    return ids[np.lexsort((ids, -sizes, major))]


def _project3(X: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """At most three columns to draw: the features themselves, or their principal components."""
    if X.shape[1] <= 3:
        return X, [f"feature {i + 1}" for i in range(X.shape[1])]
    centred = X - X.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    return centred @ vt[:3].T, ["PC 1", "PC 2", "PC 3"]


def _scatter(fig, spec, X, colours, axis_names, title):
    if X.shape[1] >= 3:
        ax = fig.add_subplot(spec, projection="3d")
        ax.scatter(X[:, 0], X[:, 1], X[:, 2], c=colours, s=8, depthshade=False)
        ax.set_zlabel(axis_names[2], fontsize=7, labelpad=-2)
        ax.set_box_aspect(None, zoom=_ZOOM)  # room inside the panel for the z label
    else:
        ax = fig.add_subplot(spec)
        y = X[:, 1] if X.shape[1] == 2 else np.zeros(X.shape[0])
        ax.scatter(X[:, 0], y, c=colours, s=8)
    ax.set_xlabel(axis_names[0], fontsize=7, labelpad=-2 if X.shape[1] >= 3 else None)
    if X.shape[1] >= 2:
        ax.set_ylabel(axis_names[1], fontsize=7, labelpad=-2 if X.shape[1] >= 3 else None)
    ax.tick_params(labelsize=6, pad=0)
    ax.set_title(title, fontsize=9)
    return ax


def _trajectory_panel(fig, spec, trajs, colours, limits, unit, title):
    segments = []
    for Y in trajs:
        step = max(1, Y.shape[0] // _MAX_POINTS)
        segments.append(Y[::step, :3] if Y.shape[1] >= 3 else Y[::step, :2])
    three_d = limits.shape[0] >= 3
    ax = fig.add_subplot(spec, projection="3d") if three_d else fig.add_subplot(spec)
    if segments:
        if three_d:
            ax.add_collection3d(Line3DCollection(segments, colors=colours, linewidths=0.7))
        else:
            ax.add_collection(LineCollection(segments, colors=colours, linewidths=0.7))
    ax.set_xlim(*limits[0])
    ax.set_ylim(*limits[1])
    tail = f" ({unit})" if unit else ""
    pad = {"labelpad": -2} if three_d else {}
    ax.set_xlabel("x" + tail, fontsize=7, **pad)
    ax.set_ylabel("y" + tail, fontsize=7, **pad)
    if three_d:
        ax.set_zlim(*limits[2])
        ax.set_zlabel("z" + tail, fontsize=7, **pad)
        ax.set_box_aspect(None, zoom=_ZOOM)
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.set_major_locator(MaxNLocator(3))  # three ticks: legible at a thumbnail's size
    ax.tick_params(labelsize=6, pad=0)
    ax.set_title(title, fontsize=9)
    return ax


def plot_cluster_comparison(features, labelings, path, *, trajectories=None, classes=None,
                            class_names=None, max_clusters_shown=6, title=None, separation=None,
                            unit=None) -> Path:
    """Draw one row per clustering: the features coloured by cluster, then each cluster's trajectories.

    Parameters
    ----------
    features : array-like of shape (n_samples, n_features)
        Drawn in 3-D (more than three features are projected on their first
        three principal components; one or two are drawn flat).
    labelings : dict of str to array-like of shape (n_samples,), or one array-like
        Cluster labels of each method, e.g. ``{"elastic": ..., "agglomerative": ...}``.
    path : str or path-like
        Output image file; parent directories are created.
    trajectories : list of array-like (n_steps, n_dims), optional
        One per sample; adds one panel per cluster with its trajectories, as
        in the paper's Fig. 4.
    classes : array-like of shape (n_samples,), optional
        True classes. Adds a "ground truth" row, colours trajectories by
        class (so misclustered demos stand out) and orders each row's
        clusters by majority class.
    class_names : list of str, optional
        Legend names of the classes (default: the class values).
    max_clusters_shown : int, default=6
        Trajectory panels per row; clusters beyond are listed in the title.
    title : str, optional
    separation : array-like of shape (n_clusters,), or dict of str to such, optional
        Each cluster's separation from its nearest other cluster
        (:attr:`ElasticClustering.separation_`), indexed like the cluster
        labels 0..k-1; written in the panel titles next to the size. An array
        is for a single clustering; a dict gives it by clustering name.
    unit : str, optional
        The trajectories' unit, written on their axes (e.g. ``"m"``).

    Returns
    -------
    pathlib.Path
        The file written (``.png`` added to a name without extension).

    Raises
    ------
    ValueError
        If shapes do not match.

    Examples
    --------
    >>> X = np.random.default_rng(0).normal(size=(30, 3))
    >>> plot_cluster_comparison(X, {"k": np.arange(30) % 3}, "clusters.png")  # doctest: +SKIP
    PosixPath('clusters.png')
    """
    X = check_array(features, name="features", ndim=2)
    n = X.shape[0]
    if not isinstance(labelings, dict):
        labelings = {"clusters": labelings}
    if not labelings:
        raise ValueError("labelings: expected at least one clustering, got none")
    rows = {str(k): _as_labels(v, n, f"labelings[{k!r}]") for k, v in labelings.items()}
    # panels name each cluster by its own label, as the labels, 'skillbank cluster' and the library do
    ids = {str(k): np.unique(np.asarray(v)) for k, v in labelings.items()}
    cls = None
    if classes is not None:
        raw_classes = np.asarray(classes)
        cls = _as_labels(raw_classes, n, "classes")
        if class_names is None:
            class_names = [str(c) for c in np.unique(raw_classes)]
        rows = {"ground truth": cls, **rows}
        ids = {"ground truth": np.unique(raw_classes), **ids}
    seps = {}
    if separation is not None:
        if not isinstance(separation, dict):
            if len(labelings) != 1:
                raise ValueError("separation: expected a dict by clustering name when there are "
                                 f"{len(labelings)} clusterings, got one array")
            separation = {next(iter(rows)) if cls is None else list(rows)[1]: separation}
        for key, value in separation.items():
            if str(key) not in rows:
                raise ValueError(f"separation: expected clustering names {list(labelings)}, got {key!r}")
            arr = np.asarray(value, dtype=float).ravel()
            if arr.shape[0] != ids[str(key)].size:
                raise ValueError(f"separation[{key!r}]: expected {ids[str(key)].size} values, one per "
                                 f"cluster, got {arr.shape[0]}")
            seps[str(key)] = arr
    trajs = None
    if trajectories is not None:
        trajs = [check_array(Y, name=f"trajectories[{i}]", ndim=(1, 2), as_2d=True)
                 for i, Y in enumerate(trajectories)]
        if len(trajs) != n:
            raise ValueError(f"trajectories: expected {n}, one per sample, got {len(trajs)}")
    shown = max(1, int(max_clusters_shown))
    n_cols = 1 + (min(shown, max(int(v.max()) + 1 for v in rows.values())) if trajs else 0)
    fig = Figure(figsize=(2.9 * n_cols + 0.6, 3.0 * len(rows) + 0.8), layout="constrained")
    grid = fig.add_gridspec(len(rows), n_cols)
    P, axis_names = _project3(X)
    if trajs:
        stacked = np.concatenate([Y[:, :3] for Y in trajs])
        pad = 0.02 * (stacked.max(axis=0) - stacked.min(axis=0)) + 1e-12
        limits = np.column_stack([stacked.min(axis=0) - pad, stacked.max(axis=0) + pad])
    for r, (name, labels) in enumerate(rows.items()):
        truth = cls is not None and r == 0
        order = np.unique(labels) if truth else _display_order(labels, cls)
        rank = np.empty(labels.max() + 1, dtype=np.intp)
        rank[order] = np.arange(order.size)
        colours = [_colour(rank[c]) for c in labels]
        ax = _scatter(fig, grid[r, 0], P, colours, axis_names,
                      f"{name}: {order.size} cluster{'s' if order.size != 1 else ''}")
        if not trajs:
            continue
        line_colours = [_colour(c) for c in (cls if cls is not None else rank[labels])]
        for j, cid in enumerate(order[:n_cols - 1]):
            members = np.flatnonzero(labels == cid)
            label = class_names[cid] if truth and class_names else f"cluster {ids[name][cid]}"
            count = f"{members.size}"
            distinct = n_distinct([trajs[i] for i in members], float(np.ptp(limits, axis=1).max()))
            if distinct < members.size:  # members drawn over each other would look like fewer
                count += " identical" if distinct == 1 else f", {distinct} distinct"
            if name in seps and np.isfinite(seps[name][cid]):
                count += f", separation {seps[name][cid]:.1f}"
            _trajectory_panel(fig, grid[r, j + 1], [trajs[i] for i in members],
                              [line_colours[i] for i in members], limits, unit, f"{label} ({count})")
        if order.size > n_cols - 1:
            ax.set_title(ax.get_title() + f" ({order.size - n_cols + 1} not drawn)", fontsize=9)
    if cls is not None and class_names:
        handles = [Line2D([], [], color=_colour(i), lw=2) for i in range(len(class_names))]
        fig.legend(handles, class_names, loc="outside lower center", ncol=len(class_names), frameon=False)
    if title:
        fig.suptitle(title)
    return _save(fig, path)
