"""The bounds on what a robot description may hold, and the reading of its files.

Every file of a description (the main URDF or MJCF, each included MJCF, each
mesh, texture, height field and skin) is read here, once, as the bytes of a
regular file inside the description's folder; MuJoCo gets only those bytes.
Each bound is checked before the work it bounds and has an environment
variable that raises it (docs/robots.md, "Any arm").
"""

from __future__ import annotations

import os
import stat

import numpy as np

__all__ = ["BOUNDS", "description_bound", "over_bound", "Budget", "inside", "read_regular_file", "check_png"]

#: Each bound: (default, what it counts). The variable is ``SKILLBANK_MAX_DESCRIPTION_<KEY>``. The
#: defaults are measured (docs/robots.md): MuJoCo's parser grows faster than linearly in the elements
#: (10,000 materials take 5.6 s, a 400-link URDF 5.6 s, 200 links of 5 boxes each 5.6 s) and a chain's
#: capsules and self-collision pairs with its bodies (a 100-link URDF loads in 12 s, 200 links in 41 s).
BOUNDS: dict[str, tuple[int, str]] = {
    "FILE_BYTES": (64 * 2 ** 20, "bytes in one file"),
    "BYTES": (256 * 2 ** 20, "bytes in all its files"),
    "INCLUDES": (100, "included files"),
    "ELEMENTS": (5000, "XML elements"),
    "BODIES": (100, "bodies (links)"),
    "JOINTS": (100, "joints"),
    "GEOMS": (1000, "geoms (visual and collision)"),
    "PIXELS": (2 ** 25, "pixels in one image"),
}


def description_bound(key: str, environ=None) -> int:
    """The bound ``key`` of :data:`BOUNDS`: ``$SKILLBANK_MAX_DESCRIPTION_<KEY>``, else its default.

    Examples
    --------
    >>> description_bound("BODIES", {})
    100
    >>> description_bound("BODIES", {"SKILLBANK_MAX_DESCRIPTION_BODIES": "1e3"})
    1000
    """
    environ = os.environ if environ is None else environ
    variable = f"SKILLBANK_MAX_DESCRIPTION_{key}"
    text = environ.get(variable, "").strip()
    if not text:
        return BOUNDS[key][0]
    try:
        number = float(text)
    except ValueError:
        number = float("nan")
    if not np.isfinite(number) or number < 1 or number != int(number):
        raise ValueError(f"{variable}: expected a whole number >= 1 (e.g. 1e4), got {text!r}"[:200])
    return int(number)


def over_bound(path, count: int, key: str, what: str | None = None) -> None:
    """Raise the one-line error of a description over bound ``key``, naming the variable that raises it."""
    bound = description_bound(key)
    if count > bound:
        raise ValueError(f"robot description {path}: {count} {what or BOUNDS[key][1]}, more than the bound "
                         f"of {bound}; set SKILLBANK_MAX_DESCRIPTION_{key} to a larger number to read it")


class Budget:
    """The bytes read so far for one description, against the per-file and total bounds."""

    def __init__(self):
        self.per_file = description_bound("FILE_BYTES")
        self.total = description_bound("BYTES")
        self.used = 0

    def take(self, path, shown: str, size: int) -> None:
        if size > self.per_file:
            raise ValueError(f"robot description {path}: {shown} has {size} bytes, more than the bound "
                             f"of {self.per_file} bytes in one file; set "
                             "SKILLBANK_MAX_DESCRIPTION_FILE_BYTES to a larger number to read it")
        if self.used + size > self.total:
            raise ValueError(f"robot description {path}: its files hold more than the bound of {self.total} "
                             f"bytes in all ({shown} would make {self.used + size}); set "
                             "SKILLBANK_MAX_DESCRIPTION_BYTES to a larger number to read it")
        self.used += size


def inside(folder: str, candidate: str) -> bool:
    """Whether ``candidate`` lies in ``folder`` (a real path), written and once its links are followed.

    Only the written path's links are followed (``os.path.realpath``, which reads no file); a path written
    out of the folder is never looked at.
    """
    written = os.path.normpath(candidate)
    if os.path.commonpath([folder, written]) != folder:
        return False
    return os.path.commonpath([folder, os.path.realpath(written)]) == folder


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a device"),
                       (stat.S_ISBLK, "a device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def read_regular_file(real: str, path, shown: str, budget: Budget) -> bytes:
    """The bytes of the regular file ``real``; anything else (a FIFO, a device) is refused unopened.

    ``path`` is the description file that names it and ``shown`` how the message names the reference.
    The size is checked against ``budget`` before a byte is read; the file is opened without following
    a link and without blocking, and checked again once open.
    """
    def refuse(mode) -> None:
        raise ValueError(f"robot description {path}: {shown} is {_kind(mode)}, not a regular file; give a "
                         "regular file inside the description's folder")

    try:
        before = os.stat(real)
        if not stat.S_ISREG(before.st_mode):
            refuse(before.st_mode)  # never opened: a FIFO would block, a device be read
        budget.take(path, shown, before.st_size)
        fd = os.open(real, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise ValueError(f"robot description {path}: {shown} cannot be read ({e.strerror or e})") from None
    try:
        now = os.fstat(fd)
        if not stat.S_ISREG(now.st_mode):  # replaced between the check and the opening
            refuse(now.st_mode)
        chunks, size = [], 0
        while size <= before.st_size:
            chunk = os.read(fd, min(1 << 20, before.st_size + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as e:
        raise ValueError(f"robot description {path}: {shown} cannot be read ({e.strerror or e})") from None
    finally:
        os.close(fd)
    if size != before.st_size:
        raise ValueError(f"robot description {path}: {shown} changed while it was read; read it again")
    return b"".join(chunks)


def check_png(data: bytes, path, shown: str) -> None:
    """Refuse a PNG whose header promises more pixels than the bound: a few kilobytes of zeros can decode
    to gigabytes, and MuJoCo decodes every texture and height field."""
    if data[:8] != b"\x89PNG\r\n\x1a\n" or len(data) < 24:
        return
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    over_bound(path, width * height, "PIXELS", f"pixels in {shown} ({width} x {height})")

