"""Shared fixtures.

Real data is found through one fixture, ``data_dir``. Library tests get their
library through one fixture, ``new_library``, parametrised over the store
backends: every test that takes it runs once on SQLite and once on a real
PostgreSQL 16 server that this file starts (see :class:`LocalPostgres`).

The PostgreSQL server is PostgreSQL 16 from the ``pgserver`` package (the ``test`` extra
installs it), else the binaries of a system install (``pg_config --bindir``,
Debian's ``/usr/lib/postgresql/*/bin``), or those in ``$SKILLBANK_PG_BINDIR``.
It runs from a new temporary folder, listening on 127.0.0.1 (password
required) and on a Unix socket in that folder (trusted, for the fixtures'
own administration). PostgreSQL refuses to run as root, so as root (CI) it
runs as a dedicated system user, created when missing. Each test gets a fresh
database. Under CI the server must start (a failure fails the tests);
elsewhere the tests that need it are skipped, with the reason.
"""

from __future__ import annotations

import contextlib
import glob
import importlib.util
import os
import secrets
import shutil
import socket
import sqlite3
import stat
import subprocess
import tempfile
from pathlib import Path

import pytest
from hypothesis import settings

from skillbank.cli import _main

# Properties are deterministic in CI: the same examples on every run (derandomised) and no example
# database carried between runs, so a property fails in a developer's run, where each run draws new
# examples, rather than by chance in CI. SKILLBANK_HYPOTHESIS=ci selects it anywhere.
settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
settings.register_profile("dev", print_blob=True)
settings.load_profile(os.environ.get("SKILLBANK_HYPOTHESIS") or ("ci" if os.environ.get("CI") else "dev"))

_DEFAULT = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


