"""The files of an export folder: confined to it, and their NPZ archives measured before they are read.

A file of an export folder is opened by :func:`open_confined` only when it
is a regular file of its own inside the folder:

- a path that resolves (links followed) outside the folder is refused;
- a **symbolic link** is refused, even one to a file inside: an export
  made by skillbank holds none, so one is either hand-made or hostile;
- a **hard link** (a file with more than one name, ``st_nlink > 1``) is
  refused: a hard link to a file outside the folder cannot be told from
  the file itself (it *is* that file), so the only way to keep an import
  from reading outside the folder is to accept no file that has another
  name. An export made by skillbank never has one. A backup tool that
  hard-links unchanged files (``rsync --link-dest``, ``cp -al``) makes
  them: copy such a folder (``cp -r``) to import it;
- a folder, FIFO, socket or device is refused after ``os.lstat``, without
  being opened (a FIFO would block).

:func:`measure_npz` reads only an archive's directory and each ``.npy``
member's header (a few hundred bytes each): the bytes the arrays will take
once decompressed, each header checked against its member's declared size.
:func:`skillbank.store._manifest.read_export` adds them up over the whole
export and compares the total with the import's bound before any array is
read; :func:`load_arrays` then reads an archive, checking it is the very file
measured.
"""

from __future__ import annotations

import os
import stat
import zipfile
import zlib

import numpy as np

from ._arrays import npy_bytes, npy_header

__all__ = ["open_confined", "measure_npz", "load_arrays", "MAX_MEMBERS"]

#: Most arrays one NPZ file of an export may hold (a demonstration's t, streams and metadata).
MAX_MEMBERS = 4096
_READ_ERRORS = (ValueError, OSError, EOFError, KeyError, TypeError, RuntimeError, NotImplementedError,
                MemoryError, zipfile.BadZipFile, zlib.error, UnicodeError)
_KINDS = {stat.S_IFDIR: "a folder", stat.S_IFIFO: "a FIFO", stat.S_IFSOCK: "a socket",
          stat.S_IFCHR: "a character device", stat.S_IFBLK: "a block device", stat.S_IFLNK: "a symbolic link"}


def _unreadable(shown: str, exc: OSError) -> ValueError:
    return ValueError(f"{shown}: expected a readable file, got {exc.strerror or type(exc).__name__}")


def open_confined(root: str, entry: str, shown: str):
    """Open ``entry`` for reading if it is a regular file of its own inside the folder ``root``.

    ``root`` is the folder's real path; ``shown`` starts every message. See
    the module docstring for what is refused and why. The file is opened
    without following links and must be the very file checked.

    Returns
    -------
    binary file object
    """
    path = os.path.join(root, entry)
    real = os.path.realpath(path)
    if os.path.commonpath([root, real]) != root:
        raise ValueError(f"{shown}: expected a file inside the export folder, got a path "
                         "that leads outside it")
    try:
        before = os.lstat(real)
    except FileNotFoundError:
        raise ValueError(f"{shown}: expected a file of the export, got a missing file") from None
    except OSError as exc:
        raise _unreadable(shown, exc) from None
    if os.path.normpath(path) != real:  # some part of the path is a link (to somewhere inside)
        raise ValueError(f"{shown}: expected a regular file, got a path through a symbolic link (an export "
                         "made by skillbank has none: put the file itself there)")
    if not stat.S_ISREG(before.st_mode):
        kind = _KINDS.get(stat.S_IFMT(before.st_mode), "something else")
        raise ValueError(f"{shown}: expected a regular file, got {kind}")
    # O_NONBLOCK: should the path be swapped for a FIFO meanwhile, opening it must not wait for a writer.
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) \
        | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(real, flags)
    except OSError as exc:
        raise _unreadable(shown, exc) from None
    after = os.fstat(fd)
    if not stat.S_ISREG(after.st_mode) or (after.st_dev, after.st_ino) != (before.st_dev, before.st_ino):
        os.close(fd)
        raise ValueError(f"{shown}: expected a file that stays put, got one replaced while "
                         "being imported")
    if after.st_nlink > 1:
        os.close(fd)
        raise ValueError(f"{shown}: expected a file of its own, got one with {after.st_nlink} hard links (a "
                         "hard link may be a file outside the folder; an export made by skillbank has none: "
                         "copy the folder with 'cp -r' to import it)")
    return os.fdopen(fd, "rb")


