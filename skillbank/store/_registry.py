"""Store backends by URL scheme, :func:`open_store`, and :func:`parse_location`, the one place that tells
a library file from a database URL (and refuses a connection string in any other form)."""

from __future__ import annotations

from pathlib import Path

from ._base import Store
from ._postgres import PostgresStore
from ._secrets import CONTROL, SCHEME_URL, credential_shape, keyword_string, mask_url
from ._sqlite import SQLiteStore

__all__ = ["STORES", "open_store", "backend", "parse_location"]

#: URL scheme -> backend class; a plain path (no ``scheme://``) is ``sqlite``. A class may answer to
#: other schemes too, listed in its ``aliases`` (``postgres://`` opens ``postgresql``).
STORES: dict[str, type[Store]] = {"sqlite": SQLiteStore, "postgresql": PostgresStore}

_FILE = "start it with ./ for a file of that name"


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
    scheme, target = parse_location(location)
    if scheme == "sqlite" and isinstance(target, Path):
        return SQLiteStore(target, create=create, **options)
    return backend(scheme).from_url(target, create=create, **options)


def parse_location(location) -> tuple[str, object]:
    """What a library location names: ``("sqlite", Path)`` for a file, else ``(scheme, URL)`` of a backend.

    The one place that tells a file from a database: a ``scheme://`` URL goes
    to its backend (``sqlite:///path`` is a file); a location with a control
    character, a libpq keyword string (``host=... password=...``), a URL
    without its ``//`` (``postgresql:ann:pw@db/skills``) or without its scheme
    (``ann:pw@db/skills``, unless such a file exists) is refused in one line
    with the password masked, and never taken for a file name.

    Examples
    --------
    >>> parse_location("lib.db"), parse_location("sqlite:////data/lib.db")
    (('sqlite', PosixPath('lib.db')), ('sqlite', PosixPath('/data/lib.db')))
    >>> parse_location("postgresql:ann:s3cret@db/skills")
    Traceback (most recent call last):
    ...
    ValueError: library 'postgresql:ann:***@db/skills': a URL without '//' after its scheme; write \
postgresql://ann:***@db/skills (or start it with ./ for a file of that name)
    """
    if isinstance(location, Path):
        _check_controls(str(location))
        return "sqlite", location
    if not isinstance(location, str):
        raise ValueError(f"library: expected a path or a URL, got {type(location).__name__}")
    if not location.strip():
        raise ValueError(f"library: expected a path or a URL, got {location!r}")
    _check_controls(location)
    shown = mask_url(location)
    match = SCHEME_URL.match(location)
    if match is None:
        if "://" in location:
            raise ValueError(f"library {shown!r}: a URL starts with its scheme (postgresql://...); remove "
                             "what comes before it")
        return "sqlite", _file(location, shown)
    scheme = match.group(1).lower()
    if scheme == "sqlite":  # sqlite:///relative or sqlite:////absolute, as SQLAlchemy writes them
        rest = match.group(2)
        path = rest[1:] if rest.startswith("/") else rest
        if not path:
            raise ValueError(f"library {shown!r}: expected sqlite:///relative/path or sqlite:////absolute/path")
        return "sqlite", _file(path, location[:len(location) - len(path)] + mask_url(path))
    return scheme, location


def _check_controls(text: str) -> None:
    if CONTROL.search(text):
        raise ValueError(f"library {mask_url(text)!r}: a path or URL holds no control characters (a "
                         "newline, NUL or escape: a quoting slip?); remove them")


def _exists(text: str) -> bool:
    try:
        return Path(text).exists()
    except OSError:  # a name too long for the file system: no such file (and its message would show it)
        return False


def _file(text: str, shown: str) -> Path:
    """``text`` as a file name, unless it is a connection string written in another form."""
    if keyword_string(text):
        raise ValueError(f"library {shown!r}: a libpq keyword string is not a library location; write it "
                         "as a URL, postgresql://user:password@host:port/dbname?param=value, with the "
                         f"password percent-encoded ('?' as %3F, '@' as %40, ...) (or {_FILE})")
    head, colon, rest = text.partition(":")
    known = {*STORES, *(a for cls in STORES.values() for a in getattr(cls, "aliases", ()))}
    if colon and head.lower() in known:
        body = mask_url(rest.lstrip("/"))
        fixed = f"sqlite:///{mask_url(rest)}" if head.lower() == "sqlite" else f"{head}://{body}"
        raise ValueError(f"library {shown!r}: a URL without '//' after its scheme; write {fixed} "
                         f"(or {_FILE})")
    if credential_shape(text) and not _exists(text):
        raise ValueError(f"library {shown!r} reads as user:password@host, a URL without its scheme; write "
                         f"postgresql://{mask_url(text)} (or {_FILE})")
    return Path(text)


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