def _data_root() -> Path:
    env = os.environ.get("SKILLBANK_DATA")
    return Path(env) if env else _DEFAULT.resolve()


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The shared data folder: ``$SKILLBANK_DATA``, else ``../shared/data``.

    Skips when absent, but fails under CI, where the data must be present.
    """
    root = _data_root()
    if not (root / "seed").is_dir():
        # one line: what is missing, where it looked and why there, and what to set
        where = "$SKILLBANK_DATA" if os.environ.get("SKILLBANK_DATA") else "the default, beside the clone"
        message = (f"needs the real data: no seed/ in {root} ({where}); "
                   "export SKILLBANK_DATA=/path/to/shared/data (the folder with seed/ and rail/)")
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    return root


#: What a command may take when it is run by :func:`run_limited` (address space, bytes).
LIMITED_MEMORY = 1 << 30


def run_limited(*argv, memory: int = LIMITED_MEMORY, timeout: float = 120.0, cwd=None, env=None):
    """``(exit status, stdout, stderr)`` of ``skillbank argv...`` in a child process under a memory limit.

    The child's address space is capped at ``memory`` bytes (``RLIMIT_AS``) and
    it is killed after ``timeout`` seconds, so an input that would take
    gigabytes or hang fails the test instead of the machine: a bound that is
    checked before the work starts gives exit status 2 and one line well
    within the limit. BLAS runs one thread (its per-thread buffers would count
    against the limit).
    """
    import resource  # POSIX only, like the limit itself
    import sys

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))

    root = str(Path(__file__).resolve().parents[1])  # this checkout's package, wherever cwd is
    path = os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")]))
    child_env = {**os.environ, "PYTHONPATH": path, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
                 "MKL_NUM_THREADS": "1", "PYTHONWARNINGS": "ignore", **(env or {})}
    done = subprocess.run([sys.executable, "-m", "skillbank.cli", *map(str, argv)], cwd=cwd,
                          env=child_env, preexec_fn=limit, capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL)
    return done.returncode, done.stdout, done.stderr


@pytest.fixture
def limited():
    """:func:`run_limited` as a fixture: ``limited(*argv, memory=..., timeout=...)``."""
    return run_limited


@pytest.fixture
def cli(capsys):
    """``cli(*argv) -> (exit status, stdout, stderr)`` of ``skillbank argv...`` (the real entry point)."""

    def call(*argv):
        capsys.readouterr()
        code = _main.main([str(a) for a in argv])
        out, err = capsys.readouterr()
        return code, out, err

    return call


def _rows(path) -> dict:
    conn = sqlite3.connect(path)
    try:
        tables = [r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table' "
                                             "ORDER BY name")]
        return {t: conn.execute(f'SELECT * FROM "{t}" ORDER BY rowid').fetchall() for t in tables}  # noqa: S608
    finally:
        conn.close()


@pytest.fixture(scope="session")
def table_rows():
    """``table_rows(path)``: every row of every table of a SQLite file; equal means nothing changed."""
    return _rows


# -- PostgreSQL ---------------------------------------------------------------------------------
SYSTEM_USER = "skillbank-pg"  # runs the server when the tests run as root
ROLE = "skillbank"


def _bindir() -> Path:
    """Where initdb, pg_ctl and postgres are: $SKILLBANK_PG_BINDIR, pgserver's, or a system install's."""
    candidates = [os.environ.get("SKILLBANK_PG_BINDIR")]
    spec = importlib.util.find_spec("pgserver")
    if spec is not None and spec.submodule_search_locations:
        candidates += [str(Path(p) / "pginstall" / "bin") for p in spec.submodule_search_locations]
    with contextlib.suppress(OSError, subprocess.SubprocessError):
        candidates.append(subprocess.run(["pg_config", "--bindir"], capture_output=True, text=True,
                                         check=True, timeout=10).stdout.strip())
    candidates += sorted(glob.glob("/usr/lib/postgresql/*/bin"), reverse=True)
    for folder in filter(None, candidates):
        if all((Path(folder) / exe).is_file() for exe in ("initdb", "pg_ctl", "postgres")):
            return Path(folder)
    raise RuntimeError("no PostgreSQL binaries found: install the test extra (pip install -e '.[test]', "
                       "which brings pgserver) or set SKILLBANK_PG_BINDIR")


def _reachable_by_all(folder: Path) -> bool:
    """Whether any user may reach ``folder`` (every folder above it searchable by others)."""
    return all(p.stat().st_mode & stat.S_IXOTH for p in (folder, *folder.parents))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class LocalPostgres:
    """A throwaway PostgreSQL server in a temporary folder (see the module docstring)."""

    def __init__(self):
        self.bindir = _bindir()
        self.password = secrets.token_urlsafe(16)
        self.folder = Path(tempfile.mkdtemp(prefix="skillbank-pg-"))  # /tmp: reachable by the server's user
        self.data = self.folder / "data"
        self.log = self.folder / "server.log"
        self.port = None
        self.user = None
        if os.geteuid() == 0:
            self.user = SYSTEM_USER
            self._ensure_user()
            shutil.chown(self.folder, SYSTEM_USER)
            os.chmod(self.folder, 0o755)  # the installation copied below must be reachable; the data is 0700
            if not _reachable_by_all(self.bindir):  # e.g. a checkout under /root: run a copy of it
                self.bindir = self._copy_installation()

    def _copy_installation(self) -> Path:
        """A copy of the installation in this folder, laid out as pgserver's wheel is: its binaries find
        their libraries at ``$ORIGIN/../../../pgserver.libs``."""
        root = self.bindir.parent
        shutil.copytree(root, self.folder / "pg" / "pkg" / root.name, symlinks=True)
        for libs in root.parent.parent.glob("*.libs"):
            shutil.copytree(libs, self.folder / "pg" / libs.name, symlinks=True)
        return self.folder / "pg" / "pkg" / root.name / self.bindir.name

    @staticmethod
    def _ensure_user() -> None:
        import pwd  # POSIX only, and only as root

        try:
            pwd.getpwnam(SYSTEM_USER)
        except KeyError:
            useradd = shutil.which("useradd") or "/usr/sbin/useradd"
            subprocess.run([useradd, "--system", "--no-create-home", "--home-dir", "/nonexistent", "--shell",
                            "/usr/sbin/nologin", SYSTEM_USER], check=True, capture_output=True)

    def _run(self, exe: str, *args, timeout=60):
        options = {"user": self.user} if self.user else {}
        done = subprocess.run([str(self.bindir / exe), *map(str, args)], capture_output=True, text=True,
                              timeout=timeout, cwd=self.folder, check=False, **options)
        if done.returncode != 0:
            log = self.log.read_text()[-2000:] if self.log.exists() else ""
            raise RuntimeError(f"{exe} failed ({done.returncode}): {done.stderr.strip()[-2000:]} {log}")
        return done

    def start(self) -> LocalPostgres:
        pwfile = self.folder / "pw"
        pwfile.touch(mode=0o600)
        pwfile.write_text(self.password + "\n")
        if self.user:
            shutil.chown(pwfile, self.user)
        try:
            self._run("initdb", "-D", self.data, "-U", ROLE, "--pwfile", pwfile, "-E", "UTF8",
                      "--auth-local=trust", "--auth-host=scram-sha-256", "--no-locale", "--no-sync",
                      "--no-instructions")
        finally:
            pwfile.unlink()
        for attempt in range(3):  # another process may take the free port first
            self.port = _free_port()
            try:
                self._run("pg_ctl", "-D", self.data, "-l", self.log, "-w", "-t", "60", "-o",
                          f"-h 127.0.0.1 -p {self.port} -k {self.folder} -c fsync=off "
                          "-c synchronous_commit=off -c full_page_writes=off -c max_connections=60",
                          "start", timeout=90)
                return self
            except RuntimeError:
                if attempt == 2:
                    raise
        return self

    def stop(self) -> None:
        with contextlib.suppress(RuntimeError, OSError, subprocess.SubprocessError):
            self._run("pg_ctl", "-D", self.data, "-w", "-m", "fast", "stop")
        shutil.rmtree(self.folder, ignore_errors=True)

    def url(self, dbname: str, *, password: str | None = None, **query) -> str:
        """A TCP URL of ``dbname`` with the role's password (or ``password``; "" for none)."""
        secret = self.password if password is None else password
        user = f"{ROLE}:{secret}" if secret else ROLE
        tail = "&".join(f"{k}={v}" for k, v in query.items())
        return f"postgresql://{user}@127.0.0.1:{self.port}/{dbname}" + (f"?{tail}" if tail else "")

    def socket_url(self, dbname: str) -> str:
        """A Unix-socket URL of ``dbname`` (``?host=/folder``): no password needed."""
        return f"postgresql://{ROLE}@/{dbname}?host={self.folder}&port={self.port}"

    def admin(self, dbname: str = "postgres"):
        import psycopg  # the test extra's

        return psycopg.connect(self.socket_url(dbname), autocommit=True)

    def create_database(self, name: str) -> None:
        with self.admin() as conn:
            conn.execute(f'CREATE DATABASE "{name}" STRATEGY FILE_COPY')  # faster than WAL_LOG here

    def drop_database(self, name: str) -> None:
        with self.admin() as conn:
            conn.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


