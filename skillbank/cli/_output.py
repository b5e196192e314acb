"""What the command line prints: user-given text without raw terminal escapes, and no password."""

from __future__ import annotations

import contextlib
import sys

from ..core._text import printable

__all__ = ["escaped_stdout", "error_line", "add_force_option", "check_overwrite", "FORCE_HELP"]


class _Escaping:
    """A text stream that shows control characters (ESC, CSI, ...) as escapes, keeping newlines and tabs.

    Labels, file names and metadata come from whoever wrote the library or the
    files; raw, an escape sequence could recolour, rewrite or hide the output.
    JSON is unchanged: ``json.dumps`` writes no raw control character.
    """

    def __init__(self, stream):
        self._stream = stream

    def write(self, text):
        self._stream.write(printable(text, keep="\n\t"))
        return len(text)

    def __getattr__(self, name):  # flush, fileno, isatty, buffer, ... as the real stream's
        return getattr(self._stream, name)


@contextlib.contextmanager
def escaped_stdout():
    """``sys.stdout`` escaped (see :class:`_Escaping`) while the block runs."""
    real = sys.stdout
    sys.stdout = _Escaping(real)
    try:
        yield
    finally:
        sys.stdout = real


def error_line(exc, args=None) -> str:
    """``exc``'s message on one line, escaped, with the password of every library URL in ``args`` masked,
    and of any location the message quotes.

    The store masks its own messages; this is the last net, for a message that quotes a URL some other way
    (argparse's "unrecognized arguments: ...", a reader's error naming its argument).
    """
    message = " ".join(str(exc).split())
    urls = [getattr(value, "url", None) for value in vars(args).values()] if args is not None else []
    urls = [url for url in urls if isinstance(url, str)]
    if urls or any(mark in message for mark in ("@", "://", "password")):
        from ..store._secrets import mask_text, scrub  # the store package, for a message that may need it

        for url in urls:
            message = scrub(message, url)
        message = mask_text(message)
    return printable(message)


#: ``--force``'s help: the one text for every command with ``--out``.
FORCE_HELP = ("overwrite what --out names when it is there already (default: refuse with one line on stderr "
              "and exit status 2, before any work, nothing written)")


def add_force_option(p, *, folder: bool = False, existing=None) -> None:
    """``--force``: the one rule of ``--out`` for every command that has it.

    Without ``--force`` an output that is there already is refused before any work (:func:`check_overwrite`):
    a file that exists; with ``folder=True`` a folder that holds anything (an empty one is new); with
    ``existing``, a function of the parsed arguments, the files it returns (``segment``: an earlier run's
    segments of the same input).
    """
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(out_is_folder=folder, out_existing=existing)


def _already_there(args) -> list:
    import os
    from pathlib import Path

    out = getattr(args, "out", None)
    if out is None:
        return []
    out = Path(out)
    existing = getattr(args, "out_existing", None)
    if existing is not None:
        return list(existing(args))
    if getattr(args, "out_is_folder", False) and out.is_dir() and not out.is_symlink():
        return [out] if any(out.iterdir()) else []
    return [out] if os.path.lexists(out) else []


def check_overwrite(args) -> None:
    """Refuse an ``--out`` that is there already, unless ``--force``: one ValueError naming it and the way on.

    Examples
    --------
    >>> import argparse
    >>> check_overwrite(argparse.Namespace(out=__file__, force=False))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: out: ... exists; give --force to overwrite it
    """
    if not hasattr(args, "force") or args.force:
        return
    there = _already_there(args)
    if there:
        more = f" (and {len(there) - 1} more)" if len(there) > 1 else ""
        raise ValueError(f"out: {str(there[0])!r}{more} exists; give --force to overwrite it")
