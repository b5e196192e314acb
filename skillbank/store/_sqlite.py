"""The embedded backend: one SQLite file in WAL mode."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core._validation import check_id
from ._arrays import from_json, from_npy, to_json, to_npy
from ._base import Primitive, Store, check_description, check_items
from ._records import insert_demonstration, load_demonstrations, primitive_demo
from ._schema import connect, database_errors, now, transaction
from ._transfer import SQLiteRecords, export_library, import_library

__all__ = ["SQLiteStore"]


class SQLiteStore(Store):
    """A skill library in one SQLite file (WAL mode; concurrent writers queue on its lock).

    Parameters
    ----------
    path : str or path-like
        The library file; created when missing (with ``create=True``).
    create : bool, default=True
        False raises ValueError when the file does not exist.
    timeout : float, default=60.0
        Seconds a writer waits for another writer before giving up.
    readonly : bool, default=False
        Open without writing anything, not even WAL's side files where the
        folder cannot be written: a library shared read-only (a folder the
        user may not write) can be read. Never creates or migrates the
        library; every write method raises ValueError.

    Raises
    ------
    ValueError
        One line, for a file that is not SQLite, is corrupt, is not a
        skillbank library or was written by a newer schema version; and
        when opened for writing where the file or its folder is read-only.

    Examples
    --------
    >>> import os, tempfile
    >>> with SQLiteStore(os.path.join(tempfile.mkdtemp(), "lib.db")) as store:
    ...     store.demonstration_ids(), store.current_version()
    ([], None)
    """

    scheme = "sqlite"

    def __init__(self, path, *, create: bool = True, timeout: float = 60.0, readonly: bool = False):
        self.path = Path(path)
        self.readonly = bool(readonly)
        self._conn = connect(self.path, timeout=timeout, create=create, readonly=self.readonly)

    # -- life cycle -----------------------------------------------------------------------------
    @classmethod
    def from_url(cls, url, *, create=True, **options):
        """``sqlite:///relative/path`` or ``sqlite:////absolute/path`` (the SQLAlchemy convention)."""
        rest = url.split("://", 1)[1]
        return cls(rest[1:] if rest.startswith("/") else rest, create=create, **options)

    @property
    def location(self) -> str:
        return str(self.path)

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    @property
    def conn(self):
        """The open SQLite connection."""
        if self._conn is None:
            raise ValueError(f"library {str(self.path)!r} is closed")
        return self._conn

    def _errors(self):
        return database_errors(self.path)

    def _writable(self, what: str):
        """The connection, for a write; one clear line when the library is open read-only."""
        if self.readonly:
            raise ValueError(f"library {str(self.path)!r} is open read-only: cannot {what}")
        return self.conn

    def check(self) -> str:
        with self._errors():
            return "; ".join(r[0] for r in self.conn.execute("PRAGMA integrity_check"))

    # -- demonstrations and primitives ------------------------------------------------------------
    def add_demonstrations(self, items) -> list:
        items = check_items(items)
        out = []
        with self._errors(), transaction(self._writable("add demonstrations")) as conn:
            for item in items:
                did, pids = insert_demonstration(
                    conn, item["demo"], item["bounds"], source=item["source"],
                    labels=[item["label"]] * len(item["bounds"]),
                    provenance=("segmentation", item["provenance"] or {}, None))
                members = item["members"]
                if members is not None:
                    conn.executemany(
                        "INSERT INTO cluster_members (version, primitive_id, cluster, features, assigned) "
                        "VALUES (?, ?, ?, ?, 'incremental')",
                        [(int(members["version"]), int(p), int(c), to_npy(x)) for p, c, x in
                         zip(pids, members["clusters"], members["features"], strict=True)])
                out.append((did, pids))
        return out

    def remove_demonstration(self, demo_id) -> None:
        demo_id = check_id(demo_id, name="demo_id")
        with self._errors(), transaction(self._writable("remove a demonstration")) as conn:
            if conn.execute("DELETE FROM demonstrations WHERE id = ?", (demo_id,)).rowcount == 0:
                raise ValueError(f"demo_id: no demonstration with id {demo_id} in the library")

    def demonstrations(self, ids) -> dict:
        ids = [check_id(i, name="demo_id") for i in ids]
        with self._errors():
            return load_demonstrations(self.conn, ids)

    def demonstration_ids(self) -> list:
        with self._errors():
            return [r[0] for r in self.conn.execute("SELECT id FROM demonstrations ORDER BY id")]

    def provenance(self, demo_id) -> dict:
        with self._errors():
            row = self.conn.execute("SELECT p.params FROM demonstrations d LEFT JOIN provenance p "
                                    "ON p.id = d.provenance_id WHERE d.id = ?",
                                    (check_id(demo_id, name="demo_id"),)).fetchone()
        if row is None:
            raise ValueError(f"demo_id: no demonstration with id {demo_id} in the library")
        return from_json(row[0]) or {}

    def primitives(self, *, label=None, cluster=None, source=None, demonstration=None, load=True) -> list:
        cluster = None if cluster is None else check_id(cluster, name="cluster")
        demonstration = None if demonstration is None else check_id(demonstration, name="demonstration")
        source = None if source is None else str(source)
        with self._errors():
            conn = self.conn
            version = self._current(conn)
            rows = conn.execute(
                "SELECT p.id, p.demonstration_id, p.start, p.stop, m.cluster, COALESCE(p.label, l.label), "
                "m.features FROM primitives p JOIN demonstrations d ON d.id = p.demonstration_id "
                "LEFT JOIN cluster_members m ON m.primitive_id = p.id AND m.version = ? "
                "LEFT JOIN cluster_labels l ON l.version = m.version AND l.cluster = m.cluster "
                "WHERE (? IS NULL OR d.source = ?) AND (? IS NULL OR p.demonstration_id = ?) "
                "AND (? IS NULL OR m.cluster = ?) AND (? IS NULL OR COALESCE(p.label, l.label) = ?) "
                "ORDER BY p.id",
                (-1 if version is None else version, source, source, demonstration, demonstration,
                 cluster, cluster, label, label)).fetchall()
            parents = load_demonstrations(conn, {r[1] for r in rows}) if load and rows else {}
        out = []
        for pid, did, a, b, c, lab, feats in rows:
            demo = primitive_demo(parents[did], pid, did, a, b) if load else None
            out.append(Primitive(pid, did, a, b, c, lab, demo, None if feats is None else from_npy(feats)))
        return out

    # -- clustering versions and labels -----------------------------------------------------------
    @staticmethod
    def _current(conn):
        return conn.execute("SELECT MAX(version) FROM cluster_versions").fetchone()[0]

    def current_version(self):
        with self._errors():
            return self._current(self.conn)

    def version(self, version) -> dict:
        with self._errors():
            row = self.conn.execute("SELECT params, n_clusters, centers, pca_mean, pca_components, created "
                                    "FROM cluster_versions WHERE version = ?", (version,)).fetchone()
        if row is None:
            raise ValueError(f"version: no clustering version {version} in the library")
        return {"version": int(version), "params": from_json(row[0]), "n_clusters": int(row[1]),
                "centers": from_npy(row[2]), "pca_mean": from_npy(row[3]),
                "pca_components": from_npy(row[4]), "created": row[5]}

    def versions(self) -> list:
        with self._errors():
            rows = self.conn.execute("SELECT version, created, n_clusters, params FROM cluster_versions "
                                     "ORDER BY version").fetchall()
        return [{"version": v, "created": c, "n_clusters": n, "params": from_json(p)} for v, c, n, p in rows]

    def members(self, version) -> dict:
        with self._errors():
            return dict(self.conn.execute("SELECT primitive_id, cluster FROM cluster_members "
                                          "WHERE version = ?", (version,)).fetchall())

    def cluster_labels(self, version) -> dict:
        with self._errors():
            return dict(self.conn.execute("SELECT cluster, label FROM cluster_labels WHERE version = ?",
                                          (version,)).fetchall())

    def add_version(self, *, params, centers, pca_mean, pca_components, members, labels=None) -> int:
        with self._errors(), transaction(self._writable("record a clustering")) as conn:
            version = conn.execute(
                "INSERT INTO cluster_versions (created, params, n_clusters, centers, pca_mean, "
                "pca_components) VALUES (?, ?, ?, ?, ?, ?)",
                (now(), to_json(params), int(np.asarray(centers).shape[0]), to_npy(centers),
                 to_npy(pca_mean), to_npy(pca_components))).lastrowid
            conn.executemany(
                "INSERT INTO cluster_members (version, primitive_id, cluster, features, assigned) "
                "VALUES (?, ?, ?, ?, 'fit')",
                [(version, int(p), int(c), to_npy(x)) for p, c, x in members])
            conn.executemany("INSERT INTO cluster_labels (version, cluster, label) VALUES (?, ?, ?)",
                             [(version, int(k), str(v)) for k, v in (labels or {}).items()])
        return version

    def add_members(self, version, members) -> None:
        with self._errors(), transaction(self._writable("assign primitives to clusters")) as conn:
            # a primitive removed meanwhile by another process is skipped, not an error
            conn.executemany(
                "INSERT OR IGNORE INTO cluster_members (version, primitive_id, cluster, features, assigned) "
                "SELECT ?, id, ?, ?, 'incremental' FROM primitives WHERE id = ?",
                [(int(version), int(c), to_npy(x), int(p)) for p, c, x in members])

    def set_label(self, name, *, cluster=None, primitive=None) -> None:
        if (cluster is None) == (primitive is None):
            raise ValueError("label: give exactly one of cluster= or primitive=")
        with self._errors(), transaction(self._writable("label")) as conn:
            if primitive is not None:
                pid = check_id(primitive, name="primitive")
                if conn.execute("UPDATE primitives SET label = ? WHERE id = ?", (name, pid)).rowcount == 0:
                    raise ValueError(f"primitive: no primitive with id {pid} in the library")
                return
            k = check_id(cluster, name="cluster")
            version = self._current(conn)
            if version is None:
                raise ValueError("cluster: the library has no clusters yet; run cluster() first")
            n = conn.execute("SELECT n_clusters FROM cluster_versions WHERE version = ?",
                             (version,)).fetchone()[0]
            if not 0 <= k < n:
                raise ValueError(f"cluster: expected a cluster id in 0..{n - 1} (version {version}), got {k}")
            conn.execute("DELETE FROM cluster_labels WHERE version = ? AND cluster = ?", (version, k))
            if name is not None:
                conn.execute("INSERT INTO cluster_labels (version, cluster, label) VALUES (?, ?, ?)",
                             (version, k, name))

    # -- skill descriptions -----------------------------------------------------------------------
    def set_description(self, label, action, binding) -> int:
        label, action, binding = check_description(label, action, binding)
        with self._errors(), transaction(self._writable("describe a skill")) as conn:
            last = conn.execute("SELECT MAX(revision) FROM skill_descriptions WHERE label = ?",
                                (label,)).fetchone()[0]
            revision = 1 if last is None else int(last) + 1
            conn.execute("INSERT INTO skill_descriptions (label, revision, created, action, binding) "
                         "VALUES (?, ?, ?, ?, ?)", (label, revision, now(), action, to_json(binding)))
        return revision

    def descriptions(self, *, history=False) -> list:
        with self._errors():
            return SQLiteRecords(self.conn).descriptions(history=history)

    # -- transfer --------------------------------------------------------------------------------
    def export(self, folder, *, progress=None):
        with self._errors():
            if progress is None:
                return export_library(self.conn, folder)
            return export_library(self.conn, folder, progress=progress)

    def import_folder(self, folder) -> dict:
        self._writable("import")
        with self._errors():
            return import_library(self.conn, folder)
