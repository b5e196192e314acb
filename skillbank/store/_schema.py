"""The SQLite schema of a library file: creation, version checks and migration.

The schema version is SQLite's ``PRAGMA user_version``; ``meta`` holds
``application = skillbank``. Version 1 (the first released layout) lacked
segmentation provenance and did not record how a primitive joined its cluster;
version 2 had no skill descriptions (the PDDL action schema and binding a
label carries for ``skillbank plan``). :func:`migrate` brings either to
version 3.

A file is identified (version, tables, ``meta``) before anything is written to
it, so a foreign SQLite file is refused exactly as it was found. A read-only
connection (:func:`connect` with ``readonly=True``) writes nothing at all: it
opens the file with SQLite's ``mode=ro``, and where the folder cannot be
written (so WAL's ``-shm`` index cannot be created) and no ``-wal`` file holds
changes, also ``immutable=1``, which reads the file without the index.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
import stat
import time
from datetime import datetime, timezone
from pathlib import Path

__all__ = ["SCHEMA_VERSION", "connect", "transaction", "now", "database_errors"]

SCHEMA_VERSION = 3
APPLICATION = "skillbank"
_SQLITE_MAGIC = b"SQLite format 3\x00"

_TABLES_V1 = (
    "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
    "CREATE TABLE demonstrations (id INTEGER PRIMARY KEY AUTOINCREMENT, source TEXT, "
    "n_steps INTEGER NOT NULL, t BLOB NOT NULL, metadata TEXT NOT NULL, created TEXT NOT NULL)",
    "CREATE TABLE streams (demonstration_id INTEGER NOT NULL REFERENCES demonstrations(id) "
    "ON DELETE CASCADE, name TEXT NOT NULL, position INTEGER NOT NULL, data BLOB NOT NULL, "
    "PRIMARY KEY (demonstration_id, name))",
    "CREATE TABLE primitives (id INTEGER PRIMARY KEY AUTOINCREMENT, demonstration_id INTEGER NOT NULL "
    "REFERENCES demonstrations(id) ON DELETE CASCADE, start INTEGER NOT NULL, stop INTEGER NOT NULL, "
    "label TEXT)",
    "CREATE TABLE cluster_versions (version INTEGER PRIMARY KEY AUTOINCREMENT, created TEXT NOT NULL, "
    "params TEXT NOT NULL, n_clusters INTEGER NOT NULL, centers BLOB NOT NULL, pca_mean BLOB NOT NULL, "
    "pca_components BLOB NOT NULL)",
    "CREATE TABLE cluster_members (version INTEGER NOT NULL REFERENCES cluster_versions(version) "
    "ON DELETE CASCADE, primitive_id INTEGER NOT NULL REFERENCES primitives(id) ON DELETE CASCADE, "
    "cluster INTEGER NOT NULL, features BLOB NOT NULL, PRIMARY KEY (version, primitive_id))",
    "CREATE TABLE cluster_labels (version INTEGER NOT NULL REFERENCES cluster_versions(version) "
    "ON DELETE CASCADE, cluster INTEGER NOT NULL, label TEXT NOT NULL, PRIMARY KEY (version, cluster))",
    "CREATE INDEX primitives_demo ON primitives(demonstration_id)",
    "CREATE INDEX members_primitive ON cluster_members(primitive_id)",
)

# Version 1 -> 2: provenance of the segmentation, and how each member joined its cluster.
_MIGRATE_1_TO_2 = (
    "CREATE TABLE provenance (id INTEGER PRIMARY KEY AUTOINCREMENT, kind TEXT NOT NULL, "
    "params TEXT NOT NULL, created TEXT NOT NULL)",
    "ALTER TABLE demonstrations ADD COLUMN provenance_id INTEGER REFERENCES provenance(id)",
    "ALTER TABLE cluster_members ADD COLUMN assigned TEXT NOT NULL DEFAULT 'fit'",
)

# Version 2 -> 3: skill descriptions, kept per label as numbered revisions (the highest is current;
# a NULL action removes the description), so a description is versioned and survives reclustering
# as its label does.
_MIGRATE_2_TO_3 = (
    "CREATE TABLE skill_descriptions (label TEXT NOT NULL, revision INTEGER NOT NULL, created TEXT NOT NULL, "
    "action TEXT, binding TEXT NOT NULL, PRIMARY KEY (label, revision))",
)


def now() -> str:
    """UTC time stamp in ISO 8601."""
    return datetime.now(timezone.utc).isoformat(timespec="microseconds")


@contextlib.contextmanager
def database_errors(path):
    """Turn SQLite's corruption and format errors into a one-line ValueError."""
    try:
        yield
    except sqlite3.OperationalError as exc:
        if "locked" in str(exc) or "busy" in str(exc):
            raise
        if "readonly" in str(exc):
            raise ValueError(f"library {str(path)!r} cannot be changed: it is read-only here ({exc})"
                             ) from None
        raise ValueError(f"library {str(path)!r}: {exc}") from None
    except sqlite3.DatabaseError as exc:
        raise ValueError(f"library {str(path)!r} is not a readable skillbank library: {exc}") from None


