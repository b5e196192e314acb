"""The shared backend: a skill library in a PostgreSQL database, written by many processes and machines.

Any libpq connection URL opens it (``postgresql://`` or ``postgres://``, with
query parameters such as a Unix-socket ``?host=/path``, ``sslmode`` or
``options=-csearch_path%3Dlab``: the tables live in the connection's current
schema). The password comes from the URL, ``PGPASSWORD`` or ``~/.pgpass``
(libpq reads them) and is never shown: :attr:`PostgresStore.location` and
every message give the URL with it masked (:func:`mask_url`).

The schema has the SQLite store's version (:data:`~skillbank.store.SCHEMA_VERSION`,
kept in ``meta``), tables and migrations (:mod:`skillbank.store._postgres_schema`);
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

from ..core._validation import check_positive
from ._postgres_schema import create_tables, identify, migrate, new_ids, psycopg
from ._schema import SCHEMA_VERSION
from ._secrets import check_url, mask_url, scrub, secrets
from ._sql import SQLStore

__all__ = ["PostgresStore", "mask_url"]

def _scrub_chain(exc, url: str) -> None:
    """Scrub the password of ``url`` from the text of ``exc`` and of every exception it chains."""
    words = secrets(url)
    seen = set()
    while exc is not None and id(exc) not in seen and words:
        seen.add(id(exc))
        with contextlib.suppress(AttributeError, TypeError):  # an exception whose args are read-only
            exc.args = tuple(scrub(a, url) if isinstance(a, str) else a for a in exc.args)
        exc = exc.__cause__ or exc.__context__


_LOCK = 0x736B6C62  # high half of the library's advisory lock key ("sklb"); the low half is its schema's oid


class PostgresStore(SQLStore):
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
    marker = "%s"

    def __init__(self, url, *, create: bool = True, timeout: float = 60.0, readonly: bool = False):
        self._url = check_url(url)  # refused, masked, when libpq would read another password than written
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

    def _failure(self, what: str, exc) -> ValueError:
        """One line naming the library and what failed, the driver's words with the password scrubbed.

        The driver's exception (and any it chains) is scrubbed too: it stays the new one's ``__context__``.
        """
        _scrub_chain(exc, self._url)
        text = scrub(str(exc), self._url) or type(exc).__name__
        if "does not exist" in text and "database" in text:
            text += " (create it with 'createdb' or CREATE DATABASE)"
        elif "password authentication failed" in text or "no password supplied" in text:
            text += " (the password comes from the URL, PGPASSWORD or ~/.pgpass)"
        return ValueError(f"library {self.location!r}: {what}: {text}")

    def _connect(self):
        pg = psycopg()
        # Failures are raised outside the except clauses, so they chain no driver exception at all.
        failure = None
        try:
            params = pg.conninfo.conninfo_to_dict(self._url)
        except pg.Error as exc:
            failure = self._failure("expected a URL postgresql://[user@][host][:port][/dbname][?param=value]",
                                    exc)
        if failure is not None:
            raise failure
        # A silent network should not hang a command; lab admins see who is connected.
        options = {k: v for k, v in (("connect_timeout", 10), ("application_name", "skillbank"))
                   if k not in params}
        try:
            return pg.connect(self._url, autocommit=True, **options)
        except pg.Error as exc:
            failure = self._failure("cannot connect", exc)
        raise failure

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
        with self._transaction(write=True) as cur:
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

    # -- the dialect of skillbank.store._sql ------------------------------------------------------
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
    def _transaction(self, write: bool):
        """A write holds the library's advisory lock (writers serialised); a read is one REPEATABLE READ,
        READ ONLY snapshot. Yields a cursor."""
        conn = self.conn
        with conn.transaction(), conn.cursor(binary=True) as cur:  # arrays as raw bytes: 8x bytea's hex text
            if write:
                cur.execute("SELECT pg_advisory_xact_lock(%s)", (self._key,))
            else:
                cur.execute("SET TRANSACTION ISOLATION LEVEL REPEATABLE READ, READ ONLY")
            yield cur

    def _statement(self):
        return self.conn.cursor(binary=True)

    def _new_ids(self, db, table, n, given=None) -> list:
        return new_ids(db.raw, table, n, given)

    def _counters(self, db) -> dict:
        return dict(db.raw.execute("SELECT name, last FROM sequences").fetchall())

    def _set_counters(self, db, counters: dict) -> None:
        db.raw.executemany("UPDATE sequences SET last = GREATEST(last, %s) WHERE name = %s",
                           [(last, table) for table, last in counters.items()])
