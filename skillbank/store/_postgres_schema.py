"""What only the PostgreSQL backend has: the driver, schema, migrations, id counters.

Kept apart from :class:`skillbank.store.PostgresStore` (connections,
transactions, the dialect of :mod:`skillbank.store._sql`, whose SQL serves
both backends). Every statement here is a fixed string with ``%s``
parameters. psycopg itself is imported only where a connection is made
(:func:`psycopg`), so ``skillbank.store`` imports without it.
"""

from __future__ import annotations

import contextlib

from ._schema import APPLICATION, SCHEMA_VERSION, now
from ._secrets import mask_url, scrub  # URLs and passwords: here before, kept for their importers

__all__ = ["mask_url", "scrub", "psycopg", "identify", "create_tables", "migrate", "new_ids", "STEPS"]

_INSTALL = "pip install 'skillbank[postgres]'"

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

# -- the driver ------------------------------------------------------------------------------------
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


# -- id counters -----------------------------------------------------------------------------------
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
