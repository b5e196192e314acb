"""The SQL of the PostgreSQL backend: schema, migration, id counters, rows, and its transfer records.

Kept apart from :class:`skillbank.store.PostgresStore` (connections,
transactions, the :class:`~skillbank.store.Store` methods). Every statement
here is a fixed string with ``%s`` parameters; arrays travel as ``.npy``
bytes (``bytea``), JSON as text. psycopg itself is imported only where a
connection is made (:func:`psycopg`), so ``skillbank.store`` imports without it.
"""

from __future__ import annotations

import contextlib
import re
from urllib.parse import unquote

from ..core import Demonstration
from ._arrays import from_json, from_npy, to_json, to_npy
from ._schema import APPLICATION, SCHEMA_VERSION, now
from ._transfer import COUNTED, current_descriptions, demonstration_record, version_record

__all__ = ["mask_url", "scrub", "psycopg", "identify", "create_tables", "migrate", "new_ids", "encode",
           "insert", "load_rows", "PostgresRecords", "STEPS"]

_INSTALL = "pip install 'skillbank[postgres]'"
_CHUNK = 500  # demonstrations loaded at a time where a whole library might be scanned

_TABLES_V1 = (
    "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
    "CREATE TABLE sequences (name TEXT PRIMARY KEY, last BIGINT NOT NULL)",
    "CREATE TABLE demonstrations (id BIGINT PRIMARY KEY, source TEXT, n_steps BIGINT NOT NULL, "
    "t BYTEA NOT NULL, metadata TEXT NOT NULL, created TEXT NOT NULL)",
    "CREATE TABLE streams (demonstration_id BIGINT NOT NULL REFERENCES demonstrations(id) "
    "ON DELETE CASCADE, name TEXT NOT NULL, position INTEGER NOT NULL, data BYTEA NOT NULL, "
    "PRIMARY KEY (demonstration_id, name))",
    "CREATE TABLE primitives (id BIGINT PRIMARY KEY, demonstration_id BIGINT NOT NULL "
    "REFERENCES demonstrations(id) ON DELETE CASCADE, start BIGINT NOT NULL, stop BIGINT NOT NULL, "
    "label TEXT)",
    "CREATE TABLE cluster_versions (version BIGINT PRIMARY KEY, created TEXT NOT NULL, "
    "params TEXT NOT NULL, n_clusters BIGINT NOT NULL, centers BYTEA NOT NULL, pca_mean BYTEA NOT NULL, "
    "pca_components BYTEA NOT NULL)",
    "CREATE TABLE cluster_members (version BIGINT NOT NULL REFERENCES cluster_versions(version) "
    "ON DELETE CASCADE, primitive_id BIGINT NOT NULL REFERENCES primitives(id) ON DELETE CASCADE, "
    "cluster BIGINT NOT NULL, features BYTEA NOT NULL, PRIMARY KEY (version, primitive_id))",
    "CREATE TABLE cluster_labels (version BIGINT NOT NULL REFERENCES cluster_versions(version) "
    "ON DELETE CASCADE, cluster BIGINT NOT NULL, label TEXT NOT NULL, PRIMARY KEY (version, cluster))",
    "CREATE INDEX primitives_demo ON primitives(demonstration_id)",
    "CREATE INDEX members_primitive ON cluster_members(primitive_id)",
    "INSERT INTO sequences (name, last) VALUES ('demonstrations', 0), ('primitives', 0), "
    "('cluster_versions', 0)",
)

# Version 1 -> 2, as in SQLite: provenance of the segmentation, and how each member joined its cluster.
_MIGRATE_1_TO_2 = (
    "CREATE TABLE provenance (id BIGINT PRIMARY KEY, kind TEXT NOT NULL, params TEXT NOT NULL, "
    "created TEXT NOT NULL)",
    "ALTER TABLE demonstrations ADD COLUMN provenance_id BIGINT REFERENCES provenance(id)",
    "ALTER TABLE cluster_members ADD COLUMN assigned TEXT NOT NULL DEFAULT 'fit'",
    "INSERT INTO sequences (name, last) VALUES ('provenance', 0)",
)

