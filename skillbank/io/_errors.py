"""The reading error, and small helpers every reader shares.

Every problem met while reading a file becomes a :class:`FormatError` whose
message is one line, ``cannot read '<path>': <reason>``, so that users never
see a traceback from inside h5py, scipy or numpy.
"""

from __future__ import annotations

import csv
import os
import stat
import struct
import zipfile
import zlib
from contextlib import contextmanager
from pathlib import Path

import numpy as np

__all__ = [
    "FormatError", "HDF5_MAGIC", "MAT5_MAGIC", "ZIP_MAGICS",
    "TIME_REPAIRS", "as_file", "check_clock", "check_repair_time", "describe_content", "expect_magic",
    "reading", "read_head", "real_array", "kind_of", "file_problem", "open_regular",
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
    ArithmeticError,
    SystemError,  # h5py walking the links of a corrupt file
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
    """Return ``path`` as a Path, raising FormatError unless it is a regular file (or a link to one).

    Checked with ``os.stat`` before anything opens it: a FIFO, a device or
    a socket would block a reader or never end.
    """
    try:
        p = Path(path)
    except TypeError:
        raise FormatError(path, f"expected a file path, got {type(path).__name__}") from None
    problem = file_problem(p)
    if problem is not None:
        folder = problem.endswith("a directory")
        raise FormatError(p, "expected a file, found a directory" if folder else problem)
    return p


_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def kind_of(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, in words ("a regular file", "a FIFO (named pipe)", ...)."""
    if stat.S_ISREG(mode):
        return "a regular file"
    return next((what for test, what in _KINDS if test(mode)), "not a regular file")


def file_problem(path) -> str | None:
    """Why ``path`` cannot be read as an input file (missing, a folder, a FIFO, ...), or None.

    ``os.stat`` only: nothing is opened, so a FIFO cannot block.
    """
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "no such file" if not os.path.islink(path) else "a symbolic link to nothing"
    except OSError as exc:
        return f"cannot inspect it: {os.strerror(exc.errno) if exc.errno else exc}"
    if stat.S_ISREG(mode):
        return None
    return f"expected a regular file, found {kind_of(mode)}"


@contextmanager
def open_regular(path):
    """Open ``path`` for binary reading only if it is a regular file: a FIFO or device never blocks.

    Opened with ``O_NONBLOCK`` and checked with ``fstat`` on the open
    descriptor, so a path swapped after an earlier check is caught too.
    """
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise FormatError(path, f"cannot open file: {exc.strerror or exc}") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise FormatError(path, f"expected a regular file, found {kind_of(mode)}")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        fh = os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise
    with fh:
        yield fh


#: The repairs a reader may apply to a clock that does not increase (its ``repair_time`` option).
TIME_REPAIRS = (None, "drop")


def check_repair_time(repair_time):
    """Validate a reader's ``repair_time`` option.

    Examples
    --------
    >>> check_repair_time("drop")
    'drop'
    """
    if repair_time not in TIME_REPAIRS:
        raise ValueError(f"repair_time: expected None (time stamps that do not increase are an error) or "
                         f"'drop' (drop samples that repeat the previous stamp), got {repair_time!r}")
    return repair_time


def check_clock(path, t, *arrays, where: str, repair_time=None):
    """Check that a stream's time stamps increase strictly: ``(t, arrays..., n_dropped)``.

    A recorder that repeats a stamp, a clock that runs backwards or one that
    never advances (all stamps equal) would otherwise lose samples silently or
    fail deep inside; each is a :class:`FormatError` naming the stream and
    its clock (``where``, e.g. ``"stream 'joints' (clock 'joint_state_info/joint_time')"``),
    the first offending sample (its index in the file) and how many steps do
    not increase. With ``repair_time="drop"`` (the documented repair) samples
    whose stamp repeats the previous one are dropped, keeping the first, and
    counted in ``n_dropped``; a clock that runs backwards, or that leaves
    fewer than 2 samples of several, is still an error.

    Examples
    --------
    >>> check_clock("a.csv", [0.0, 1.0, 1.0, 2.0], [[0], [1], [2], [3]], where="stream 'position'",
    ...             repair_time="drop")[2]
    1
    """
    check_repair_time(repair_time)
    t = np.asarray(t, dtype=float).ravel()
    n = t.shape[0]
    if n < 2 or not np.isfinite(t).all():  # NaN and inf are the validator's to name
        return (t, *arrays, 0)
    steps = np.diff(t)
    bad = np.flatnonzero(steps <= 0)
    if bad.size == 0:
        return (t, *arrays, 0)
    backwards = np.flatnonzero(steps < 0)
    if repair_time == "drop" and backwards.size == 0 and np.any(steps > 0):
        keep = np.ones(n, dtype=bool)
        keep[1:] = steps > 0
        return (t[keep], *(np.asarray(a)[keep] for a in arrays), int(n - keep.sum()))
    i = int((backwards if backwards.size else bad)[0]) + 1
    what = "runs back from" if t[i] < t[i - 1] else "repeats"
    reason = (f"{where}: expected strictly increasing time stamps, but sample {i} "
              f"({float(t[i])!r} s) {what} sample {i - 1} ({float(t[i - 1])!r} s); {bad.size} of {n - 1} "
              "steps do not increase")
    if not np.any(steps > 0):
        reason += " (the clock never advances, so no repair applies)"
    elif backwards.size == 0:
        reason += "; read with repair_time='drop' to drop the repeated stamps (keeping the first)"
    raise FormatError(path, reason)


def real_array(path, value, what: str) -> np.ndarray:
    """``value`` (a dataset's content) as float64; complex or non-numeric content is a FormatError.

    Casting complex data to float would drop the imaginary part with only a
    ``ComplexWarning``.

    Examples
    --------
    >>> real_array("a.h5", [1, 2], "'t'").tolist()
    [1.0, 2.0]
    """
    raw = np.asarray(value)
    if raw.dtype.kind == "c":
        raise FormatError(path, f"expected real numbers in {what}, found complex values ({raw.dtype})")
    try:
        return raw.astype(float)
    except (TypeError, ValueError):
        raise FormatError(path, f"expected numbers in {what}, found {raw.dtype} values") from None


HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
MAT5_MAGIC = b"MATLAB 5.0"
ZIP_MAGICS = (b"PK\x03\x04", b"PK\x05\x06")


def read_head(path: Path, n: int = 1024) -> bytes:
    """The first ``n`` bytes of a file, with I/O errors as FormatError."""
    with open_regular(path) as fh, reading(path, "cannot read file"):
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
    # Never quote the bytes: a file named by mistake (or by a hostile manifest) may hold secrets.
    if b"\x00" in head:
        return "binary data"
    return "a text file" if head.strip() else "a blank text file"


def expect_magic(path: Path, magic, what: str) -> bytes:
    """Check the file starts with ``magic`` (bytes or tuple of bytes); return its head."""
    head = read_head(path)
    if not head.startswith(magic):
        raise FormatError(path, f"expected {what}, found {describe_content(head)}")
    return head
