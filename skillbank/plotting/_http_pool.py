"""A bounded HTTP server for the web view: a fixed pool of worker threads and a deadline on every connection.

``ThreadingHTTPServer`` starts a thread per connection, with no limit and no
timeout: 200 connections that send nothing hold 200 threads for as long as
their clients like, and a client that goes away mid-response leaves a
traceback in the log. Here one thread accepts connections and reads each
request's head without blocking (a selector); only a complete head is handed
to one of ``workers`` threads, so idle or trickling clients hold no thread.
A connection that has not sent its head within ``timeout`` seconds is
closed; so is the oldest idle one when ``connections`` are open; a worker
writes with the same timeout, so a client that stops reading frees it. A
client that goes away is one line in the log.
"""

from __future__ import annotations

import concurrent.futures
import io
import os
import selectors
import socket
import threading
import time
from http.server import HTTPServer

__all__ = ["PooledHTTPServer", "PooledHTTPServer6", "server_limits", "WORKERS", "CONNECTIONS", "TIMEOUT",
           "LIMIT_VARIABLES"]

#: Threads that answer requests.
WORKERS = 8
#: Connections open at once (idle ones and those being answered); past it the oldest idle one is closed.
CONNECTIONS = 128
#: Seconds a client has to send its request's head, and that a worker waits on a client that stops reading.
TIMEOUT = 10.0
#: Bytes of a request's head (request line and headers) read at most.
MAX_HEAD = 65536
#: The environment variables that set other limits (``library view --serve``).
LIMIT_VARIABLES = {"workers": "SKILLBANK_VIEW_WORKERS", "connections": "SKILLBANK_VIEW_CONNECTIONS",
                   "timeout": "SKILLBANK_VIEW_TIMEOUT"}
_DEFAULTS = {"workers": WORKERS, "connections": CONNECTIONS, "timeout": TIMEOUT}


def _limit(name: str, value, environ):
    variable = LIMIT_VARIABLES[name]
    shown = name if value is not None else variable
    if value is None:
        text = environ.get(variable, "").strip()
        if not text:
            return _DEFAULTS[name]
        value = text
    try:
        number = float(value) if name == "timeout" else int(value)
        if isinstance(value, bool) or not 0 < number < float("inf"):
            raise ValueError
    except (TypeError, ValueError):
        kind = "seconds > 0" if name == "timeout" else f"a whole number of {name} > 0"
        raise ValueError(f"{shown}: expected {kind}, got {str(value)[:40]!r}") from None
    return number


def server_limits(*, workers=None, connections=None, timeout=None, environ=None) -> dict:
    """``{"workers", "connections", "timeout"}``: each as given, else its :data:`LIMIT_VARIABLES`
    variable, else the default.

    Examples
    --------
    >>> server_limits(environ={})
    {'workers': 8, 'connections': 128, 'timeout': 10.0}
    >>> server_limits(workers=2, environ={"SKILLBANK_VIEW_TIMEOUT": "2.5"})["timeout"]
    2.5
    """
    environ = os.environ if environ is None else environ
    given = {"workers": workers, "connections": connections, "timeout": timeout}
    return {name: _limit(name, value, environ) for name, value in given.items()}