# Version 2 -> 3, as in SQLite: skill descriptions, numbered revisions per label (the highest current).
_MIGRATE_2_TO_3 = (
    "CREATE TABLE skill_descriptions (label TEXT NOT NULL, revision BIGINT NOT NULL, created TEXT NOT NULL, "
    "action TEXT, binding TEXT NOT NULL, PRIMARY KEY (label, revision))",
)

#: The statements of each schema version from the previous one (a test keeps it as long as SCHEMA_VERSION).
STEPS = (_TABLES_V1, _MIGRATE_1_TO_2, _MIGRATE_2_TO_3)

# Samples are stored as they are: compressing float64 arrays saves nothing (measured: the same size with
# pglz) and took 2.4 times as long to insert. How rows are stored, not what they hold: no schema version.
_STORAGE = tuple(f"ALTER TABLE {table} ALTER COLUMN {column} SET STORAGE EXTERNAL" for table, column in (
    ("demonstrations", "t"), ("streams", "data"), ("cluster_members", "features")))

_USERINFO = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*://)([^?#]*)(.*)$", re.S)
_QUERY_PASSWORD = re.compile(r"([?&]password=)([^&#]*)", re.I)


# -- URLs and the driver ----------------------------------------------------------------------------
def mask_url(url) -> str:
    """``url`` with its password (in the user part or a ``password=`` parameter) shown as ``***``.

    Examples
    --------
    >>> mask_url("postgresql://ann:s3cret@db.lab:5432/skills?sslmode=require")
    'postgresql://ann:***@db.lab:5432/skills?sslmode=require'
    >>> mask_url("postgres:///skills?host=/run/pg&password=s3cret")
    'postgres:///skills?host=/run/pg&password=***'
    >>> mask_url("postgresql://postgres:@/skills?host=/tmp/pg")  # an empty password hides nothing
    'postgresql://postgres:@/skills?host=/tmp/pg'
    >>> mask_url("lib.db")
    'lib.db'
    """
    text = str(url)
    m = _USERINFO.match(text)
    if m is None:
        return text
    scheme, head, rest = m.groups()
    if "@" in head:  # the last '@' ends the user part, whatever the password holds
        user, hosts = head.rsplit("@", 1)
        name, _, password = user.partition(":")
        head = f"{name}:***@{hosts}" if password else head
    return scheme + head + _QUERY_PASSWORD.sub(r"\1***", rest)


def scrub(text: str, url: str) -> str:
    """``text`` (a driver's message) on one line, with the password of ``url``, as written or decoded, masked.

    libpq quotes the bad part of a malformed URL, which may be the password.

    Examples
    --------
    >>> scrub('invalid percent-encoded token: "se%zz"', "postgresql://ann:se%zz@db/skills")
    'invalid percent-encoded token: "***"'
    """
    m = _USERINFO.match(url)
    found = []
    if m is not None:
        head, rest = m.group(2), m.group(3)
        user = head.rsplit("@", 1)[0] if "@" in head else ""
        if ":" in user:
            found.append(user.split(":", 1)[1])
        found += [p for _, p in _QUERY_PASSWORD.findall(rest)]
    found += [unquote(p) for p in found]
    text = str(text)
    for secret in sorted({p for p in found if p}, key=len, reverse=True):
        text = text.replace(secret, "***")
    return " ".join(text.split())


def psycopg():
    """The psycopg 3 module; a one-line ImportError saying what to install when it is missing."""
    try:
        import psycopg as module  # optional: the PostgreSQL backend only
    except ImportError:
        raise ImportError(f"PostgreSQL libraries need psycopg 3: {_INSTALL}") from None
    return module


