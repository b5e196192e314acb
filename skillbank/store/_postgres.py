"""The shared backend: a skill library in a PostgreSQL database, written by many processes and machines.

Any libpq connection URL opens it (``postgresql://`` or ``postgres://``, with
query parameters such as a Unix-socket ``?host=/path``, ``sslmode`` or
``options=-csearch_path%3Dlab``: the tables live in the connection's current
schema). The password comes from the URL, ``PGPASSWORD`` or ``~/.pgpass``
(libpq reads them) and is never shown: :attr:`PostgresStore.location` and
every message give the URL with it masked (:func:`mask_url`).

The schema has the SQLite store's version (:data:`~skillbank.store.SCHEMA_VERSION`,
kept in ``meta``), tables and migrations (:mod:`skillbank.store._postgres_rows`);
arrays are ``bytea`` holding ``.npy`` bytes (never pickles), JSON is text, and
every statement is parameterised.

Concurrency. Every write method is one transaction that first takes a
transaction-level advisory lock of the library (keyed by its schema), so
writers from any number of processes or machines are serialised exactly as
SQLite's ``BEGIN IMMEDIATE`` serialises them, and wait for it up to
``timeout`` seconds (``lock_timeout``). Under that lock the transaction runs
at READ COMMITTED, so each statement sees everything the previous lock
holders committed (REPEATABLE READ would keep the snapshot taken before the
wait), and ids come from a ``sequences`` table (SQLite's ``sqlite_sequence``):
never reused, and a rolled-back write leaves no gap, so both backends number
alike. Arrays are serialised before the lock is taken. Reads never wait: a
read of several statements is one ``REPEATABLE READ, READ ONLY`` transaction,
a consistent snapshot.
"""

from __future__ import annotations

import contextlib

import numpy as np

from ..core._validation import check_id, check_positive
from ._arrays import from_json, from_npy, to_json, to_npy
from ._base import Primitive, Store, check_description, check_items
from ._manifest import read_export
from ._postgres_rows import (
    PostgresRecords,
    create_tables,
    encode,
    identify,
    insert,
    load_rows,
    mask_url,
    migrate,
    new_ids,
    psycopg,
    scrub,
)
from ._records import primitive_demo
from ._schema import SCHEMA_VERSION, now
from ._transfer import import_records, write_export

__all__ = ["PostgresStore", "mask_url"]

_LOCK = 0x736B6C62  # high half of the library's advisory lock key ("sklb"); the low half is its schema's oid


def _int(value):
    """An id or version as a Python int for the driver (numpy integers too); None stays None."""
    return None if value is None else int(value)


