"""A parallel add's workers and scheduler are checked before any process starts (issue 23, items 4, 8)."""

from __future__ import annotations

import socket
import threading
import time

import pytest

from skillbank.cli._main import main
from skillbank.core._cluster_address import (
    WORKERS_PER_CORE,
    check_scheduler,
    check_workers,
    max_workers,
    probe_scheduler,
)

from .test_parallel import check_clean, write_files


class _Peer:
    """A TCP server on loopback that accepts and then does ``behaviour(conn)``."""

    def __init__(self, behaviour):
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        self.behaviour, self.conns = behaviour, []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            self.behaviour(conn)

    def close(self):
        self.sock.close()
        for conn in self.conns:
            conn.close()


@pytest.fixture
def peer():
    made = []

    def make(behaviour):
        made.append(_Peer(behaviour))
        return made[-1]

    yield make
    for p in made:
        p.close()


def _web_server(conn):
    conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")


def _silent(conn):
    pass  # accepts and says nothing, like a port behind a firewall that completes the handshake


@pytest.mark.parametrize("address, expected", [
    ("tcp://10.0.0.5:8786", ("tcp", "10.0.0.5", 8786)),
    ("10.0.0.5:8786", ("tcp", "10.0.0.5", 8786)),
    ("TLS://sched.lab:8786", ("tls", "sched.lab", 8786)),
    ("tcp://[::1]:8786", ("tcp", "::1", 8786)),
    ("inproc://10.0.0.5/1234/1", ("inproc", None, None)),
])
def test_scheduler_addresses_are_parsed(address, expected):
    assert check_scheduler(address) == expected


@pytest.mark.parametrize("address, message", [
    ("http://127.0.0.1:8787", r"is a web address \(the dashboard's, usually port 8787\); give the"),
    ("https://dask.lab/status", r"is a web address"),
    ("ftp://h:1", r"unknown transport ftp:// in ftp://h:1 \(Dask's are tcp://, tls://"),
    ("tcp://h", r"expected tcp://HOST:PORT with a port from 1 to 65535, got tcp://h"),
    ("tcp://h:0", r"a port from 1 to 65535"),
    ("tcp://h:99999", r"a port from 1 to 65535"),
    ("tcp://:8786", r"expected tcp://HOST:PORT"),
    ("tcp://h:1\nx", r"expected tcp://HOST:PORT .*'tcp://h:1\\nx'"),
])
def test_bad_scheduler_addresses_are_one_line(address, message):
    with pytest.raises(ValueError, match=rf"^scheduler: .*{message}"):
        check_scheduler(address)


def test_a_web_server_is_not_taken_for_a_scheduler(peer):
    # Dask's client read "HTTP/1.1" as a message length of 3.5e18 bytes and tried to allocate it
    web = peer(_web_server)
    with pytest.raises(OSError, match=r"does not speak Dask's protocol \(it sent 'HTTP/1.1'\): give"):
        probe_scheduler(f"tcp://127.0.0.1:{web.port}", timeout=5)


def test_a_silent_peer_fails_within_the_timeout(peer):
    quiet = peer(_silent)
    start = time.monotonic()
    with pytest.raises(OSError, match=r"accepted the connection but sent no Dask handshake within 0.5 s"):
        probe_scheduler(f"tcp://127.0.0.1:{quiet.port}", timeout=0.5)
    assert time.monotonic() - start < 30  # Dask's own wait is 30 s to connect and 60 s to close


def test_nothing_listening_is_one_line():
    with socket.create_server(("127.0.0.1", 0)) as s:
        port = s.getsockname()[1]
    with pytest.raises(OSError, match=rf"^scheduler: cannot reach the Dask scheduler at "
                                      rf"'tcp://127.0.0.1:{port}': Connection refused"):
        probe_scheduler(f"tcp://127.0.0.1:{port}", timeout=5)


def test_a_real_scheduler_passes_the_probe():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as cluster:
        probe_scheduler(cluster.scheduler_address, timeout=10)


def test_cli_refuses_a_web_address_and_a_web_server_at_once(tmp_path, peer, capsys, monkeypatch):
    files = [str(p) for p in write_files(tmp_path / "in", 1)]
    db = tmp_path / "lib.db"
    assert main(["library", "init", str(db)]) == 0
    before = db.read_bytes()
    web = peer(_web_server)
    monkeypatch.setenv("SKILLBANK_CONNECT_TIMEOUT", "5")
    for address, message in [("http://127.0.0.1:8787", "is a web address"),
                             (f"tcp://127.0.0.1:{web.port}", "does not speak Dask's protocol")]:
        capsys.readouterr()
        start = time.monotonic()
        assert main(["library", "add", str(db), *files, "--scheduler", address]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err and err.startswith("skillbank library add: error: ")
        assert time.monotonic() - start < 20
    assert db.read_bytes() == before
    check_clean(db, 0)


def test_workers_are_bounded_per_core(monkeypatch):
    bound = max_workers()
    assert bound % WORKERS_PER_CORE == 0 and check_workers(bound) == bound
    with pytest.raises(ValueError, match=rf"^workers: at most {bound} local worker processes on this machine "
                                         rf"\({WORKERS_PER_CORE} per core of \d+; .*got {bound + 1}; set "
                                         r"SKILLBANK_MAX_WORKERS to start more"):
        check_workers(bound + 1)
    monkeypatch.setenv("SKILLBANK_MAX_WORKERS", str(bound + 5))
    assert check_workers(bound + 5) == bound + 5
    monkeypatch.setenv("SKILLBANK_MAX_WORKERS", "lots")
    with pytest.raises(ValueError, match=r"^SKILLBANK_MAX_WORKERS: expected an integer > 0, got 'lots'"):
        check_workers(1)


def test_a_huge_worker_count_is_refused_before_anything_starts(tmp_path, limited):
    files = [str(p) for p in write_files(tmp_path / "in", 1)]
    db = tmp_path / "lib.db"
    assert main(["library", "init", str(db)]) == 0
    before = db.read_bytes()
    for n in ("1000000000000000000", str(max_workers() + 1)):
        code, out, err = limited("library", "add", db, *files, "--workers", n, memory=1 << 30, timeout=60)
        assert code == 2 and out == ""
        assert err.count("\n") == 1 and "workers: at most" in err and "SKILLBANK_MAX_WORKERS" in err
    assert db.read_bytes() == before