@pytest.fixture(scope="session")
def postgres_server():
    """The session's PostgreSQL server (:class:`LocalPostgres`); fails under CI if it cannot start."""
    server = None
    try:
        if importlib.util.find_spec("psycopg") is None:
            raise RuntimeError("psycopg is not installed (pip install -e '.[test]')")
        server = LocalPostgres()
        server.start()
    except (RuntimeError, OSError, subprocess.SubprocessError) as exc:
        if server is not None:
            server.stop()
        message = f"cannot start a PostgreSQL server for the tests: {' '.join(str(exc).split())[:800]}"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    yield server
    server.stop()


@pytest.fixture
def postgres_url(postgres_server):
    """A URL (TCP, with password) of a new empty database, dropped after the test."""
    name = f"t_{secrets.token_hex(6)}"
    postgres_server.create_database(name)
    yield postgres_server.url(name)
    postgres_server.drop_database(name)


# -- one library fixture for every backend --------------------------------------------------------
BACKENDS = ("sqlite", "postgresql")


@pytest.fixture(params=BACKENDS)
def backend(request) -> str:
    """The store backend of a library test: each test that uses it runs once per backend."""
    return request.param


@pytest.fixture
def new_library(request, backend, tmp_path):
    """``new_library(name="lib")``: the location of a new, empty library on the test's ``backend``.

    A SQLite file in the test's folder, or a URL (TCP, with password) of a new
    database on the session's PostgreSQL server, dropped after the test.
    """
    made = []
    server = request.getfixturevalue("postgres_server") if backend == "postgresql" else None

    def new(name: str = "lib"):
        if server is None:
            return tmp_path / f"{name}.db"
        db = f"t_{name}_{secrets.token_hex(5)}".lower()
        server.create_database(db)
        made.append(db)
        return server.url(db)

    yield new
    for db in made:
        server.drop_database(db)


