"""Serve a library's web view read-only over HTTP, from the live library (standard library ``http.server``).

The server answers only its own pages (:class:`~skillbank.plotting._view.LibraryView`'s names, ``/`` for
the index) and the three assets, to GET and HEAD; every other method is refused with 405, every other path
with 404 (no file is ever read from a path in a request, so none outside the site can be reached, and
nothing is listed). Requests are answered by a bounded pool of threads, and every connection has a
deadline (``_http_pool``: idle and half-open clients hold no thread; the limits are parameters, or
``SKILLBANK_VIEW_WORKERS``, ``SKILLBANK_VIEW_CONNECTIONS``, ``SKILLBANK_VIEW_TIMEOUT``). Pages are rendered
one at a time by one worker thread that owns the library's
connection (SQLite's may not be shared between threads), so it reads what the library holds at each
request. Log lines carry the request line escaped and never a password: the library is named by its
store's ``location``, which masks it, and an error is logged masked.
"""

from __future__ import annotations

import concurrent.futures
import re
import sys
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler
from urllib.parse import unquote, urlsplit

from ..core._text import printable
from ..store._secrets import mask_text
from ._http_pool import PooledHTTPServer, PooledHTTPServer6, head_reader, server_limits
from ._view import PAGE_SIZE, LibraryView, _assets
from ._view_html import CSP_HEADER

__all__ = ["ViewServer", "parse_address", "DEFAULT_HOST"]

#: Where the server listens unless told otherwise: this machine only.
DEFAULT_HOST = "127.0.0.1"
_PAGE = re.compile(r"/([a-z]+(?:-\d{1,18}){0,2}\.html)")
_TYPES = {".html": "text/html; charset=utf-8", ".css": "text/css; charset=utf-8",
          ".js": "text/javascript; charset=utf-8"}


def parse_address(text: str) -> tuple[str, int]:
    """``[HOST:]PORT`` as ``(host, port)``; the host defaults to :data:`DEFAULT_HOST`.

    Examples
    --------
    >>> parse_address("8000"), parse_address("0.0.0.0:80"), parse_address("[::1]:0")
    (('127.0.0.1', 8000), ('0.0.0.0', 80), ('::1', 0))
    >>> parse_address("localhost:http")
    Traceback (most recent call last):
    ...
    ValueError: serve: expected [HOST:]PORT with PORT an integer in 0..65535, got 'localhost:http'
    """
    host, _, port = str(text).rpartition(":")
    host = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    if not port.isdigit() or not 0 <= int(port) <= 65535 or (_ and not host):
        raise ValueError(f"serve: expected [HOST:]PORT with PORT an integer in 0..65535, got {text!r}")
    return host or DEFAULT_HOST, int(port)


class _Handler(BaseHTTPRequestHandler):
    server_version = "skillbank-view"
    sys_version = ""

    def setup(self):
        super().setup()
        head = self.server.take_head(self.request)
        if head is not None:  # read by the accepting thread: reading it here never waits
            self.rfile.close()
            self.rfile = head_reader(head)

    def __getattr__(self, name):
        # any method but GET and HEAD (POST, PUT, DELETE, PATCH, OPTIONS, an unknown one): 405
        if name.startswith("do_"):
            return self._refuse
        raise AttributeError(name)

    def _refuse(self):
        self._send(HTTPStatus.METHOD_NOT_ALLOWED, b"method not allowed: this view is read-only\n",
                   "text/plain; charset=utf-8", extra={"Allow": "GET, HEAD"})

    def do_GET(self):  # noqa: N802 - the name http.server calls
        self._answer(body=True)

    def do_HEAD(self):  # noqa: N802
        self._answer(body=False)

    def _answer(self, body: bool):
        status, data, kind = self.server.view_server.respond(self.path)
        self._send(status, data, kind, body=body)

    def _send(self, status, data: bytes, kind: str, *, body: bool = True, extra=None):
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(data)))
        self.send_header("Content-Security-Policy", CSP_HEADER)
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Referrer-Policy", "no-referrer")
        self.send_header("Cache-Control", "no-store")
        for key, value in (extra or {}).items():
            self.send_header(key, value)
        self.end_headers()
        if body:
            self.wfile.write(data)

    def log_message(self, format, *args):  # noqa: A002 - http.server's signature
        log = self.server.view_server.log
        if log is not None:
            line = format % args
            print(printable(mask_text(f"{self.address_string()} {line}")), file=log, flush=True)


