"""User-given text made safe to show on a terminal: control characters as visible escapes."""

from __future__ import annotations

import re

__all__ = ["printable", "CONTROL"]

#: C0 controls, DEL and C1 controls (ESC starts a terminal escape sequence, U+009B is a one-character
#: CSI), and the bidirectional overrides and isolates, which reorder what a terminal shows.
CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def _escape(match) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def printable(text, keep: str = "") -> str:
    """``text`` with every control character shown as an escape (``\\x1b``), except those in ``keep``.

    Parameters
    ----------
    text : str
        What a label, a file name or a message holds (anything else is converted with ``str``).
    keep : str, default=""
        Characters left as they are, e.g. ``"\\n\\t"`` for lines of output.

    Examples
    --------
    >>> printable("\\x1b[31mred\\x1b[0m")
    '\\\\x1b[31mred\\\\x1b[0m'
    >>> printable("one\\ntwo\\x9b2J", keep="\\n")
    'one\\ntwo\\\\x9b2J'
    """
    text = str(text)
    if keep:
        return CONTROL.sub(lambda m: m.group() if m.group() in keep else _escape(m), text)
    return CONTROL.sub(_escape, text)
