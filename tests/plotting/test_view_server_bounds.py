"""The view server holds a bounded number of threads, drops idle clients, and logs a lost client in one line
(issue 41): real sockets against a real server."""

from __future__ import annotations

import io
import socket
import struct
import threading
import time
import urllib.request

import numpy as np
import pytest

from skillbank.core import Demonstration
from skillbank.plotting._http_pool import server_limits
from skillbank.plotting._view_server import ViewServer
from skillbank.store import open_store


@pytest.fixture
def library(tmp_path):
    path = tmp_path / "lib.db"
    t = np.linspace(0.0, 1.0, 30)
    with open_store(path) as store:
        store.add_demonstration(Demonstration.from_array(np.c_[t, t, t], t), [(0, 30)])
    return path


def _serve(library, **limits):
    log = io.StringIO()
    server = ViewServer(lambda: open_store(library, readonly=True), log=log, **limits)
    server.start()
    server.log_text = log
    return server


def _wait_for(condition, seconds=20.0):
    """Poll ``condition`` until it holds or ``seconds`` pass (a deadline, not a timed assertion)."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(0.05)
    return condition()


def _get(server, path="/", timeout=10):
    with urllib.request.urlopen(server.url + path.lstrip("/"), timeout=timeout) as answer:
        return answer.status, answer.read()


def test_many_half_open_connections_hold_no_threads_and_the_index_is_still_served(library):
    server = _serve(library, workers=4, connections=64)
    before = threading.active_count()
    clients = []
    try:
        for k in range(200):
            sock = socket.create_connection(("127.0.0.1", server.port), timeout=10)
            if k % 2:  # half a request: its head never ends
                sock.sendall(b"GET / HTTP/1.1\r\nHost: x\r\n")
            clients.append(sock)
        status, body = _get(server)
        assert status == 200 and b"<h1>Library " in body
        assert threading.active_count() <= before + 4
        for _ in range(10):  # several at once, while the idle ones are still open
            assert _get(server, "/assets/view.css")[0] == 200
        assert threading.active_count() <= before + 4
    finally:
        for sock in clients:
            sock.close()
        server.close()
    logged = server.log_text.getvalue()
    assert "Traceback" not in logged
    assert "64 connections open, the oldest idle one is closed" in logged


def test_a_client_that_sends_nothing_is_closed_after_the_timeout(library):
    server = _serve(library, timeout=0.3)
    try:
        with socket.create_connection(("127.0.0.1", server.port), timeout=10) as sock:
            assert sock.recv(1) == b""  # the server closed it: no request came
        assert _wait_for(lambda: "closed: no complete request within 0.3 s" in server.log_text.getvalue())
        assert _get(server)[0] == 200
    finally:
        server.close()


def test_a_client_that_drops_mid_response_is_one_log_line(library):
    server = _serve(library)
    try:
        sock = socket.create_connection(("127.0.0.1", server.port), timeout=10)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        sock.sendall(b"GET /assets/plotly.min.js HTTP/1.0\r\n\r\n")  # megabytes: more than the buffers
        assert sock.recv(1024).startswith(b"HTTP/1.0 200")
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        sock.close()  # a reset, mid-response
        assert _wait_for(lambda: "went away mid-response" in server.log_text.getvalue())
        assert _get(server)[0] == 200
    finally:
        server.close()
    lines = [line for line in server.log_text.getvalue().splitlines() if "mid-response" in line]
    assert len(lines) == 1 and lines[0].startswith("127.0.0.1 went away mid-response (")
    assert "Traceback" not in server.log_text.getvalue()


def test_a_client_that_stops_reading_frees_its_worker(library):
    server = _serve(library, workers=1, timeout=0.5)
    try:
        sock = socket.create_connection(("127.0.0.1", server.port), timeout=10)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        sock.sendall(b"GET /assets/plotly.min.js HTTP/1.0\r\n\r\n")  # and never reads it
        assert _wait_for(lambda: "Request timed out" in server.log_text.getvalue())  # http.server's line
        assert _get(server)[0] == 200  # the only worker is free again
        sock.close()
    finally:
        server.close()


@pytest.mark.parametrize("given, environ, match", [
    ({"workers": 0}, {}, r"^workers: expected a whole number of workers > 0, got '0'"),
    ({"timeout": float("inf")}, {}, r"^timeout: expected seconds > 0, got 'inf'"),
    ({}, {"SKILLBANK_VIEW_CONNECTIONS": "lots"},
     r"^SKILLBANK_VIEW_CONNECTIONS: expected a whole number of connections > 0, got 'lots'"),
])
def test_bad_limits_are_one_line(given, environ, match):
    with pytest.raises(ValueError, match=match):
        server_limits(**given, environ=environ)


def test_the_limits_come_from_the_environment(monkeypatch, library):
    assert server_limits(environ={"SKILLBANK_VIEW_WORKERS": "3"})["workers"] == 3
    monkeypatch.setenv("SKILLBANK_VIEW_TIMEOUT", "-1")
    with pytest.raises(ValueError, match=r"^SKILLBANK_VIEW_TIMEOUT: expected seconds > 0, got '-1'"):
        ViewServer(lambda: open_store(library, readonly=True), log=None)
