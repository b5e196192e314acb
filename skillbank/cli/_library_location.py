"""Where a library command's library is: a file or a URL, printed masked, opened once per command."""

from __future__ import annotations

from pathlib import Path

__all__ = ["_DB", "_DB_READ", "_URL", "_location", "_target", "_library", "_open", "check_libraries"]

#: The arguments that name a library (``library copy`` has two).
_LIBRARIES = ("db", "src", "dst")

_DB = "the library: a file (see 'library init') or a postgresql:// URL"
_DB_READ = ("the library, a file or a postgresql:// URL; opened read-only, so a library in a folder you "
            "cannot write works")


class _URL:
    """A library URL from the command line: the library opens with all of it, messages show it masked."""

    def __init__(self, url: str):
        self.url = url

    def __str__(self) -> str:
        from ..store import mask_url  # the store package, when a URL is printed (after a command ran)

        return mask_url(self.url)

    @property
    def name(self) -> str:
        """The URL's last path part (the database), for figure titles."""
        return str(self).split("?", 1)[0].rstrip("/").rsplit("/", 1)[-1]


def _location(text: str):
    """A ``db`` argument: a URL of a store backend (``postgresql://...``), else a library file.

    The store tells them apart (``store._registry.parse_location``); one it refuses is refused when opened.

    Examples
    --------
    >>> _location("lib.db"), _location("sqlite:////data/lib.db")
    (PosixPath('lib.db'), PosixPath('/data/lib.db'))
    >>> str(_location("postgresql://ann:s3cret@db.lab/skills"))
    'postgresql://ann:***@db.lab/skills'
    """
    from ..store._registry import parse_location  # the store package, when a library command is parsed

    try:
        _, target = parse_location(text)
    except ValueError:  # refused by the store when the command opens it: one line, exit status 2, masked
        return _URL(text)
    return target if isinstance(target, Path) else _URL(target)


def _target(location):
    """What the store opens: the full URL (password included), or the path."""
    return location.url if isinstance(location, _URL) else location


def _library(location, **kwargs):
    # The pipeline and its store: imported when a library command runs, not for --help (what it needs of
    # scikit-learn and scipy, only when the command clusters, cuts, reuses or plans).
    from ..pipeline import Library

    return Library(_target(location), **kwargs)


def _open(args, *, create=False, readonly=False):
    if readonly:
        return _library(args.db, readonly=True)
    return _library(args.db, create=create)


def check_libraries(args) -> None:
    """Refuse a library file that is a FIFO, a device or a socket before any work (``skillbank.cli.main``).

    The store refuses them too when it opens one (``store._schema.check_library_file``, the same check);
    here a command that would first read, plan or record learns it before that work.
    """
    for name in _LIBRARIES:
        value = getattr(args, name, None)
        if isinstance(value, Path):
            from ..store._schema import check_library_file  # the store's one check, when a file is named

            check_library_file(value)