# -- schema ----------------------------------------------------------------------------------------
def identify(cur, shown: str, schema: str) -> int:
    """The schema version of the library in the current schema (0: no tables), refusing foreign tables.

    Reads only. ``shown`` names the library in messages.
    """
    tables = sorted(r[0] for r in cur.execute(
        "SELECT relname FROM pg_class WHERE relnamespace = current_schema()::regnamespace "
        "AND relkind IN ('r', 'p', 'v', 'm', 'f')").fetchall())
    if not tables:
        return 0
    meta = {}
    if "meta" in tables:
        with contextlib.suppress(psycopg().Error), cur.connection.transaction():
            # a savepoint when in a transaction: a foreign 'meta' table must not abort the caller's
            meta = dict(cur.execute("SELECT key, value FROM meta WHERE key IN "
                                    "('application', 'schema_version')").fetchall())
    if meta.get("application") != APPLICATION or not str(meta.get("schema_version", "")).isdigit():
        raise ValueError(f"library {shown!r}: schema {schema!r} holds tables that are not a skillbank "
                         f"library ({', '.join(tables[:5])})")
    version = int(meta["schema_version"])
    if version > SCHEMA_VERSION:
        raise ValueError(f"library {shown!r} has schema version {version}, written by a newer skillbank; "
                         f"this one reads versions up to {SCHEMA_VERSION}")
    return version


def create_tables(cur, *, version: int = SCHEMA_VERSION) -> None:
    """Create the tables of schema ``version`` in the caller's transaction (an older one tests migrate)."""
    for sql in (*(sql for step in STEPS[:version] for sql in step), *_STORAGE):
        cur.execute(sql)
    cur.executemany("INSERT INTO meta (key, value) VALUES (%s, %s)",
                    [("application", APPLICATION), ("created", now()), ("schema_version", str(version))])


def migrate(cur, version: int) -> int:
    """Bring a library from ``version`` to SCHEMA_VERSION inside the caller's transaction (as SQLite's)."""
    if version == 1:
        for sql in _MIGRATE_1_TO_2:
            cur.execute(sql)
        pid = new_ids(cur, "provenance", 1)[0]
        cur.execute("INSERT INTO provenance (id, kind, params, created) VALUES (%s, %s, %s, %s)",
                    (pid, "segmentation", '{"unknown": true, "migrated_from_schema": 1}', now()))
        cur.execute("UPDATE demonstrations SET provenance_id = %s", (pid,))
        version = 2
    if version == 2:
        for sql in _MIGRATE_2_TO_3:
            cur.execute(sql)
        version = 3
    for sql in _STORAGE:
        cur.execute(sql)
    cur.execute("UPDATE meta SET value = %s WHERE key = 'schema_version'", (str(version),))
    return version


# -- rows ------------------------------------------------------------------------------------------
def new_ids(cur, table: str, n: int, given=None) -> list:
    """``n`` new ids of ``table`` from its counter, or the ``given`` ids with the counter moved past them.

    The counter row is updated inside the caller's transaction: a rollback
    returns the ids (no gaps), and concurrent writers queue on the row.
    """
    if given is not None:
        if given:
            cur.execute("UPDATE sequences SET last = GREATEST(last, %s) WHERE name = %s", (max(given), table))
        return list(given)
    if n == 0:
        return []
    last = cur.execute("UPDATE sequences SET last = last + %s WHERE name = %s RETURNING last",
                       (n, table)).fetchone()[0]
    return list(range(last - n + 1, last + 1))


def encode(demo, bounds, *, source, labels, provenance, created=None) -> dict:
    """A demonstration's rows, serialised before the transaction (so the write lock is held shorter).

    ``labels`` holds one label (or None) per bound; ``provenance`` is
    ``(kind, params, created)`` or None; ``created`` defaults to now.
    """
    return {"source": source, "n_steps": demo.n_steps, "t": to_npy(demo.t),
            "metadata": to_json(demo.metadata), "created": created or now(), "labels": list(labels),
            "streams": [(name, k, to_npy(arr)) for k, (name, arr) in enumerate(demo.streams.items())],
            "bounds": [(int(a), int(b)) for a, b in bounds],
            "provenance": None if provenance is None else (provenance[0], to_json(provenance[1]),
                                                           provenance[2] or now())}


_INSERTS = (
    ("provenance", "INSERT INTO provenance (id, kind, params, created) VALUES (%s, %s, %s, %s)"),
    ("demonstrations", "INSERT INTO demonstrations (id, source, n_steps, t, metadata, created, "
                       "provenance_id) VALUES (%s, %s, %s, %s, %s, %s, %s)"),
    ("streams", "INSERT INTO streams (demonstration_id, name, position, data) VALUES (%s, %s, %s, %s)"),
    ("primitives", "INSERT INTO primitives (id, demonstration_id, start, stop, label) "
                   "VALUES (%s, %s, %s, %s, %s)"),
)