# The same SELECTs on both databases: every row that makes up a library.
_CONTENT = {
    "demonstrations": "SELECT d.id, d.source, d.n_steps, d.t, d.metadata, d.created, p.kind, p.params, "
                      "p.created FROM demonstrations d LEFT JOIN provenance p ON p.id = d.provenance_id "
                      "ORDER BY d.id",
    "streams": "SELECT demonstration_id, name, position, data FROM streams "
               "ORDER BY demonstration_id, position",
    "primitives": "SELECT id, demonstration_id, start, stop, label FROM primitives ORDER BY id",
    "cluster_versions": "SELECT version, created, params, n_clusters, centers, pca_mean, pca_components "
                        "FROM cluster_versions ORDER BY version",
    "cluster_members": "SELECT version, primitive_id, cluster, features, assigned FROM cluster_members "
                       "ORDER BY version, primitive_id",
    "cluster_labels": "SELECT version, cluster, label FROM cluster_labels ORDER BY version, cluster",
    "skill_descriptions": "SELECT label, revision, created, action, binding FROM skill_descriptions "
                          "ORDER BY label, revision",
}
_COUNTERS = {"sqlite": "SELECT name, seq FROM sqlite_sequence WHERE name IN ('demonstrations', 'primitives', "
                       "'cluster_versions') ORDER BY name",
             "postgresql": "SELECT name, last FROM sequences WHERE name IN ('demonstrations', 'primitives', "
                           "'cluster_versions') ORDER BY name"}


def _content(location) -> dict:
    """Every row that makes up the library at ``location`` (a SQLite path or a PostgreSQL URL), read
    with the database's own driver, not through skillbank; plus the id counters."""
    if str(location).startswith(("postgresql://", "postgres://")):
        import psycopg  # the test extra's

        conn, kind = psycopg.connect(str(location)), "postgresql"
    else:
        conn, kind = sqlite3.connect(location), "sqlite"
    try:
        out = {name: [tuple(bytes(v) if isinstance(v, memoryview) else v for v in row)
                      for row in conn.execute(sql).fetchall()] for name, sql in _CONTENT.items()}
        out["counters"] = [tuple(r) for r in conn.execute(_COUNTERS[kind]).fetchall()]
    finally:
        conn.close()
    return out


@pytest.fixture(scope="session")
def library_content():
    """``library_content(location)``: every row of a library on either backend; equal means identical."""
    return _content


def count_rows(lib, table: str) -> int:
    """Rows of ``table`` in ``lib``'s store, on either backend (``table`` is the test's own constant)."""
    return lib.store.conn.execute(f"SELECT COUNT(*) FROM {table}").fetchone()[0]  # noqa: S608


@pytest.fixture(scope="session")
def table_count():
    """``table_count(lib, table)``: how many rows ``table`` of ``lib``'s store holds (either backend)."""
    return count_rows