class PostgresStore(Store):
    """A skill library in a PostgreSQL database, shared by many processes and machines.

    See the module docstring for URLs, passwords and concurrency. Needs
    psycopg 3 (``pip install 'skillbank[postgres]'``). The database must exist
    (``createdb``); the library's tables are created in the connection's
    current schema on first use (with ``create=True``).

    Parameters
    ----------
    url : str
        A libpq URL, ``postgresql://[user[:password]@][host][:port][/dbname][?param=value&...]``
        (``postgres://`` too).
    create : bool, default=True
        Create the library's tables when the schema holds none; False raises
        ValueError instead.
    timeout : float, default=60.0
        Seconds a writer waits for another writer (``lock_timeout``).
    readonly : bool, default=False
        Open for reading only: every transaction is read-only on the server
        too (``default_transaction_read_only``); never creates or migrates;
        every write method raises ValueError.

    Attributes
    ----------
    created : bool
        Whether opening created the library's tables.

    Raises
    ------
    ValueError
        One line, naming the URL with the password masked: a malformed URL,
        a server that cannot be reached or refuses the login, a missing
        database, a schema holding other tables, or a newer schema version.
    ImportError
        When psycopg is not installed.

    Examples
    --------
    >>> with PostgresStore("postgresql://lab@db.lab/skills") as store:  # doctest: +SKIP
    ...     store.demonstration_ids()
    []
    """

    scheme = "postgresql"
    #: Other URL schemes that open it (libpq accepts both).
    aliases = ("postgres",)

    def __init__(self, url, *, create: bool = True, timeout: float = 60.0, readonly: bool = False):
        self._url = str(url)
        self.readonly = bool(readonly)
        self.created = False
        self._timeout = float(check_positive(timeout, name="timeout"))
        self._conn = None
        self._conn = self._connect()
        try:
            with self._errors():
                self._prepare(create)
        except BaseException:
            self.close()
            raise

    # -- life cycle -----------------------------------------------------------------------------
    @classmethod
    def from_url(cls, url, *, create=True, **options):
        """The libpq URL as it is (``postgresql://`` or ``postgres://``)."""
        return cls(url, create=create, **options)

    @property
    def location(self) -> str:
        return mask_url(self._url)

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    @property
    def conn(self):
        """The open psycopg connection (autocommit; transactions are explicit)."""
        if self._conn is None:
            raise ValueError(f"library {self.location!r} is closed")
        return self._conn

    def _failure(self, what: str, exc) -> ValueError:
        """One line naming the library and what failed, the driver's words with the password scrubbed."""
        text = scrub(str(exc), self._url) or type(exc).__name__
        if "does not exist" in text and "database" in text:
            text += " (create it with 'createdb' or CREATE DATABASE)"
        elif "password authentication failed" in text or "no password supplied" in text:
            text += " (the password comes from the URL, PGPASSWORD or ~/.pgpass)"
        return ValueError(f"library {self.location!r}: {what}: {text}")

    def _connect(self):
        pg = psycopg()
        try:
            params = pg.conninfo.conninfo_to_dict(self._url)
        except pg.Error as exc:
            raise self._failure("expected a URL postgresql://[user@][host][:port][/dbname][?param=value]",
                                exc) from None
        # A silent network should not hang a command; lab admins see who is connected.
        options = {k: v for k, v in (("connect_timeout", 10), ("application_name", "skillbank"))
                   if k not in params}
        try:
            return pg.connect(self._url, autocommit=True, **options)
        except pg.Error as exc:
            raise self._failure("cannot connect", exc) from None

    @contextlib.contextmanager
    def _errors(self):
        pg = psycopg()
        try:
            yield
        except pg.errors.LockNotAvailable:
            raise ValueError(f"library {self.location!r}: another writer held it longer than the timeout "
                             f"({self._timeout:g} s); nothing was written") from None
        except pg.errors.ReadOnlySqlTransaction:
            raise ValueError(f"library {self.location!r} cannot be changed: it is open read-only") from None
        except pg.Error as exc:
            raise self._failure(type(exc).__name__, exc) from None

    @contextlib.contextmanager
    def _read(self):
        """One consistent snapshot: a REPEATABLE READ, READ ONLY transaction; yields a cursor."""
        conn = self.conn
        with self._errors(), conn.transaction():
            cur = conn.cursor(binary=True)  # arrays as raw bytes: 8 times faster than bytea's hex text
            cur.execute("SET TRANSACTION ISOLATION LEVEL REPEATABLE READ, READ ONLY")
            yield cur

    @contextlib.contextmanager
    def _write(self, what: str):
        """One transaction holding the library's advisory lock (writers serialised); yields a cursor."""
        if self.readonly:
            raise ValueError(f"library {self.location!r} is open read-only: cannot {what}")
        conn = self.conn
        with self._errors(), conn.transaction():
            cur = conn.cursor(binary=True)
            cur.execute("SELECT pg_advisory_xact_lock(%s)", (self._key,))
            yield cur

    def _prepare(self, create: bool) -> None:
        cur = self.conn.cursor()
        schema, oid = cur.execute("SELECT current_schema(), (SELECT oid FROM pg_namespace "
                                  "WHERE nspname = current_schema())").fetchone()
        if schema is None:
            raise ValueError(f"library {self.location!r}: no schema to hold it (the search_path names "
                             "none that exists)")
        self._key = (_LOCK << 32) | int(oid)
        cur.execute("SELECT set_config('lock_timeout', %s, false)",
                    (f"{max(1, round(self._timeout * 1000))}ms",))
        if self.readonly:
            cur.execute("SELECT set_config('default_transaction_read_only', 'on', false)")
        version = identify(cur, self.location, schema)
        if version == SCHEMA_VERSION:
            return
        if version == 0 and (self.readonly or not create):
            raise ValueError(f"library {self.location!r} does not exist (schema {schema!r} holds no "
                             "library); create it with 'skillbank library init'")
        if self.readonly:
            raise ValueError(f"library {self.location!r} has schema version {version}; open it once "
                             "read-write (any 'skillbank library' command that writes, or 'library init') "
                             f"to migrate it to version {SCHEMA_VERSION}")
        with self._write("create the library") as cur:
            version = identify(cur, self.location, schema)  # again, under the lock: another may have won
            if version == 0:
                create_tables(cur)
                self.created = True
            elif version < SCHEMA_VERSION:
                migrate(cur, version)

    def check(self) -> str:
        """``"ok"``, or what is wrong: a counter behind its ids, a range outside its demonstration, a
        member of a cluster its version does not have (the server enforces keys and references)."""
        with self._read() as cur:
            tops = cur.execute(
                "SELECT name, last, CASE name "
                "WHEN 'demonstrations' THEN (SELECT MAX(id) FROM demonstrations) "
                "WHEN 'primitives' THEN (SELECT MAX(id) FROM primitives) "
                "WHEN 'cluster_versions' THEN (SELECT MAX(version) FROM cluster_versions) "
                "WHEN 'provenance' THEN (SELECT MAX(id) FROM provenance) END "
                "FROM sequences ORDER BY name").fetchall()
            problems = [f"counter of {name} at {last}, below its largest id {top}"
                        for name, last, top in tops if top is not None and last < top]
            n = cur.execute("SELECT COUNT(*) FROM primitives p JOIN demonstrations d "
                            "ON d.id = p.demonstration_id WHERE NOT "
                            "(0 <= p.start AND p.start < p.stop AND p.stop <= d.n_steps)").fetchone()[0]
            if n:
                problems.append(f"{n} primitive(s) outside their demonstration")
            n = cur.execute("SELECT COUNT(*) FROM cluster_members m JOIN cluster_versions v USING (version) "
                            "WHERE m.cluster < 0 OR m.cluster >= v.n_clusters").fetchone()[0]
            if n:
                problems.append(f"{n} member(s) in a cluster their version does not have")
        return "; ".join(problems) or "ok"

    # -- demonstrations and primitives ------------------------------------------------------------
    def add_demonstrations(self, items) -> list:
        items = check_items(items)
        encoded = [encode(item["demo"], item["bounds"], source=item["source"],
                          labels=[item["label"]] * len(item["bounds"]),
                          provenance=("segmentation", item["provenance"] or {}, None)) for item in items]
        members = [None if item["members"] is None else
                   (int(item["members"]["version"]), [int(c) for c in item["members"]["clusters"]],
                    [to_npy(x) for x in item["members"]["features"]]) for item in items]
        with self._write("add demonstrations") as cur:
            out = insert(cur, encoded)
            rows = [(m[0], p, c, x) for (_, pids), m in zip(out, members, strict=True) if m is not None
                    for p, c, x in zip(pids, m[1], m[2], strict=True)]
            if rows:
                cur.executemany("INSERT INTO cluster_members (version, primitive_id, cluster, features, "
                                "assigned) VALUES (%s, %s, %s, %s, 'incremental')", rows)
        return out

    def remove_demonstration(self, demo_id) -> None:
        demo_id = check_id(demo_id, name="demo_id")
        with self._write("remove a demonstration") as cur:
            if cur.execute("DELETE FROM demonstrations WHERE id = %s", (demo_id,)).rowcount == 0:
                raise ValueError(f"demo_id: no demonstration with id {demo_id} in the library")

    def demonstrations(self, ids) -> dict:
        ids = [check_id(i, name="demo_id") for i in ids]
        with self._read() as cur:
            return load_rows(cur, ids)

    def demonstration_ids(self) -> list:
        with self._errors():
            return [r[0] for r in self.conn.execute("SELECT id FROM demonstrations ORDER BY id").fetchall()]

    def provenance(self, demo_id) -> dict:
        demo_id = check_id(demo_id, name="demo_id")
        with self._errors():
            row = self.conn.execute("SELECT p.params FROM demonstrations d LEFT JOIN provenance p "
                                    "ON p.id = d.provenance_id WHERE d.id = %s", (demo_id,)).fetchone()
        if row is None:
            raise ValueError(f"demo_id: no demonstration with id {demo_id} in the library")
        return from_json(row[0]) or {}

    def primitives(self, *, label=None, cluster=None, source=None, demonstration=None, load=True) -> list:
        filters = [("d.source = %s", None if source is None else str(source)),
                   ("p.demonstration_id = %s",
                    None if demonstration is None else check_id(demonstration, name="demonstration")),
                   ("m.cluster = %s", None if cluster is None else check_id(cluster, name="cluster")),
                   ("COALESCE(p.label, l.label) = %s", label)]
        given = [(sql, value) for sql, value in filters if value is not None]
        where = " AND ".join(sql for sql, _ in given) or "TRUE"
        with self._read() as cur:
            version = self._current(cur)
            rows = cur.execute(
                "SELECT p.id, p.demonstration_id, p.start, p.stop, m.cluster, COALESCE(p.label, l.label), "
                "m.features FROM primitives p JOIN demonstrations d ON d.id = p.demonstration_id "
                "LEFT JOIN cluster_members m ON m.primitive_id = p.id AND m.version = %s "
                "LEFT JOIN cluster_labels l ON l.version = m.version AND l.cluster = m.cluster "
                f"WHERE {where} ORDER BY p.id",  # noqa: S608 - fixed clauses; every value is a parameter
                [-1 if version is None else version, *(value for _, value in given)]).fetchall()
            parents = load_rows(cur, {r[1] for r in rows}) if load and rows else {}
        return [Primitive(pid, did, a, b, c, lab,
                          primitive_demo(parents[did], pid, did, a, b) if load else None,
                          None if feats is None else from_npy(feats))
                for pid, did, a, b, c, lab, feats in rows]

    # -- clustering versions and labels -----------------------------------------------------------
    @staticmethod
    def _current(cur):
        return cur.execute("SELECT MAX(version) FROM cluster_versions").fetchone()[0]

    def current_version(self):
        with self._errors():
            return self._current(self.conn)

    def version(self, version) -> dict:
        with self._errors():
            row = self.conn.execute("SELECT params, n_clusters, centers, pca_mean, pca_components, created "
                                    "FROM cluster_versions WHERE version = %s", (_int(version),)).fetchone()
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
                                          "WHERE version = %s", (_int(version),)).fetchall())

    def cluster_labels(self, version) -> dict:
        with self._errors():
            return dict(self.conn.execute("SELECT cluster, label FROM cluster_labels WHERE version = %s",
                                          (_int(version),)).fetchall())

    def add_version(self, *, params, centers, pca_mean, pca_components, members, labels=None) -> int:
        row = (now(), to_json(params), int(np.asarray(centers).shape[0]), to_npy(centers), to_npy(pca_mean),
               to_npy(pca_components))
        rows = [(int(p), int(c), to_npy(x)) for p, c, x in members]
        label_rows = [(int(k), str(v)) for k, v in (labels or {}).items()]
        with self._write("record a clustering") as cur:
            version = new_ids(cur, "cluster_versions", 1)[0]
            cur.execute("INSERT INTO cluster_versions (version, created, params, n_clusters, centers, "
                        "pca_mean, pca_components) VALUES (%s, %s, %s, %s, %s, %s, %s)", (version, *row))
            if rows:
                cur.executemany("INSERT INTO cluster_members (version, primitive_id, cluster, features, "
                                "assigned) VALUES (%s, %s, %s, %s, 'fit')", [(version, *r) for r in rows])
            if label_rows:
                cur.executemany("INSERT INTO cluster_labels (version, cluster, label) VALUES (%s, %s, %s)",
                                [(version, *r) for r in label_rows])
        return version

    def add_members(self, version, members) -> None:
        rows = [(int(version), int(c), to_npy(x), int(p)) for p, c, x in members]
        with self._write("assign primitives to clusters") as cur:
            if rows:  # a primitive removed meanwhile by another process is skipped, not an error
                cur.executemany("INSERT INTO cluster_members (version, primitive_id, cluster, features, "
                                "assigned) SELECT %s, id, %s, %s, 'incremental' FROM primitives "
                                "WHERE id = %s ON CONFLICT DO NOTHING", rows)

    def set_label(self, name, *, cluster=None, primitive=None) -> None:
        if (cluster is None) == (primitive is None):
            raise ValueError("label: give exactly one of cluster= or primitive=")
        with self._write("label") as cur:
            if primitive is not None:
                pid = check_id(primitive, name="primitive")
                if cur.execute("UPDATE primitives SET label = %s WHERE id = %s", (name, pid)).rowcount == 0:
                    raise ValueError(f"primitive: no primitive with id {pid} in the library")
                return
            k = check_id(cluster, name="cluster")
            version = self._current(cur)
            if version is None:
                raise ValueError("cluster: the library has no clusters yet; run cluster() first")
            n = cur.execute("SELECT n_clusters FROM cluster_versions WHERE version = %s",
                            (version,)).fetchone()[0]
            if not 0 <= k < n:
                raise ValueError(f"cluster: expected a cluster id in 0..{n - 1} (version {version}), got {k}")
            cur.execute("DELETE FROM cluster_labels WHERE version = %s AND cluster = %s", (version, k))
            if name is not None:
                cur.execute("INSERT INTO cluster_labels (version, cluster, label) VALUES (%s, %s, %s)",
                            (version, k, name))

    # -- skill descriptions -----------------------------------------------------------------------
    def set_description(self, label, action, binding) -> int:
        label, action, binding = check_description(label, action, binding)
        row = (now(), action, to_json(binding))
        with self._write("describe a skill") as cur:
            last = cur.execute("SELECT MAX(revision) FROM skill_descriptions WHERE label = %s",
                               (label,)).fetchone()[0]
            revision = 1 if last is None else int(last) + 1
            cur.execute("INSERT INTO skill_descriptions (label, revision, created, action, binding) "
                        "VALUES (%s, %s, %s, %s, %s)", (label, revision, *row))
        return revision

    def descriptions(self, *, history=False) -> list:
        records = self.records()
        with records.snapshot():
            return records.descriptions(history=history)

    # -- transfer --------------------------------------------------------------------------------
    def records(self) -> PostgresRecords:
        """The records protocol of :mod:`skillbank.store._transfer` (export, import, copy)."""
        return PostgresRecords(self)

    def export(self, folder, *, progress=None):
        return write_export(self.records(), folder, progress=progress)

    def import_folder(self, folder) -> dict:
        if self.readonly:
            raise ValueError(f"library {self.location!r} is open read-only: cannot import")
        return import_records(self.records(), read_export(folder))
