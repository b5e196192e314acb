"""``skillbank library view``: the library as a web site, written to a folder or served read-only."""

from __future__ import annotations

import json
import signal
import sys
import threading
from pathlib import Path

from ._library_location import _DB_READ, _location, _open, _target
from ._output import add_force_option

__all__ = ["add_view_parser", "check_view", "write_library_view"]


def add_view_parser(cmds) -> None:
    """Register ``library view`` on the ``library`` sub-command parsers ``cmds``."""
    c = cmds.add_parser("view", help="the library as a self-contained web site: skills, members in 3-D, "
                                     "demonstrations and their cuts, planning descriptions")
    c.add_argument("db", type=_location, help=_DB_READ)
    where = c.add_mutually_exclusive_group(required=True)
    where.add_argument("--out", type=Path, default=None, metavar="DIR",
                       help="write the site to this folder (new or empty; a view written before is replaced "
                            "with --force); open DIR/index.html, no network needed")
    where.add_argument("--serve", default=None, metavar="[HOST:]PORT",
                       help="serve the pages from the live library, read-only, on HOST (default 127.0.0.1) "
                            "and PORT (0: any free port); Ctrl-C stops")
    add_force_option(c, folder=True)
    c.add_argument("--page-size", type=int, default=None, metavar="N",
                   help="members per page of a skill (default 100)")
    c.add_argument("--json", action="store_true",
                   help="print the folder, its index and the page count as JSON (with --serve: the URL, once "
                        "listening)")
    c.set_defaults(func=_view)


def check_view(path) -> None:
    """A ``--view DIR`` a site can be written to, and plotly.js there to write: checked before any work."""
    # the plotting package and plotly's JavaScript, only when a view is asked for
    from ..plotting._view import check_out, plotly_js

    plotly_js()
    check_out(path, name="view")


def write_library_view(args, extra: dict) -> dict:
    """Write the web view of ``args.db`` to ``args.view`` with the ``extra`` result pages; what was written.

    Returns ``{"out", "index", "pages": {name: path of each extra page}}``.
    """
    from ..plotting._view import write_view  # the web view, only when one is asked for

    with _open(args, readonly=True) as lib:
        done = write_view(lib, args.view, extra=extra)
    return {"out": done["out"], "index": done["index"],
            "pages": {name: str(Path(done["out"]) / name) for name in extra}}


def _view(args) -> int:
    # the plotting package and plotly's JavaScript, only when a view is asked for
    from ..plotting._view import PAGE_SIZE, check_out, plotly_js, write_view

    size = PAGE_SIZE if args.page_size is None else args.page_size
    if size < 1:
        raise ValueError(f"page-size: expected a positive integer, got {size}")
    plotly_js()  # the extra is missing: one line before any work
    if args.serve is not None:
        return _serve(args, size)
    check_out(args.out)
    with _open(args, readonly=True) as lib:
        done = write_view(lib, args.out, page_size=size)
    if args.json:
        print(json.dumps(done))
        return 0
    print(f"{args.db}: wrote the library's view ({done['pages']} page(s)) to {done['out']}")
    print(f"  open {done['index']}")
    return 0


def _serve(args, size: int) -> int:
    from ..pipeline import Library  # opened in the server's worker thread
    from ..plotting._view_server import ViewServer, parse_address  # the standard library's http.server

    host, port = parse_address(args.serve)
    target = _target(args.db)
    try:
        server = ViewServer(lambda: Library(target, readonly=True), host=host, port=port, page_size=size)
    except OSError as exc:  # the address is taken or cannot be bound: one line, the library not named
        raise ValueError(f"serve: cannot listen on {host}:{port}: {exc.strerror or exc}") from None
    with server:
        if args.json:
            print(json.dumps({"url": server.url, "library": str(args.db)}), flush=True)
        else:
            print(f"{args.db}: serving its view read-only at {server.url} (Ctrl-C stops)", flush=True)
        # Ctrl-C stops it whatever the process inherited: started by one that ignores SIGINT (a pytest-xdist
        # worker, a shell's background job), Python installs no handler of its own and it would never stop
        previous = signal.signal(signal.SIGINT, signal.default_int_handler) \
            if threading.current_thread() is threading.main_thread() else None
        try:
            server.serve_forever()
        except KeyboardInterrupt:
            print("stopped", file=sys.stderr)
        finally:
            if previous is not None:
                signal.signal(signal.SIGINT, previous)
    return 0
