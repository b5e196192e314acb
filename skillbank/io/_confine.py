"""Inputs are regular files inside the folder they were given in; outputs are written whole or not at all.

A FIFO, a device or a socket given as an input would block a reader forever
(or read an endless stream), so every reader checks what a path is with
``os.stat`` before it opens it, and opens what it reads itself with
``O_NONBLOCK`` (so a path swapped for a FIFO after the check cannot block
either). Paths that a file names (a LeRobot ``data_path`` template, the
members of a ROS 2 bag folder, metadata files) must stay inside the dataset
folder: no ``..``, no absolute path, and no symbolic link whose target is
outside the folder. Symbolic links that stay inside the folder are followed
(datasets deduplicate files that way).
"""

from __future__ import annotations

import os
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path, PurePosixPath, PureWindowsPath

from ._errors import FormatError, file_problem, kind_of

__all__ = ["check_input_file", "check_input_folder", "atomic_output", "check_output_path", "inside",
           "MAX_READ_BYTES",
           "ReadBudget", "max_read_bytes"]

def check_input_file(path, *, name: str = "input") -> Path:
    """Return ``path`` as a Path if it is a regular file (or a link to one); else a one-line ValueError.

    FIFOs, devices, sockets and folders are refused before anything opens
    them: reading one would block, or never end.

    Parameters
    ----------
    path : str or path-like
    name : str, default="input"
        The argument's name, which starts the message.

    Examples
    --------
    >>> check_input_file("/dev/null", name="demo")
    Traceback (most recent call last):
    ...
    ValueError: demo: expected a regular file, got '/dev/null', a character device; give the path of a file
    """
    try:
        p = Path(path)
    except TypeError:
        raise ValueError(f"{name}: expected a file path, got {type(path).__name__}") from None
    problem = file_problem(p)
    if problem is None:
        return p
    found = problem.removeprefix("expected a regular file, found ")
    raise ValueError(f"{name}: expected a regular file, got {str(p)!r}, {found}; give the path of a file")


def check_input_folder(root, *, what: str = "a dataset folder") -> Path:
    """``root`` as a resolved Path if it is a folder whose entries are regular files or folders.

    Each entry is checked with ``lstat`` and, for a symbolic link, its
    target: a FIFO, device or socket, a link to one, or a link leaving the
    folder is a :class:`FormatError` naming the entry. Sub-folders are
    checked the same way, recursively (links to folders are not descended:
    their target is inside, and is checked where it is).
    """
    p = Path(root)
    try:
        real = Path(os.path.realpath(p))
        mode = os.stat(real).st_mode
    except OSError:
        raise FormatError(p, f"expected {what}, found no such folder") from None
    if not stat.S_ISDIR(mode):
        raise FormatError(p, f"expected {what}, found {kind_of(mode)}")
    for folder, dirs, files in os.walk(real):
        for entry in dirs + files:
            full = Path(folder) / entry
            rel = full.relative_to(real).as_posix()
            inside(p, rel, real=real, allow_dir=True, what="file")
    return real


def _outside(real_root: Path, target: Path) -> bool:
    return target != real_root and real_root not in target.parents


def inside(root, rel, *, real=None, allow_dir: bool = False, what: str = "path") -> Path:
    """The path ``rel`` (named by a file of the dataset ``root``) resolved, when it stays inside ``root``.

    ``rel`` must be a relative path without ``..``; following symbolic links
    it must stay inside ``root``; and if it exists it must be a regular file
    (or a folder, with ``allow_dir``). A missing path is returned as it is
    (the caller says what it expected there). Otherwise a
    :class:`FormatError` naming ``rel`` and ``root``.
    """
    if not isinstance(rel, str):
        raise FormatError(root, f"expected the {what} as a string, found {type(rel).__name__} {rel!r}")
    posix, windows = PurePosixPath(rel), PureWindowsPath(rel)
    if not rel or posix.is_absolute() or windows.is_absolute() or windows.drive or ".." in posix.parts \
            or ".." in windows.parts:
        raise FormatError(root, f"the {what} {rel!r} leaves the dataset folder: expected a relative path "
                          "inside it (no '..', not absolute); skillbank reads nothing outside the folder")
    real_root = Path(os.path.realpath(root)) if real is None else real
    full = real_root / posix
    target = Path(os.path.realpath(full))
    if _outside(real_root, target):
        raise FormatError(root, f"the {what} {rel!r} is a symbolic link (or under one) to {str(target)!r}, "
                          "outside the dataset folder; skillbank reads nothing outside the folder: copy the "
                          "file in instead")
    try:
        mode = os.stat(target).st_mode
    except FileNotFoundError:
        return target
    except OSError as exc:
        raise FormatError(root, f"cannot inspect the {what} {rel!r}: {exc.strerror or exc}") from None
    if not (stat.S_ISREG(mode) or (allow_dir and stat.S_ISDIR(mode))):
        raise FormatError(root, f"the {what} {rel!r} is {kind_of(mode)}: expected a regular file")
    return target


