"""Clustering versions: fitting, incremental assignment and label carry-over."""

from __future__ import annotations

import numpy as np

from .._validation import check_positive
from ._arrays import FEATURE_KINDS, flat_features, from_json, from_npy, to_json, to_npy
from ._schema import now

__all__ = ["current_version", "fit_version", "assign_incremental", "load_version"]


def current_version(conn):
    """The latest clustering version number, or None before the first clustering."""
    return conn.execute("SELECT MAX(version) FROM cluster_versions").fetchone()[0]


def load_version(conn, version) -> dict:
    """A clustering version's parameters and learned arrays."""
    row = conn.execute("SELECT params, n_clusters, centers, pca_mean, pca_components, created "
                       "FROM cluster_versions WHERE version = ?", (version,)).fetchone()
    if row is None:
        raise ValueError(f"version: no clustering version {version} in the library")
    return {"version": int(version), "params": from_json(row[0]), "n_clusters": int(row[1]),
            "centers": from_npy(row[2]), "pca_mean": from_npy(row[3]),
            "pca_components": from_npy(row[4]), "created": row[5]}


def project(F, mean, components) -> np.ndarray:
    """The PCA projection ``(F - mean) @ components.T`` (no whitening)."""
    return (F - mean) @ components.T


def nearest(X, centers) -> np.ndarray:
    """Index of the nearest centre of each row of ``X``."""
    d2 = (np.einsum("ij,ij->i", X, X)[:, None] - 2.0 * X @ centers.T
          + np.einsum("ij,ij->i", centers, centers)[None, :])
    return np.argmin(d2, axis=1)


def _carry_labels(conn, old, new_version, prim_ids, labels) -> None:
    """Give a new cluster the old cluster label that more than half of its members had."""
    if old is None:
        return
    old_label = dict(conn.execute(
        "SELECT m.primitive_id, l.label FROM cluster_members m JOIN cluster_labels l "
        "ON l.version = m.version AND l.cluster = m.cluster WHERE m.version = ?", (old,)).fetchall())
    if not old_label:
        return
    for k in np.unique(labels):
        members = [pid for pid, c in zip(prim_ids, labels, strict=True) if c == k]
        names = [old_label[pid] for pid in members if pid in old_label]
        if not names:
            continue
        values, counts = np.unique(names, return_counts=True)
        best = int(np.argmax(counts))
        if counts[best] * 2 > len(members):
            conn.execute("INSERT INTO cluster_labels (version, cluster, label) VALUES (?, ?, ?)",
                         (new_version, int(k), str(values[best])))


def fit_version(conn, prims, demos, *, stretch, features, n_points, n_components, random_state) -> int:
    """Cluster primitives ``prims`` (rows ``(id, ...)``) whose samples are ``demos``; store a new version.

    The caller holds the transaction. Returns the new version number.
    """
    from sklearn.decomposition import PCA

    from ..clustering import ElasticClustering

    if features not in FEATURE_KINDS:
        raise ValueError(f"features: expected one of {list(FEATURE_KINDS)}, got {features!r}")
    n_points = check_positive(n_points, name="n_points", integer=True)
    n_components = check_positive(n_components, name="n_components", integer=True)
    if n_points < 2:
        raise ValueError(f"n_points: expected an integer >= 2, got {n_points}")
    if len(demos) < 2:
        raise ValueError(f"library: expected at least 2 primitives to cluster, got {len(demos)}")
    F = flat_features(demos, kind=features, n_points=n_points)
    pca = PCA(n_components=min(n_components, F.shape[0], F.shape[1]), random_state=random_state).fit(F)
    X = project(F, pca.mean_, pca.components_)
    model = ElasticClustering(stretch=stretch, random_state=random_state).fit(X)
    old = current_version(conn)
    params = {"stretch": float(stretch), "features": features, "n_points": int(n_points),
              "n_components": int(pca.components_.shape[0]), "random_state": random_state,
              "method": "ElasticClustering", "criterion": model.criterion,
              "min_separation": model.min_separation, "n_primitives": len(demos),
              "energy": float(model.energy_)}
    cur = conn.execute(
        "INSERT INTO cluster_versions (created, params, n_clusters, centers, pca_mean, pca_components) "
        "VALUES (?, ?, ?, ?, ?, ?)",
        (now(), to_json(params), int(model.n_clusters_), to_npy(model.cluster_centers_),
         to_npy(pca.mean_), to_npy(pca.components_)))
    version = cur.lastrowid
    prim_ids = [int(p) for p in prims]
    conn.executemany(
        "INSERT INTO cluster_members (version, primitive_id, cluster, features, assigned) "
        "VALUES (?, ?, ?, ?, 'fit')",
        [(version, pid, int(c), to_npy(x)) for pid, c, x in zip(prim_ids, model.labels_, X, strict=True)])
    _carry_labels(conn, old, version, prim_ids, model.labels_)
    return version


def assign_incremental(conn, prim_ids, demos) -> list:
    """Put new primitives in the nearest cluster of the current version; returns their clusters.

    Features are computed with the featuriser of that version (its stored
    resampling parameters and PCA arrays). Primitives that cannot be
    featurised the same way (another number of dimensions, fewer than 2
    samples) stay unclustered (None). The caller holds the transaction.
    """
    version = current_version(conn)
    if version is None or not prim_ids:
        return [None] * len(prim_ids)
    v = load_version(conn, version)
    p = v["params"]
    try:
        F = flat_features(demos, kind=p["features"], n_points=p["n_points"])
    except ValueError:
        return [None] * len(prim_ids)
    if F.shape[1] != v["pca_mean"].shape[0]:
        return [None] * len(prim_ids)
    X = project(F, v["pca_mean"], v["pca_components"])
    clusters = nearest(X, v["centers"])
    conn.executemany(
        "INSERT INTO cluster_members (version, primitive_id, cluster, features, assigned) "
        "VALUES (?, ?, ?, ?, 'incremental')",
        [(version, int(pid), int(c), to_npy(x)) for pid, c, x in zip(prim_ids, clusters, X, strict=True)])
    return [int(c) for c in clusters]
