"""The embedded backend: one SQLite file in WAL mode."""

from __future__ import annotations

import contextlib
from pathlib import Path

from ._schema import connect, database_errors, transaction
from ._sql import SQLStore

__all__ = ["SQLiteStore"]

# The last id AUTOINCREMENT has handed out in each table with a counter: the larger of the table's
# sqlite_sequence row (absent before its first row) and its largest id, as SQLite itself takes it.
_LAST_ID = {table: f"SELECT MAX(COALESCE((SELECT seq FROM sqlite_sequence WHERE name = '{table}'), 0), "
                   f"COALESCE(MAX({key}), 0)) FROM {table}"  # noqa: S608 - fixed names, no values
            for table, key in (("demonstrations", "id"), ("primitives", "id"), ("provenance", "id"),
                               ("cluster_versions", "version"))}


class SQLiteStore(SQLStore):
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

    def check(self) -> str:
        with self._errors():
            return "; ".join(r[0] for r in self.conn.execute("PRAGMA integrity_check"))

    # -- the dialect of skillbank.store._sql ------------------------------------------------------
    def _errors(self):
        return database_errors(self.path)

    def _transaction(self, write: bool):
        # a write takes the lock up front (BEGIN IMMEDIATE), so the busy timeout queues writers
        return transaction(self.conn, write=write)

    def _statement(self):
        return contextlib.nullcontext(self.conn)

    def _new_ids(self, db, table, n, given=None) -> list:
        # An inserted id advances sqlite_sequence exactly as one AUTOINCREMENT chose would, so given ids
        # need no bookkeeping, and new ones continue where AUTOINCREMENT would (the write lock is held).
        if given is not None:
            return list(given)
        if n == 0:
            return []
        last = db.execute(_LAST_ID[table]).fetchone()[0]
        return list(range(last + 1, last + n + 1))

    def _counters(self, db) -> dict:
        return dict(db.execute("SELECT name, seq FROM sqlite_sequence").fetchall())

    def _set_counters(self, db, counters: dict) -> None:
        for table, last in counters.items():
            if db.execute("UPDATE sqlite_sequence SET seq = MAX(seq, ?) WHERE name = ?",
                          (last, table)).rowcount == 0 and last:
                db.execute("INSERT INTO sqlite_sequence (name, seq) VALUES (?, ?)", (table, last))