class PooledHTTPServer(HTTPServer):
    """An :class:`http.server.HTTPServer` answering with a bounded pool (see the module's docstring).

    The handler class takes the request's head from :meth:`take_head` (``_Handler.setup`` in
    ``_view_server``); ``log_line(text)`` receives the server's own log lines.
    """

    request_queue_size = 64  # the listen backlog; accepted connections are bounded by ``connections``

    def __init__(self, address, handler, *, workers=WORKERS, connections=CONNECTIONS, timeout=TIMEOUT,
                 log_line=None):
        self.workers, self.connections, self.limit_timeout = int(workers), int(connections), float(timeout)
        self._log = log_line
        self._pool = None
        self._pending: dict = {}  # socket -> [client address, head so far, deadline]
        self._heads: dict = {}  # socket -> its complete head, while a worker answers it
        self._busy = 0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._idle = threading.Event()
        self._idle.set()
        super().__init__(address, handler)  # binds and listens (closes itself when that fails)
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=self.workers,
                                                           thread_name_prefix="view-http")

    # -- the accepting thread --------------------------------------------------------------------------
    def serve_forever(self, poll_interval: float = 0.25) -> None:
        self._idle.clear()
        try:
            with selectors.DefaultSelector() as sel:
                sel.register(self.socket, selectors.EVENT_READ)
                while not self._stop.is_set():
                    for key, _ in sel.select(poll_interval):
                        if key.fileobj is self.socket:
                            self._accept(sel)
                        else:
                            self._read(sel, key.fileobj)
                    self._expire(sel)
                for sock in list(self._pending):
                    self._drop(sel, sock, None)
        finally:
            self._stop.clear()
            self._idle.set()

    def shutdown(self) -> None:
        """Stop :meth:`serve_forever` (from another thread) and wait until it has."""
        self._stop.set()
        self._idle.wait()

    def server_close(self) -> None:
        super().server_close()
        for sock in list(self._pending):
            self._pending.pop(sock, None)
            sock.close()
        if self._pool is not None:
            self._pool.shutdown(wait=True)

    def _line(self, text: str) -> None:
        if self._log is not None:
            self._log(text)

    def _accept(self, sel) -> None:
        try:
            sock, address = self.socket.accept()
        except OSError:  # the client gave up between select and accept
            return
        with self._lock:
            busy = self._busy
        if len(self._pending) + busy >= self.connections:
            if not self._pending:
                self._line(f"{address[0]} refused: {self.connections} connections are being answered")
                sock.close()
                return
            oldest = min(self._pending, key=lambda s: self._pending[s][2])
            self._drop(sel, oldest, f"closed: {self.connections} connections open, the oldest idle one is "
                                    "closed")
        sock.setblocking(False)
        self._pending[sock] = [address, bytearray(), time.monotonic() + self.limit_timeout]
        sel.register(sock, selectors.EVENT_READ)

    def _read(self, sel, sock) -> None:
        entry = self._pending.get(sock)
        if entry is None:
            return
        address, head, _ = entry
        try:
            data = sock.recv(MAX_HEAD - len(head))
        except (BlockingIOError, InterruptedError):
            return
        except OSError:  # reset before a request: nothing to answer
            self._drop(sel, sock, None)
            return
        if not data:  # closed before a complete request
            self._drop(sel, sock, None)
            return
        head += data
        if b"\r\n\r\n" in head or b"\n\n" in head or len(head) >= MAX_HEAD:
            sel.unregister(sock)
            del self._pending[sock]
            with self._lock:
                self._busy += 1
            self._pool.submit(self._answer, sock, address, bytes(head))

    def _expire(self, sel) -> None:
        now = time.monotonic()
        for sock, (_, _, deadline) in list(self._pending.items()):
            if deadline <= now:
                self._drop(sel, sock, f"closed: no complete request within {self.limit_timeout:g} s")

    def _drop(self, sel, sock, why) -> None:
        address = self._pending.pop(sock)[0]
        sel.unregister(sock)
        sock.close()
        if why is not None:
            self._line(f"{address[0]} {why}")

    # -- a worker --------------------------------------------------------------------------------------
    def take_head(self, sock):
        """The head read for ``sock`` (once), or None."""
        return self._heads.pop(sock, None)

    def _answer(self, sock, address, head: bytes) -> None:
        try:
            sock.setblocking(True)
            sock.settimeout(self.limit_timeout)  # a client that stops reading frees the worker
            self._heads[sock] = head
            self.finish_request(sock, address)
        except Exception as exc:  # noqa: BLE001 - one client must not stop the server, nor fill the log
            self._dropped(address, exc)
        finally:
            self._heads.pop(sock, None)
            self.shutdown_request(sock)
            with self._lock:
                self._busy -= 1

    def _dropped(self, address, exc) -> None:
        if isinstance(exc, (BrokenPipeError, ConnectionResetError, ConnectionAbortedError)):
            why = f"went away mid-response ({type(exc).__name__})"
        elif isinstance(exc, (TimeoutError, socket.timeout)):
            why = f"stopped reading the response for {self.limit_timeout:g} s; closed"
        else:
            why = f"answer failed: {type(exc).__name__}: {' '.join(str(exc).split())}"
        self._line(f"{address[0]} {why}")

    def handle_error(self, request, client_address) -> None:  # socketserver's hook: one line, no traceback
        self._line(f"{client_address[0]} answer failed")


class PooledHTTPServer6(PooledHTTPServer):
    address_family = socket.AF_INET6  # an IPv6 host ("::1")


def head_reader(head: bytes):
    """The request's head as the handler's ``rfile``: read already, so reading it never waits."""
    return io.BytesIO(head)