@contextlib.contextmanager
def transaction(conn, *, write: bool = True):
    """``BEGIN IMMEDIATE`` (``BEGIN`` for a read) ... ``COMMIT``; rolled back on any exception.

    Taking the write lock up front lets SQLite's busy timeout queue
    concurrent writers instead of failing one with "database is locked". A
    read transaction sees one consistent state (WAL mode) while others write.
    """
    conn.execute("BEGIN IMMEDIATE" if write else "BEGIN")
    try:
        yield conn
    except BaseException:
        conn.execute("ROLLBACK")
        raise
    conn.execute("COMMIT")


def check_library_file(path) -> None:
    """Refuse a library path that exists and is not a regular file (or a link to one), without opening it.

    The one check every SQLite library goes through (:func:`connect`): a FIFO would block SQLite's
    open or fail deep inside it (``disk I/O error``), a device would be read or written as a database.

    Examples
    --------
    >>> check_library_file("/dev/null")
    Traceback (most recent call last):
    ...
    ValueError: library '/dev/null': expected a regular file (a SQLite library), got a character device; \
give the path of a library file
    """
    from ..io._errors import kind_of  # the words for a file's kind, shared with the readers

    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return
    except OSError as exc:
        raise ValueError(f"library {str(path)!r}: cannot inspect it: {exc.strerror or exc}") from None
    if not stat.S_ISREG(mode):
        raise ValueError(f"library {str(path)!r}: expected a regular file (a SQLite library), got "
                         f"{kind_of(mode)}; give the path of a library file")


def _check_header(path: Path) -> None:
    check_library_file(path)
    if not path.exists() or path.stat().st_size == 0:
        return
    with open(path, "rb") as fh:
        head = fh.read(len(_SQLITE_MAGIC))
    if head != _SQLITE_MAGIC:
        raise ValueError(f"library {str(path)!r} is not a SQLite file (header {head[:16]!r})")


def _wal(conn) -> None:
    # Switching to WAL needs a moment of exclusive access; retry while another opener holds it.
    for attempt in range(200):
        try:
            mode = conn.execute("PRAGMA journal_mode=WAL").fetchone()[0]
            break
        except sqlite3.OperationalError as exc:
            if "locked" not in str(exc) or attempt == 199:
                raise
            time.sleep(0.05)
    if str(mode).lower() != "wal":
        raise ValueError(f"journal_mode: expected WAL, SQLite reports {mode!r}")


def _create(conn) -> None:
    for sql in _TABLES_V1 + _MIGRATE_1_TO_2 + _MIGRATE_2_TO_3:
        conn.execute(sql)
    conn.execute("INSERT INTO meta (key, value) VALUES (?, ?)", ("application", APPLICATION))
    conn.execute("INSERT INTO meta (key, value) VALUES (?, ?)", ("created", now()))
    conn.execute(f"PRAGMA user_version = {int(SCHEMA_VERSION)}")


def migrate(conn, version: int) -> int:
    """Bring a library from ``version`` to :data:`SCHEMA_VERSION` inside the caller's transaction."""
    if version == 1:
        for sql in _MIGRATE_1_TO_2:
            conn.execute(sql)
        conn.execute("INSERT INTO provenance (kind, params, created) VALUES (?, ?, ?)",
                     ("segmentation", '{"unknown": true, "migrated_from_schema": 1}', now()))
        pid = conn.execute("SELECT last_insert_rowid()").fetchone()[0]
        conn.execute("UPDATE demonstrations SET provenance_id = ?", (pid,))
        version = 2
    if version == 2:
        for sql in _MIGRATE_2_TO_3:
            conn.execute(sql)
        version = 3
    conn.execute(f"PRAGMA user_version = {int(version)}")
    return version


def _tables(conn) -> set:
    return {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}


