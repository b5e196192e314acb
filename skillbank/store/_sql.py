"""The library's SQL, written once: :class:`SQLStore`, the base of the SQL backends, and :class:`Session`.

Every query of the :class:`~skillbank.store.Store` methods is here (the rows
of demonstrations and the transfer records are in
:mod:`skillbank.store._records`), with ``?`` for each bound value: all SQL
stays parameterised, and one text serves SQLite and PostgreSQL. What differs
between databases is a small *dialect* that each backend provides:

- ``marker``: its driver's parameter marker (``"?"``; psycopg's ``"%s"``), to
  which :func:`translate` rewrites the shared SQL once per statement;
- ``_transaction(write)``: how one transaction opens, yielding the driver's
  cursor or connection: a write takes the library's writer lock (SQLite's
  ``BEGIN IMMEDIATE`` with its busy timeout; a PostgreSQL advisory lock), a
  read is one consistent snapshot (SQLite's ``BEGIN`` in WAL mode;
  PostgreSQL's ``REPEATABLE READ, READ ONLY``);
- ``_statement()``: a cursor for one statement outside a transaction;
- ``_errors()``: the driver's errors as one-line ValueErrors naming the library;
- ``_new_ids``, ``_counters``, ``_set_counters``: the id counters (SQLite's
  ``sqlite_sequence`` behind ``AUTOINCREMENT``; a ``sequences`` table).
  Every insert names its ids, taken from these counters, so one batched
  statement per table serves both (no ``lastrowid`` or ``RETURNING``).

Bytes come back as the driver gives them (``bytes`` or ``memoryview``):
:func:`~skillbank.store._arrays.from_npy` takes either. The connection, URLs,
schema creation and migration, and ``check`` stay in each backend.
"""

from __future__ import annotations

import contextlib
import functools
from abc import abstractmethod

import numpy as np

from ..core._validation import check_id
from ._arrays import from_json, to_json, to_npy
from ._base import Primitive, Store, check_description, check_items
from ._manifest import read_export
from ._records import (
    SQLRecords,
    encode,
    insert,
    load_demonstrations,
    primitive_demo,
    remedy,
    stored_array,
    stored_json,
    stored_metadata,
)
from ._rows import damaged
from ._schema import now
from ._transfer import import_records, write_export

__all__ = ["SQLStore", "Session", "translate"]


@functools.lru_cache(maxsize=1024)
def translate(sql: str, marker: str) -> str:
    """``sql`` (written with ``?`` markers) for a driver whose marker is ``marker``.

    A ``?`` inside a quoted literal stays as it is; for ``%``-style markers
    (psycopg's ``%s``) every literal ``%`` is doubled, as the driver reads it.
    Cached: the library's statements are fixed texts.

    Examples
    --------
    >>> translate("SELECT name FROM t WHERE a = ? AND b LIKE 'x?%'", "%s")
    "SELECT name FROM t WHERE a = %s AND b LIKE 'x?%%'"
    >>> translate("SELECT ?", "?")
    'SELECT ?'
    """
    if marker == "?":
        return sql
    if "%" in marker:
        sql = sql.replace("%", "%%")
    parts = sql.split("'")  # even parts are outside quotes ('' inside a literal keeps the parity)
    return "'".join(part.replace("?", marker) if k % 2 == 0 else part for k, part in enumerate(parts))


# Sparse labels (the paper's): a label a person gave one primitive is inferred for the primitives of its
# cluster that have none, when the cluster's labelled members agree on it (members labelled differently
# are an ambiguity, and none is inferred); a label given to the cluster itself comes first.
_INFERRED = ("SELECT m2.cluster AS cluster, MIN(p2.label) AS label FROM cluster_members m2 "
             "JOIN primitives p2 ON p2.id = m2.primitive_id WHERE m2.version = ? AND p2.label IS NOT NULL "
             "GROUP BY m2.cluster HAVING COUNT(DISTINCT p2.label) = 1")