def insert(cur, encoded: list, *, demo_ids=None, primitive_ids=None) -> list:
    """Insert :func:`encode`-d demonstrations with their streams, primitives and provenance.

    Ids come from the counters, or ``demo_ids`` and ``primitive_ids`` keep
    given ones. One batched statement per table. Returns
    ``[(demonstration id, [primitive ids])]``.
    """
    prov = iter(new_ids(cur, "provenance", sum(e["provenance"] is not None for e in encoded)))
    dids = new_ids(cur, "demonstrations", len(encoded), demo_ids)
    pids = iter(new_ids(cur, "primitives", sum(len(e["bounds"]) for e in encoded), primitive_ids))
    rows: dict = {table: [] for table, _ in _INSERTS}
    out = []
    for e, did in zip(encoded, dids, strict=True):
        prov_id = None
        if e["provenance"] is not None:
            prov_id = next(prov)
            rows["provenance"].append((prov_id, *e["provenance"]))
        rows["demonstrations"].append((did, e["source"], e["n_steps"], e["t"], e["metadata"], e["created"],
                                       prov_id))
        rows["streams"] += [(did, name, k, data) for name, k, data in e["streams"]]
        mine = [next(pids) for _ in e["bounds"]]
        rows["primitives"] += [(p, did, a, b, lab)
                               for p, (a, b), lab in zip(mine, e["bounds"], e["labels"], strict=True)]
        out.append((did, mine))
    for table, sql in _INSERTS:
        if rows[table]:
            cur.executemany(sql, rows[table])
    return out


def load_rows(cur, ids) -> dict:
    """Demonstrations by id, streams in their stored order; ValueError naming a missing one."""
    ids = sorted({int(i) for i in ids})
    rows = {did: (from_npy(t), from_json(meta)) for did, t, meta in cur.execute(
        "SELECT id, t, metadata FROM demonstrations WHERE id = ANY(%s)", (ids,)).fetchall()}
    streams: dict = {}
    for did, name, data in cur.execute(
            "SELECT demonstration_id, name, data FROM streams WHERE demonstration_id = ANY(%s) "
            "ORDER BY demonstration_id, position", (ids,)).fetchall():
        streams.setdefault(did, {})[name] = from_npy(data)
    missing = [i for i in ids if i not in rows]
    if missing:
        raise ValueError(f"demonstration: no demonstration with id {missing[0]} in the library")
    return {did: Demonstration(t, streams.get(did, {}), meta) for did, (t, meta) in rows.items()}


