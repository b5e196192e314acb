"""The reading error, and small helpers every reader shares.

Every problem met while reading a file becomes a :class:`FormatError` whose
message is one line, ``cannot read '<path>': <reason>``, so that users never
see a traceback from inside h5py, scipy or numpy.
"""

from __future__ import annotations

import csv
import struct
import zipfile
import zlib
from contextlib import contextmanager
from pathlib import Path

import numpy as np

__all__ = [
    "FormatError", "HDF5_MAGIC", "MAT5_MAGIC", "ZIP_MAGICS",
    "as_file", "describe_content", "drop_repeated_times", "expect_magic", "reading", "read_head",
]

# What the file libraries raise on bad content. FormatError is a ValueError,
# so it is re-raised untouched before this tuple is consulted.
_LIBRARY_ERRORS = (
    OSError,
    ValueError,
    KeyError,
    TypeError,
    IndexError,
    AttributeError,
    EOFError,
    RuntimeError,
    NotImplementedError,
    UnicodeError,
    zipfile.BadZipFile,
    csv.Error,
    zlib.error,
    struct.error,
)


def _one_line(text) -> str:
    return " ".join(str(text).split())


class FormatError(ValueError):
    """A file could not be read: wrong format, corrupt, or missing content.

    Parameters
    ----------
    path : str or path-like
        The file (or folder) being read.
    reason : str
        What was expected and what was found. Newlines are collapsed so the
        message stays on one line.

    Attributes
    ----------
    path : str
    reason : str

    Examples
    --------
    >>> str(FormatError("demo.xyz", "unknown extension '.xyz'"))
    "cannot read 'demo.xyz': unknown extension '.xyz'"
    """

    def __init__(self, path, reason):
        self.path = str(path)
        self.reason = _one_line(reason)
        super().__init__(f"cannot read '{self.path}': {self.reason}")

    def __reduce__(self):
        return (type(self), (self.path, self.reason))


@contextmanager
def reading(path, what: str = "invalid content"):
    """Turn any library or validation error raised inside into a FormatError.

    ``what`` prefixes the library's own (one-lined) message.
    """
    try:
        yield
    except FormatError:
        raise
    except _LIBRARY_ERRORS as exc:
        detail = _one_line(exc) or type(exc).__name__
        # ``from None``: the library traceback is noise to the user.
        raise FormatError(path, f"{what}: {detail}") from None


def as_file(path) -> Path:
    """Return ``path`` as a Path, raising FormatError unless it is a regular file."""
    try:
        p = Path(path)
    except TypeError:
        raise FormatError(path, f"expected a file path, got {type(path).__name__}") from None
    if not p.exists():
        raise FormatError(p, "no such file")
    if p.is_dir():
        raise FormatError(p, "expected a file, found a directory")
    return p


def drop_repeated_times(t, *arrays):
    """Drop samples whose time stamp repeats the previous one.

    Recorders sometimes log two samples with the same stamp; keeping the first
    is the least surprising fix and leaves a strictly increasing clock.
    Decreasing time is left alone so that validation still reports it.

    Returns
    -------
    t, arrays..., n_dropped
    """
    t = np.asarray(t, dtype=float).ravel()
    if t.shape[0] < 2:
        return (t, *arrays, 0)
    keep = np.ones(t.shape[0], dtype=bool)
    keep[1:] = np.diff(t) != 0
    n_dropped = int(t.shape[0] - keep.sum())
    if n_dropped == 0:
        return (t, *arrays, 0)
    return (t[keep], *(np.asarray(a)[keep] for a in arrays), n_dropped)


HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
MAT5_MAGIC = b"MATLAB 5.0"
ZIP_MAGICS = (b"PK\x03\x04", b"PK\x05\x06")


def read_head(path: Path, n: int = 1024) -> bytes:
    """The first ``n`` bytes of a file, with I/O errors as FormatError."""
    with reading(path, "cannot open file"), open(path, "rb") as fh:
        return fh.read(n)


def describe_content(head: bytes) -> str:
    """A short human description of what a file's first bytes look like."""
    if not head:
        return "an empty file"
    if head.startswith(HDF5_MAGIC):
        return "an HDF5 file"
    if head.startswith(MAT5_MAGIC):
        return "a MATLAB 5.0 file"
    if head.startswith(b"MATLAB 7.3"):
        return "a MATLAB 7.3 (HDF5-based) file"
    if head.startswith(ZIP_MAGICS):
        return "a zip archive"
    if head.startswith(b"\x93NUMPY"):
        return "a single .npy array"
    if b"\x00" in head:
        return f"binary data starting {head[:8]!r}"
    text = head.decode("utf-8", errors="replace").strip().splitlines()
    return f"text starting {text[0][:40]!r}" if text else "a blank text file"


def expect_magic(path: Path, magic, what: str) -> bytes:
    """Check the file starts with ``magic`` (bytes or tuple of bytes); return its head."""
    head = read_head(path)
    if not head.startswith(magic):
        raise FormatError(path, f"expected {what}, found {describe_content(head)}")
    return head