_EFFECTIVE = "COALESCE(p.label, l.label, i.label)"


class Session:
    """One transaction's (or statement's) driver cursor, taking the library's SQL as written.

    Parameters
    ----------
    raw : cursor or connection
        The driver's object (``execute``, ``executemany``).
    store : SQLStore
        Gives the marker and the id counters.
    """

    __slots__ = ("raw", "store", "_marker")

    def __init__(self, raw, store):
        self.raw = raw
        self.store = store
        self._marker = store.marker

    def execute(self, sql: str, params=()):
        """Run one statement; returns the driver's cursor (``fetchone``, ``fetchall``, ``rowcount``)."""
        return self.raw.execute(translate(sql, self._marker), params)

    def executemany(self, sql: str, rows: list) -> None:
        """Run one statement for every row (nothing for none; drivers differ on an empty batch)."""
        if rows:
            self.raw.executemany(translate(sql, self._marker), rows)

    def new_ids(self, table: str, n: int, given=None) -> list:
        """``n`` new ids of ``table``, or the ``given`` ids with its counter moved past them."""
        return self.store._new_ids(self, table, n, given)


class SQLStore(Store):
    """A store in a SQL database: every :class:`~skillbank.store.Store` method, over a small dialect.

    A backend subclasses it, opens its connection as ``_conn`` and provides
    what the module docstring lists (``marker``, ``_errors``, ``_transaction``,
    ``_statement``, ``_new_ids``, ``_counters``, ``_set_counters``), besides
    ``from_url``, ``location`` and ``check``. Every write method
    is one ``_write`` transaction; a read of several statements is one
    ``_read`` snapshot.
    """

    #: The driver's parameter marker; the shared SQL's ``?`` become it.
    marker: str = "?"

    #: The driver's connection, opened by the backend (autocommit: transactions are explicit); None: closed.
    _conn = None

    @property
    def conn(self):
        """The open connection (SQLite's or psycopg's)."""
        if self._conn is None:
            raise ValueError(f"library {self.location!r} is closed")
        return self._conn

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    # -- the dialect ------------------------------------------------------------------------------
    @abstractmethod
    def _errors(self):
        """Context manager turning the driver's errors into one-line ValueErrors naming the library."""

    @abstractmethod
    def _transaction(self, write: bool):
        """Context manager of one transaction, yielding the driver's cursor: ``write`` holds the
        library's writer lock (writers serialised, waiting up to the timeout), else a read snapshot."""

    @abstractmethod
    def _statement(self):
        """Context manager yielding a driver cursor for one statement outside a transaction."""

    @abstractmethod
    def _new_ids(self, db: Session, table: str, n: int, given=None) -> list:
        """``n`` new ids of ``table`` (never reused; a rolled-back write returns them), or ``given``
        ids with the counter moved past them; inside ``db``'s write transaction."""

    @abstractmethod
    def _counters(self, db: Session) -> dict:
        """``{table: last id handed out}``."""

    @abstractmethod
    def _set_counters(self, db: Session, counters: dict) -> None:
        """Move each table's counter up to ``counters[table]`` (never lowering it)."""

    # -- transactions -----------------------------------------------------------------------------
    @contextlib.contextmanager
    def _read(self):
        """One consistent read snapshot; yields a :class:`Session`."""
        with self._errors(), self._transaction(write=False) as raw:
            yield Session(raw, self)

    @contextlib.contextmanager
    def _write(self, what: str):
        """One write transaction holding the library's writer lock; yields a :class:`Session`.

        One clear line when the library is open read-only (``what``: what was refused).
        """
        self._check_writable(what)
        with self._errors(), self._transaction(write=True) as raw:
            yield Session(raw, self)

    def _check_writable(self, what: str) -> None:
        if self.readonly:
            raise ValueError(f"library {self.location!r} is open read-only: cannot {what}")

    def _rows(self, sql: str, params=()) -> list:
        """Every row of one read statement (a statement is its own snapshot: no transaction needed)."""
        with self._errors(), self._statement() as raw:
            return Session(raw, self).execute(sql, params).fetchall()

    # -- demonstrations and primitives ------------------------------------------------------------
    def add_demonstrations(self, items) -> list:
        items = check_items(items)
        encoded = [encode(item["demo"], item["bounds"], source=item["source"],
                          labels=[item["label"]] * len(item["bounds"]),
                          provenance=("segmentation", item["provenance"] or {}, None)) for item in items]
        members = [None if item["members"] is None else
                   (int(item["members"]["version"]), [int(c) for c in item["members"]["clusters"]],
                    [to_npy(x) for x in item["members"]["features"]]) for item in items]
        with self._write("add demonstrations") as db:
            out = insert(db, encoded)
            db.executemany("INSERT INTO cluster_members (version, primitive_id, cluster, features, assigned) "
                           "VALUES (?, ?, ?, ?, 'incremental')",
                           [(m[0], p, c, x) for (_, pids), m in zip(out, members, strict=True)
                            if m is not None for p, c, x in zip(pids, m[1], m[2], strict=True)])
        return out

    def remove_demonstration(self, demo_id) -> None:
        demo_id = check_id(demo_id, name="demo_id")
        with self._write("remove a demonstration") as db:
            if db.execute("DELETE FROM demonstrations WHERE id = ?", (demo_id,)).rowcount == 0:
                raise ValueError(f"demo_id: no demonstration with id {demo_id} in the library")

    def demonstrations(self, ids) -> dict:
        ids = [check_id(i, name="demo_id") for i in ids]
        with self._read() as db:
            return load_demonstrations(db, ids)

    def demonstration_ids(self) -> list:
        return [r[0] for r in self._rows("SELECT id FROM demonstrations ORDER BY id")]

    def demonstration_metadata(self) -> dict:
        with self._read() as db:
            rows = db.execute("SELECT id, metadata FROM demonstrations ORDER BY id").fetchall()
            return {did: stored_metadata(db, meta, did) for did, meta in rows}

    def provenance(self, demo_id) -> dict:
        demo_id = check_id(demo_id, name="demo_id")
        rows = self._rows("SELECT p.params FROM demonstrations d LEFT JOIN provenance p "
                          "ON p.id = d.provenance_id WHERE d.id = ?", (demo_id,))
        if not rows:
            raise ValueError(f"demo_id: no demonstration with id {demo_id} in the library")
        return from_json(rows[0][0]) or {}

    def primitives(self, *, label=None, cluster=None, source=None, demonstration=None, load=True) -> list:
        # only the filters given go into the query: a NULL-tolerant "? IS NULL OR ..." would leave the
        # planner no index, and PostgreSQL cannot type a bare NULL parameter
        filters = [("d.source = ?", None if source is None else str(source)),
                   ("p.demonstration_id = ?",
                    None if demonstration is None else check_id(demonstration, name="demonstration")),
                   ("m.cluster = ?", None if cluster is None else check_id(cluster, name="cluster")),
                   (f"{_EFFECTIVE} = ?", label)]
        given = [(sql, value) for sql, value in filters if value is not None]
        where = " AND ".join(sql for sql, _ in given) or "1 = 1"
        with self._read() as db:
            version = self._current(db)
            # LEFT JOIN: a primitive whose demonstration is gone (a damaged library) is named, not hidden
            rows = db.execute(
                f"SELECT p.id, p.demonstration_id, p.start, p.stop, m.cluster, {_EFFECTIVE}, "
                "m.features, d.id, d.n_steps, "
                "CASE WHEN p.label IS NOT NULL THEN 'given' WHEN l.label IS NOT NULL THEN 'cluster' "
                "WHEN i.label IS NOT NULL THEN 'inferred' END "
                "FROM primitives p LEFT JOIN demonstrations d ON d.id = p.demonstration_id "
                "LEFT JOIN cluster_members m ON m.primitive_id = p.id AND m.version = ? "
                "LEFT JOIN cluster_labels l ON l.version = m.version AND l.cluster = m.cluster "
                f"LEFT JOIN ({_INFERRED}) i ON i.cluster = m.cluster "
                f"WHERE {where} ORDER BY p.id",  # noqa: S608 - fixed clauses; every value is a parameter
                [-1 if version is None else version, -1 if version is None else version,
                 *(value for _, value in given)]).fetchall()
            for pid, did, a, b, *_, found, n, _source in rows:
                if found is None:
                    raise damaged(self.location, f"primitive {pid}",
                                  f"expected its demonstration {did}, got none (an orphan primitive)")
                if not isinstance(n, int) or n < 1:
                    raise damaged(self.location, f"demonstration {did}",
                                  f"expected n_steps >= 1, got {n!r}"[:200], remedy(self.location, did))
                if not (isinstance(a, int) and isinstance(b, int) and 0 <= a < b <= n):
                    raise damaged(self.location, f"primitive {pid}", f"expected 0 <= start < stop <= {n} "
                                  f"(the samples of demonstration {did}), got start {a}, stop {b}",
                                  remedy(self.location, did))
            parents = load_demonstrations(db, {r[1] for r in rows}) if load and rows else {}
            feats = {r[0]: None if r[6] is None else
                     stored_array(db, r[6], f"clustering version {version} member {r[0]} (its features)")
                     for r in rows}
        return [Primitive(pid, did, a, b, c, lab,
                          primitive_demo(parents[did], pid, did, a, b) if load else None, feats[pid], origin)
                for pid, did, a, b, c, lab, _f, _d, _n, origin in rows]

    def inferred_labels(self, version) -> dict:
        with self._read() as db:
            return dict(db.execute(_INFERRED, (check_id(version, name="version"),)).fetchall())

    # -- clustering versions and labels -----------------------------------------------------------
    @staticmethod
    def _current(db):
        return db.execute("SELECT MAX(version) FROM cluster_versions").fetchone()[0]

    def current_version(self):
        return self._rows("SELECT MAX(version) FROM cluster_versions")[0][0]

    def version(self, version) -> dict:
        with self._read() as db:
            rows = db.execute("SELECT params, n_clusters, centers, pca_mean, pca_components, created "
                              "FROM cluster_versions WHERE version = ?",
                              (check_id(version, name="version"),)).fetchall()
            if not rows:
                raise ValueError(f"version: no clustering version {version} in the library")
            params, n, centers, mean, comps, created = rows[0]
            row = f"clustering version {int(version)}"
            return {"version": int(version), "params": stored_json(db, params, f"{row} (its params)"),
                    "n_clusters": int(n), "centers": stored_array(db, centers, f"{row} (its centers)"),
                    "pca_mean": stored_array(db, mean, f"{row} (its pca_mean)"),
                    "pca_components": stored_array(db, comps, f"{row} (its pca_components)"),
                    "created": created}

    def versions(self) -> list:
        rows = self._rows("SELECT version, created, n_clusters, params FROM cluster_versions "
                          "ORDER BY version")
        return [{"version": v, "created": c, "n_clusters": n, "params": from_json(p)} for v, c, n, p in rows]

    def members(self, version) -> dict:
        return dict(self._rows("SELECT primitive_id, cluster FROM cluster_members WHERE version = ?",
                               (check_id(version, name="version"),)))

    def cluster_labels(self, version) -> dict:
        return dict(self._rows("SELECT cluster, label FROM cluster_labels WHERE version = ?",
                               (check_id(version, name="version"),)))

    def add_version(self, *, params, centers, pca_mean, pca_components, members, labels=None) -> int:
        row = (now(), to_json(params), int(np.asarray(centers).shape[0]), to_npy(centers), to_npy(pca_mean),
               to_npy(pca_components))
        rows = [(int(p), int(c), to_npy(x)) for p, c, x in members]
        label_rows = [(int(k), str(v)) for k, v in (labels or {}).items()]
        with self._write("record a clustering") as db:
            version = db.new_ids("cluster_versions", 1)[0]
            db.execute("INSERT INTO cluster_versions (version, created, params, n_clusters, centers, "
                       "pca_mean, pca_components) VALUES (?, ?, ?, ?, ?, ?, ?)", (version, *row))
            db.executemany("INSERT INTO cluster_members (version, primitive_id, cluster, features, assigned) "
                           "VALUES (?, ?, ?, ?, 'fit')", [(version, *r) for r in rows])
            db.executemany("INSERT INTO cluster_labels (version, cluster, label) VALUES (?, ?, ?)",
                           [(version, *r) for r in label_rows])
        return version

    def add_members(self, version, members) -> None:
        rows = [(int(version), int(c), to_npy(x), int(p)) for p, c, x in members]
        with self._write("assign primitives to clusters") as db:
            # a primitive removed meanwhile by another process is skipped, not an error
            db.executemany("INSERT INTO cluster_members (version, primitive_id, cluster, features, assigned) "
                           "SELECT ?, id, ?, ?, 'incremental' FROM primitives WHERE id = ? "
                           "ON CONFLICT DO NOTHING", rows)

    def set_label(self, name, *, cluster=None, primitive=None) -> None:
        if (cluster is None) == (primitive is None):
            raise ValueError("label: give exactly one of cluster= or primitive=")
        with self._write("label") as db:
            if primitive is not None:
                pid = check_id(primitive, name="primitive")
                if db.execute("UPDATE primitives SET label = ? WHERE id = ?", (name, pid)).rowcount == 0:
                    raise ValueError(f"primitive: no primitive with id {pid} in the library")
                return
            k = check_id(cluster, name="cluster")
            version = self._current(db)
            if version is None:
                raise ValueError("cluster: the library has no clusters yet; run cluster() first")
            n = db.execute("SELECT n_clusters FROM cluster_versions WHERE version = ?",
                           (version,)).fetchone()[0]
            if not 0 <= k < n:
                raise ValueError(f"cluster: expected a cluster id in 0..{n - 1} (version {version}), got {k}")
            db.execute("DELETE FROM cluster_labels WHERE version = ? AND cluster = ?", (version, k))
            if name is not None:
                db.execute("INSERT INTO cluster_labels (version, cluster, label) VALUES (?, ?, ?)",
                           (version, k, name))

    # -- skill descriptions -----------------------------------------------------------------------
    def set_description(self, label, action, binding) -> int:
        label, action, binding = check_description(label, action, binding)
        row = (now(), action, to_json(binding))
        with self._write("describe a skill") as db:
            last = db.execute("SELECT MAX(revision) FROM skill_descriptions WHERE label = ?",
                              (label,)).fetchone()[0]
            revision = 1 if last is None else int(last) + 1
            db.execute("INSERT INTO skill_descriptions (label, revision, created, action, binding) "
                       "VALUES (?, ?, ?, ?, ?)", (label, revision, *row))
        return revision

    def descriptions(self, *, history=False) -> list:
        records = self.records()
        with records.snapshot():
            return records.descriptions(history=history)

    # -- transfer --------------------------------------------------------------------------------
    def records(self) -> SQLRecords:
        """The records protocol of :mod:`skillbank.store._transfer` (export, import, copy)."""
        return SQLRecords(self)

    def export(self, folder, *, progress=None):
        return write_export(self.records(), folder, progress=progress)

    def import_folder(self, folder, *, max_bytes=None) -> dict:
        self._check_writable("import")  # before the folder is read
        return import_records(self.records(), read_export(folder, max_bytes=max_bytes))
