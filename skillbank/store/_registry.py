"""Store backends by URL scheme, and :func:`open_store`."""

from __future__ import annotations

import re
from pathlib import Path

from ._base import Store
from ._postgres import PostgresStore
from ._sqlite import SQLiteStore

__all__ = ["STORES", "open_store", "backend"]

#: URL scheme -> backend class; a plain path (no ``scheme://``) is ``sqlite``. A class may answer to
#: other schemes too, listed in its ``aliases`` (``postgres://`` opens ``postgresql``).
STORES: dict[str, type[Store]] = {"sqlite": SQLiteStore, "postgresql": PostgresStore}

_URL = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*)://(.*)$")


def open_store(location, *, create: bool = True, **options) -> Store:
    """Open the library at ``location``: a path, ``sqlite:///path``, or a URL of another registered backend.

    Parameters
    ----------
    location : str, path-like or Store
        A Store is returned as it is; ``postgresql://...`` (or ``postgres://``)
        opens a :class:`~skillbank.store.PostgresStore`.
    create : bool, default=True
        Create the library when it does not exist.
    **options
        Passed to the backend (``timeout``, ``readonly``).

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
    return backend(match.group(1)).from_url(str(location), create=create, **options)


def backend(scheme: str) -> type[Store]:
    """The backend class serving URL ``scheme`` (a key of :data:`STORES` or one of a class's ``aliases``).

    Examples
    --------
    >>> backend("postgres").__name__
    'PostgresStore'
    """
    scheme = scheme.lower()
    found = STORES.get(scheme) or next((cls for cls in STORES.values()
                                        if scheme in getattr(cls, "aliases", ())), None)
    if found is None:
        known = sorted({*STORES, *(a for cls in STORES.values() for a in getattr(cls, "aliases", ()))})
        raise ValueError(f"library: no store backend for {scheme}:// (known: {', '.join(known)}; "
                         "a plain path is a SQLite file)")
    return found
