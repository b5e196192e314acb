"""A real PostgreSQL server for the store tests, started here and stopped at the end of the session.

The server is PostgreSQL 16 from the ``pgserver`` package (the ``test`` extra
installs it), else the binaries of a system install (``pg_config --bindir``,
Debian's ``/usr/lib/postgresql/*/bin``), or those in ``$SKILLBANK_PG_BINDIR``.
It runs from a new temporary folder, listening on 127.0.0.1 (password
required) and on a Unix socket in that folder (trusted, for the fixtures'
own administration). PostgreSQL refuses to run as root, so as root (CI) it
runs as a dedicated system user, created when missing. Each test gets a fresh
database (``postgres_url``). Under CI the server must start (a failure fails
the tests); elsewhere the tests that need it are skipped, with the reason.
"""

from __future__ import annotations

import contextlib
import glob
import importlib.util
import os
import secrets
import shutil
import socket
import stat
import subprocess
import tempfile
from pathlib import Path

import pytest

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