def _identify(conn, path) -> int:
    """The schema version of the file, after checking that it is a skillbank library (or empty).

    Reads only: a foreign file is refused before anything is written to it.
    """
    version = conn.execute("PRAGMA user_version").fetchone()[0]
    if version > SCHEMA_VERSION:
        raise ValueError(f"library {str(path)!r} has schema version {version}, written by a newer skillbank; "
                         f"this one reads versions up to {SCHEMA_VERSION}")
    tables = _tables(conn) - {"sqlite_sequence"}
    if version == 0 and not tables:
        return 0
    app = None
    if version > 0 and "meta" in tables:
        app = conn.execute("SELECT value FROM meta WHERE key = ?", ("application",)).fetchone()
    if app is None or app[0] != APPLICATION:
        raise ValueError(f"library {str(path)!r} is a SQLite file but not a skillbank library "
                         f"(tables {sorted(tables)[:5]})")
    return version


def _prepare(conn, path) -> int:
    version = conn.execute("PRAGMA user_version").fetchone()[0]
    if version == SCHEMA_VERSION:
        return version
    with transaction(conn):
        version = _identify(conn, path)  # again, under the write lock: another process may have won
        if version == 0:
            _create(conn)
        elif version < SCHEMA_VERSION:
            migrate(conn, version)
    return version


def _folder_writable(folder) -> bool:
    """Whether this process may create files in ``folder`` (WAL's side files live there)."""
    return os.access(folder, os.W_OK | os.X_OK)


def _open_readonly(path: Path, timeout: float) -> sqlite3.Connection:
    # mode=ro never writes the library. In WAL mode a reader also needs the -shm index: SQLite
    # creates it when the folder is writable; where it is not, immutable=1 reads the file
    # without it, which is right as long as no -wal file holds changes not yet in the file.
    # When one does (a writer has the library open), that writer's -shm exists and mode=ro
    # reads through it.
    wal = path.with_name(path.name + "-wal")
    immutable = not _folder_writable(path.parent) and not (wal.exists() and wal.stat().st_size > 0)
    uri = path.resolve().as_uri() + ("?mode=ro&immutable=1" if immutable else "?mode=ro")
    return sqlite3.connect(uri, uri=True, timeout=timeout, isolation_level=None)


def _check_writable(path: Path) -> None:
    file_ok = not path.exists() or os.access(path, os.W_OK)
    if not (file_ok and _folder_writable(path.parent)):
        raise ValueError(f"library {str(path)!r} is read-only here (its file or its folder is not writable): "
                         "it cannot be changed; 'library list', 'reuse' and 'export' can read it")


def connect(path, *, timeout: float = 60.0, create: bool = True,
            readonly: bool = False) -> sqlite3.Connection:
    """Open (and create or migrate) the library file at ``path``.

    Parameters
    ----------
    path : path-like
    timeout : float
        Seconds a writer waits for the write lock.
    create : bool
        Create the library when the file does not exist.
    readonly : bool
        Open without writing anything (no creation, migration or WAL switch;
        see the module docstring).

    Raises
    ------
    ValueError
        A one-line message for a file that is not SQLite, is corrupt, is not a
        skillbank library, or has a newer schema version; for a read-only
        opening, also for a missing or empty file or one that needs migrating.
    """
    path = Path(path)
    _check_header(path)
    if (readonly or not create) and not path.exists():
        raise ValueError(f"library {str(path)!r} does not exist; create it with 'skillbank library init'")
    if not path.parent.exists():
        raise ValueError(f"library {str(path)!r}: folder {str(path.parent)!r} does not exist")
    if readonly and path.stat().st_size == 0:
        raise ValueError(f"library {str(path)!r} is empty, not a skillbank library")
    if readonly:
        conn = _open_readonly(path, timeout)
    else:
        _check_writable(path)
        conn = sqlite3.connect(str(path), timeout=timeout, isolation_level=None)
    try:
        with database_errors(path):
            conn.execute("PRAGMA foreign_keys = ON")
            version = _identify(conn, path)
            if readonly:
                if version < SCHEMA_VERSION:
                    raise ValueError(f"library {str(path)!r} has schema version {version}; open it once "
                                     f"read-write (any 'skillbank library' command that writes, or "
                                     f"'library init') to migrate it to version {SCHEMA_VERSION}")
            else:
                _wal(conn)
                _prepare(conn, path)
    except BaseException:
        conn.close()
        raise
    return conn