def _default_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def _output_target(path, *, name: str, folder_too: bool):
    """``(path, real path, stat or None)`` if ``path`` is new, a regular file or (``folder_too``) a folder."""
    try:
        p = Path(path)
    except TypeError:
        raise ValueError(f"{name}: expected a file path, got {type(path).__name__}") from None
    if not str(path):
        raise ValueError(f"{name}: expected a file path, got ''")
    target = Path(os.path.realpath(p))
    try:
        st = os.stat(target)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise ValueError(f"{name}: cannot inspect {str(p)!r}: {exc.strerror or exc}") from None
    if st is not None and not (stat.S_ISREG(st.st_mode) or (folder_too and stat.S_ISDIR(st.st_mode))):
        wanted = "a regular file or a folder" if folder_too else "a regular file"
        raise ValueError(f"{name}: expected {wanted} to write (or a new one), got {str(p)!r}, "
                         f"{kind_of(st.st_mode)}; give the path of a file")
    return p, target, st


def check_output_path(path, *, name: str = "out") -> Path:
    """``path`` if it is new, a regular file or a folder: never a FIFO, a device or a socket.

    Commands check their outputs with it before any work, so that a bad
    target is refused before anything is computed or written
    (:func:`atomic_output` checks again when the file is written).

    Examples
    --------
    >>> check_output_path("/dev/null", name="out")
    Traceback (most recent call last):
    ...
    ValueError: out: expected a regular file or a folder to write (or a new one), got '/dev/null', \
a character device; give the path of a file
    """
    return _output_target(path, name=name, folder_too=True)[0]


@contextmanager
def atomic_output(path, *, name: str = "out"):
    """Write an output file whole or not at all: yields a temporary path in the same folder.

    The caller writes the temporary file (it has the same suffix as
    ``path``, so writers that choose a format by suffix still work); when
    the block ends without an exception it replaces ``path`` in one step
    (``os.replace``), else it is removed and ``path`` is left as it was.
    An existing target that is not a regular file (a FIFO, a device, a
    folder) is refused before anything is written: writing to a FIFO would
    block, to a device would clobber it. A symbolic link at ``path`` (to a
    regular file or to nothing) is replaced by the new file, never written
    through: its target, which may be anywhere, is left as it was.

    Parameters
    ----------
    path : str or path-like
        The output file. Its folder must exist.
    name : str, default="out"
        The argument's name, which starts an error message.

    Raises
    ------
    ValueError
        A target that is not a regular file, or a folder that does not exist.

    Examples
    --------
    >>> import os, tempfile
    >>> out = os.path.join(tempfile.mkdtemp(), "r.txt")
    >>> with atomic_output(out) as tmp:
    ...     _ = tmp.write_text("done")
    >>> open(out).read()
    'done'
    """
    p, _, st = _output_target(path, name=name, folder_too=False)
    if os.path.islink(p):  # replaced, not written through: the new file takes the link's place
        st = None
    target = Path(os.path.realpath(p.parent)) / p.name
    folder = target.parent
    if not folder.is_dir():
        raise ValueError(f"{name}: the folder {str(p.parent)!r} of {str(p)!r} does not exist; "
                         "create it first")
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{target.name}.", suffix=f".part{target.suffix}")
    except OSError as exc:
        raise ValueError(f"{name}: cannot write in {str(p.parent)!r}: {exc.strerror or exc}") from None
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        os.chmod(tmp, stat.S_IMODE(st.st_mode) if st is not None else _default_mode())
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


#: Bytes a reader takes from one file at most (its datasets or tables as stored in memory); the
#: environment variable ``SKILLBANK_MAX_READ_BYTES`` sets another bound.
MAX_READ_BYTES = 1 << 30
READ_BYTES_VARIABLE = "SKILLBANK_MAX_READ_BYTES"


def max_read_bytes() -> int:
    """The bound on bytes read from one file: ``$SKILLBANK_MAX_READ_BYTES``, else :data:`MAX_READ_BYTES`."""
    raw = os.environ.get(READ_BYTES_VARIABLE)
    if raw is None or not raw.strip():
        return MAX_READ_BYTES
    try:
        value = int(raw)
    except ValueError:
        value = 0
    if value <= 0:
        raise ValueError(f"{READ_BYTES_VARIABLE}: expected a positive number of bytes, got {raw[:40]!r}")
    return value


class ReadBudget:
    """What is left of :func:`max_read_bytes` while one file is read; checked before each read.

    A file of a few kilobytes can declare a dataset of gigabytes (a chunked
    HDF5 dataset whose chunks were never written reads as its fill value; a
    parquet column of one repeated value compresses to nothing): the
    declared size is checked before the read allocates it.
    """

    def __init__(self, path):
        self.path, self.limit = path, max_read_bytes()
        self.left = self.limit

    def take(self, n_bytes: int, what: str) -> None:
        """Count ``n_bytes`` of ``what``, or raise a FormatError saying the bound and how to lift it."""
        if n_bytes > self.left:
            read = self.limit - self.left
            raise FormatError(self.path, f"{what} would take {n_bytes} bytes in memory, and with the {read} "
                              f"bytes read before it that passes the bound of {self.limit} bytes read from "
                              f"one file; set {READ_BYTES_VARIABLE} to read more")
        self.left -= n_bytes

    def dataset(self, dset, name: str):
        """The content of an h5py dataset, counted against the bound first."""
        self.take(int(dset.size) * dset.dtype.itemsize, f"dataset '{name}' ({dset.shape}, {dset.dtype})")
        return dset[()]