# -- transfer --------------------------------------------------------------------------------------
class PostgresRecords:
    """The records protocol of :mod:`skillbank.store._transfer` over a PostgreSQL store.

    ``store`` gives the transactions: ``store._read()`` (a snapshot) and
    ``store._write(what)`` (one transaction under the library's write lock),
    each yielding a cursor.
    """

    def __init__(self, store):
        self.store = store
        self.cur = None

    @contextlib.contextmanager
    def snapshot(self):
        with self.store._read() as self.cur:
            yield self

    @contextlib.contextmanager
    def writing(self):
        with self.store._write("import") as self.cur:
            yield self

    def counts(self) -> tuple:
        return tuple(self.cur.execute("SELECT (SELECT COUNT(*) FROM demonstrations), "
                                      "(SELECT COUNT(*) FROM cluster_versions)").fetchone())

    def demonstrations(self) -> tuple:
        cur = self.cur
        rows = cur.execute("SELECT d.id, d.source, d.created, p.kind, p.params, p.created "
                           "FROM demonstrations d LEFT JOIN provenance p ON p.id = d.provenance_id "
                           "ORDER BY d.id").fetchall()

        def records():
            for did, source, created, kind, params, p_created in rows:
                prims = cur.execute("SELECT id, start, stop, label FROM primitives "
                                    "WHERE demonstration_id = %s ORDER BY id", (did,)).fetchall()
                yield demonstration_record(did, source, created, (kind, params, p_created), prims,
                                           load_rows(cur, [did])[did])

        return len(rows), records()

    def versions(self):
        cur = self.cur
        for v, created, params, n, centers, mean, comps in cur.execute(
                "SELECT version, created, params, n_clusters, centers, pca_mean, pca_components "
                "FROM cluster_versions ORDER BY version").fetchall():
            members = cur.execute("SELECT primitive_id, cluster, features, assigned FROM cluster_members "
                                  "WHERE version = %s ORDER BY primitive_id", (v,)).fetchall()
            labels = cur.execute("SELECT cluster, label FROM cluster_labels WHERE version = %s "
                                 "ORDER BY cluster", (v,)).fetchall()
            yield version_record(v, created, params, n, (centers, mean, comps), members, labels)

    def lengths(self, n_steps):
        ids = [r[0] for r in self.cur.execute(
            "SELECT id FROM demonstrations WHERE n_steps = ANY(%s) ORDER BY id",
            (sorted({int(n) for n in n_steps}),)).fetchall()]
        for i in range(0, len(ids), _CHUNK):  # a chunk at a time: memory stays bounded on a large library
            yield load_rows(self.cur, ids[i:i + _CHUNK])

    def insert_demonstration(self, d, *, keep_id: bool) -> tuple:
        prov, prims = d["provenance"], d["primitives"]
        encoded = encode(d["demo"], [(p["start"], p["stop"]) for p in prims], source=d["source"],
                         labels=[p["label"] for p in prims], created=d["created"],
                         provenance=None if prov is None else
                         (prov["kind"], prov["params"], prov["created"]))
        [(did, pids)] = insert(self.cur, [encoded], demo_ids=[d["id"]] if keep_id else None,
                               primitive_ids=[p["id"] for p in prims] if keep_id else None)
        return did, {p["id"]: new for p, new in zip(prims, pids, strict=True)}

    def insert_version(self, v, primitives: dict) -> int:
        a, cur = v["arrays"], self.cur
        new_ids(cur, "cluster_versions", 1, [v["version"]])
        cur.execute("INSERT INTO cluster_versions (version, created, params, n_clusters, centers, "
                    "pca_mean, pca_components) VALUES (%s, %s, %s, %s, %s, %s, %s)",
                    (v["version"], v["created"], to_json(v["params"]), v["n_clusters"],
                     to_npy(a["centers"]), to_npy(a["pca_mean"]), to_npy(a["pca_components"])))
        rows = [(v["version"], primitives[int(i)], int(c), to_npy(f), s) for i, c, f, s in zip(
            a["member_ids"], a["member_clusters"], a["member_features"], a["member_assigned"], strict=True)]
        if rows:
            cur.executemany("INSERT INTO cluster_members (version, primitive_id, cluster, features, "
                            "assigned) VALUES (%s, %s, %s, %s, %s)", rows)
        if v["labels"]:
            cur.executemany("INSERT INTO cluster_labels (version, cluster, label) VALUES (%s, %s, %s)",
                            [(v["version"], int(c), lab) for c, lab in v["labels"]])
        return v["version"]

    def counters(self) -> dict:
        return dict(self.cur.execute("SELECT name, last FROM sequences WHERE name = ANY(%s)",
                                     (list(COUNTED),)).fetchall())

    def set_counters(self, counters: dict) -> None:
        self.cur.executemany("UPDATE sequences SET last = GREATEST(last, %s) WHERE name = %s",
                             [(int(counters.get(t, 0)), t) for t in COUNTED])

    def descriptions(self, *, history: bool = True) -> list:
        rows = self.cur.execute("SELECT label, revision, created, action, binding FROM skill_descriptions "
                                "ORDER BY label, revision").fetchall()
        out = [{"label": lab, "revision": int(r), "created": c, "action": a, "binding": from_json(b)}
               for lab, r, c, a, b in rows]
        return out if history else current_descriptions(out)

    def insert_descriptions(self, rows) -> None:
        rows = [(d["label"], int(d["revision"]), d["created"], d["action"], to_json(d["binding"]))
                for d in rows]
        if rows:
            self.cur.executemany("INSERT INTO skill_descriptions (label, revision, created, action, binding) "
                                 "VALUES (%s, %s, %s, %s, %s)", rows)
