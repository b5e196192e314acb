"""What the command line prints: user-given text without raw terminal escapes, and no password."""

from __future__ import annotations

import contextlib
import sys

from ..core._text import printable

__all__ = ["escaped_stdout", "error_line"]


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