class _Refused(Exception):
    """A reason of our own (quoting nothing from the file) to refuse an NPZ file."""


def _identity(fh) -> tuple:
    s = os.fstat(fh.fileno())
    return s.st_dev, s.st_ino, s.st_size, s.st_mtime_ns


def _members(fh, shown: str) -> list:
    if fh.read(4) not in (b"PK\x03\x04", b"PK\x05\x06"):
        raise ValueError(f"{shown}: expected an NPZ archive, got a file that is not one")
    fh.seek(0)
    zf = zipfile.ZipFile(fh)
    infos = zf.infolist()
    if len(infos) > MAX_MEMBERS:
        raise _Refused(f"{len(infos)} members (an export's NPZ files hold at most {MAX_MEMBERS})")
    names = [i.filename for i in infos]
    if any(not n.endswith(".npy") for n in names) or len(set(names)) != len(names):
        raise _Refused("a member that is not a .npy array, or one repeated")
    return zf, infos


def _header(zf, info) -> tuple:
    """``(shape, fortran, dtype)`` of a member, its header checked against the member's declared size."""
    with zf.open(info) as fh:
        try:
            shape, fortran, dtype = npy_header(fh)
        except ValueError as exc:
            raise _Refused(str(exc).split(", got ", 1)[-1]) from None  # npy_header's "got" part
        size, start = npy_bytes(shape, dtype), fh.tell()
    if dtype.kind not in "biufU":
        raise _Refused(f"an array of {dtype.kind}-kind values, neither numbers nor text")
    if start + size != info.file_size:  # numpy allocates what the header says before reading
        raise _Refused(f"an array header declaring {size} bytes of data, while its member holds "
                       f"{max(info.file_size - start, 0)}")
    return shape, fortran, dtype


def _guarded(shown: str, work):
    try:
        return work()
    except _Refused as exc:
        raise ValueError(f"{shown}: expected an NPZ archive of numeric arrays, got {exc}") from None
    except _READ_ERRORS as exc:  # their messages may quote the file's bytes: name the kind only
        if isinstance(exc, ValueError) and str(exc).startswith(shown):
            raise
        raise ValueError(f"{shown}: expected an NPZ archive written by 'library export', "
                         f"got one that cannot be read ({type(exc).__name__})") from None


def measure_npz(root: str, entry: str, shown: str) -> tuple:
    """``(bytes its arrays take once read, the file's identity)``, reading only directory and headers."""
    with open_confined(root, entry, shown) as fh:
        def work():
            zf, infos = _members(fh, shown)
            with zf:
                for info in infos:
                    _header(zf, info)
            return sum(info.file_size for info in infos)

        return _guarded(shown, work), _identity(fh)


def load_arrays(root: str, entry: str, shown: str, identity=None) -> dict:
    """The arrays of an NPZ file of the export, read without unpickling; messages start with ``shown``.

    ``identity``, from :func:`measure_npz`, must be the file's still (else
    it changed since it was measured, and is refused).
    """
    with open_confined(root, entry, shown) as fh:
        if identity is not None and _identity(fh) != identity:
            raise ValueError(f"{shown}: expected a file that stays put, got one changed while being imported")

        def work():
            zf, infos = _members(fh, shown)
            arrays = {}
            with zf:
                for info in infos:
                    _header(zf, info)
                    with zf.open(info) as member:
                        arrays[info.filename[:-4]] = np.lib.format.read_array(member, allow_pickle=False)
            return arrays

        return _guarded(shown, work)
