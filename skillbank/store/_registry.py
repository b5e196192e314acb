"""Store backends by URL scheme, and :func:`open_store`."""

from __future__ import annotations

import re
from pathlib import Path

from ._base import Store
from ._sqlite import SQLiteStore

__all__ = ["STORES", "open_store"]

#: URL scheme -> backend class; a plain path (no ``scheme://``) is ``sqlite``.
STORES: dict[str, type[Store]] = {"sqlite": SQLiteStore}

_URL = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*)://(.*)$")


def open_store(location, *, create: bool = True, **options) -> Store:
    """Open the library at ``location``: a path, ``sqlite:///path``, or a URL of another registered backend.

    Parameters
    ----------
    location : str, path-like or Store
        A Store is returned as it is.
    create : bool, default=True
        Create the library when it does not exist.
    **options
        Passed to the backend (e.g. ``timeout`` for SQLite).

    Examples
    --------
    >>> import os, tempfile
    >>> store = open_store("sqlite:///" + os.path.join(tempfile.mkdtemp(), "lib.db"))
    >>> type(store).__name__
    'SQLiteStore'
    >>> store.close()
    """
    if isinstance(location, Store):
        return location
    if not isinstance(location, (str, Path)):
        raise ValueError(f"library: expected a path or a URL, got {type(location).__name__}")
    match = _URL.match(str(location)) if isinstance(location, str) else None
    if match is None:
        return SQLiteStore(location, create=create, **options)
    scheme = match.group(1).lower()
    if scheme not in STORES:
        raise ValueError(f"library: no store backend for {scheme}:// (known: "
                         f"{', '.join(sorted(STORES))}; a plain path is a SQLite file)")
    return STORES[scheme].from_url(str(location), create=create, **options)