class ViewServer:
    """The web view of a library served over HTTP, read-only.

    Parameters
    ----------
    open_library : callable
        Called once, in the worker thread that renders every page, to open
        the library (e.g. ``lambda: Library(url, readonly=True)``); its
        ``close()`` is called when the server closes.
    host : str, default=DEFAULT_HOST
    port : int, default=0
        0 picks a free port (see :attr:`port`).
    page_size : int, default=PAGE_SIZE
    log : file-like or None, default=sys.stderr
        Where each request is logged (one line each), None for no log.
    workers, connections, timeout : optional
        Threads that answer requests (8), connections open at once (128; past it the oldest idle one
        is closed) and seconds a client has to send its request and to read the answer (10); each
        defaults to ``SKILLBANK_VIEW_WORKERS``, ``SKILLBANK_VIEW_CONNECTIONS``, ``SKILLBANK_VIEW_TIMEOUT``
        when set.

    Examples
    --------
    >>> import os, tempfile, urllib.request
    >>> from skillbank.store import open_store
    >>> path = os.path.join(tempfile.mkdtemp(), "lib.db")
    >>> open_store(path).close()
    >>> with ViewServer(lambda: open_store(path, readonly=True), log=None) as server:
    ...     _ = server.start()
    ...     urllib.request.urlopen(server.url + "index.html").status
    200
    """

    def __init__(self, open_library, *, host: str = DEFAULT_HOST, port: int = 0, page_size: int = PAGE_SIZE,
                 log=sys.stderr, workers=None, connections=None, timeout=None):
        self.log = log
        limits = server_limits(workers=workers, connections=connections, timeout=timeout)
        self._assets = {f"/{name}": data for name, data in _assets().items()}
        self._worker = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="view")
        self._library = None
        try:
            self._library = self._worker.submit(open_library).result()
            self._view = LibraryView(self._library, page_size=page_size)
            self._http = (PooledHTTPServer6 if ":" in host else PooledHTTPServer)(
                (host, port), _Handler, log_line=self._log_line, **limits)
        except BaseException:
            self.close()
            raise
        self._http.view_server = self
        self._thread = None

    def _log_line(self, text: str) -> None:
        if self.log is not None:
            print(printable(mask_text(text)), file=self.log, flush=True)

    @property
    def port(self) -> int:
        """The port listened on."""
        return int(self._http.server_address[1])

    @property
    def url(self) -> str:
        """``http://host:port/`` of the index."""
        host = self._http.server_address[0]
        host = f"[{host}]" if ":" in host else host
        return f"http://{host}:{self.port}/"

    def respond(self, raw_path: str) -> tuple:
        """``(status, body, content type)`` for a request path: one of the site's, or 404."""
        path = unquote(urlsplit(raw_path).path)
        if path == "/":
            path = "/index.html"
        if path in self._assets:
            kind = _TYPES[path[path.rfind("."):]]
            return HTTPStatus.OK, self._assets[path], kind
        m = _PAGE.fullmatch(path)
        if m is not None:
            try:
                found = self._worker.submit(self._view.render, m.group(1)).result()
            except Exception as exc:  # noqa: BLE001 - one page failing must not stop the server
                if self.log is not None:
                    print(printable(mask_text(f"error rendering {path}: {' '.join(str(exc).split())}")),
                          file=self.log, flush=True)
                return HTTPStatus.INTERNAL_SERVER_ERROR, b"the page could not be rendered\n", \
                    "text/plain; charset=utf-8"
            if found is not None:
                return HTTPStatus.OK, found.encode(), _TYPES[".html"]
        return HTTPStatus.NOT_FOUND, b"not found\n", "text/plain; charset=utf-8"

    def start(self) -> ViewServer:
        """Serve in a background thread (for tests and embedding); returns self."""
        self._thread = threading.Thread(target=self._http.serve_forever, name="view-http", daemon=True)
        self._thread.start()
        return self

    def serve_forever(self) -> None:
        """Serve in this thread until interrupted (Ctrl-C)."""
        self._http.serve_forever()

    def close(self) -> None:
        """Stop serving and close the library (idempotent)."""
        http = getattr(self, "_http", None)
        if http is not None:
            if self._thread is not None:
                http.shutdown()
                self._thread.join()
                self._thread = None
            http.server_close()
            self._http = None
        if self._library is not None:
            library, self._library = self._library, None
            self._worker.submit(library.close).result()
        self._worker.shutdown(wait=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
