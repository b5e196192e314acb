"""How the store serialises values: arrays as ``.npy`` bytes (never pickles), the rest as JSON."""

from __future__ import annotations

import hashlib
import io
import json

import numpy as np

from ..io import to_jsonable

__all__ = ["to_npy", "from_npy", "npy_header", "npy_bytes", "to_json", "from_json", "content_hash"]


def to_npy(array) -> bytes:
    """Serialise a numeric array as ``.npy`` bytes (never a pickle).

    Examples
    --------
    >>> from_npy(to_npy(np.arange(3.0))).tolist()
    [0.0, 1.0, 2.0]
    """
    arr = np.asarray(array)
    if arr.dtype == object:
        raise ValueError(f"array: expected a numeric array, got dtype {arr.dtype}")
    buf = io.BytesIO()
    np.save(buf, arr, allow_pickle=False)
    return buf.getvalue()


def npy_header(fh) -> tuple:
    """``(shape, fortran_order, dtype)`` of the ``.npy`` header at ``fh``'s position, read without the data.

    Raises ValueError (saying what is wrong, quoting nothing) for bytes that
    are not a ``.npy`` header, a format version other than 1.0 or 2.0, or a
    dtype of Python objects (never unpickled).
    """
    try:
        version = np.lib.format.read_magic(fh)
    except ValueError:
        raise ValueError("expected .npy array bytes, got bytes that are not (no .npy magic)") from None
    if version not in ((1, 0), (2, 0)):
        raise ValueError(f"expected a .npy array of format 1.0 or 2.0, got format {version[0]}.{version[1]}")
    read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
    try:
        shape, fortran, dtype = read(fh)
    except (ValueError, SyntaxError, TypeError) as exc:  # numpy's text may quote the header: name the kind
        raise ValueError(f"expected a .npy array header, got one that cannot be read ({type(exc).__name__})"
                         ) from None
    if dtype.hasobject:
        raise ValueError("expected numbers, got an array of Python objects: not a numeric .npy array (never "
                         "unpickled)")
    return shape, fortran, dtype


def npy_bytes(shape, dtype) -> int:
    """Bytes of the data of an array of ``shape`` and ``dtype`` (exact, in Python integers)."""
    n = 1
    for k in shape:
        n *= int(k)
    return n * dtype.itemsize


def from_npy(blob) -> np.ndarray:
    """Load ``.npy`` bytes written by :func:`to_npy`, refusing pickles.

    The header is checked against the bytes that follow it before anything
    is allocated, so a blob of a few bytes declaring 10^11 values is refused
    in one line instead of asking for 745 GiB.

    Raises
    ------
    ValueError
        One line saying what is wrong with the bytes (quoting none of them).

    Examples
    --------
    >>> from_npy(to_npy(np.eye(2))).shape
    (2, 2)
    >>> from_npy(b"some text")
    Traceback (most recent call last):
    ...
    ValueError: expected .npy array bytes, got bytes that are not (no .npy magic)
    """
    if blob is None:
        raise ValueError("expected .npy array bytes, got NULL")
    if isinstance(blob, str):
        raise ValueError("expected .npy array bytes, got text")
    try:
        data = memoryview(blob).cast("B")
    except TypeError:  # SQLite keeps any type in any column
        raise ValueError(f"expected .npy array bytes, got a value of type {type(blob).__name__}") from None
    fh = io.BytesIO(data)
    shape, fortran, dtype = npy_header(fh)
    start, size = fh.tell(), npy_bytes(shape, dtype)
    if size != len(data) - start:
        raise ValueError(f"expected a .npy array whose header matches its data, got a header declaring "
                         f"{size} bytes of data ({dtype.str} of shape {shape}) followed by "
                         f"{len(data) - start}")
    flat = np.frombuffer(data, dtype=dtype, count=size // dtype.itemsize if dtype.itemsize else 0,
                         offset=start)
    # a copy: the array owns its memory and is writable, as np.load's is
    return (flat.reshape(shape[::-1]).T if fortran else flat.reshape(shape)).copy(order="K")


def to_json(obj) -> str:
    """JSON text of ``obj`` with numpy values and paths converted.

    Examples
    --------
    >>> to_json({"a": np.int64(2)})
    '{"a": 2}'
    """
    return json.dumps(to_jsonable(obj), allow_nan=False, sort_keys=True)


def from_json(text):
    """Parse JSON text stored by :func:`to_json` (``None`` stays ``None``)."""
    return None if text is None else json.loads(text)


def content_hash(demo) -> str:
    """SHA-256 over ``t``, every stream (name, dtype, shape, bytes, in order) and the metadata JSON.

    Two demonstrations with the same hash hold the same samples, streams and
    metadata; ``library import`` uses it to skip what a library already holds.

    Examples
    --------
    >>> from skillbank import Demonstration
    >>> a = Demonstration(np.arange(3.0), {"position": np.zeros((3, 2))}, {"user": 1})
    >>> b = Demonstration(np.arange(3.0), {"position": np.zeros((3, 2))}, {"user": 2})
    >>> content_hash(a) == content_hash(Demonstration(a.t, dict(a.streams), {"user": 1}))
    True
    >>> content_hash(a) == content_hash(b)
    False
    """
    h = hashlib.sha256()

    def field(data: bytes) -> None:  # length-prefixed, so field boundaries cannot be shifted
        h.update(len(data).to_bytes(8, "little"))
        h.update(data)

    for name, arr in (("t", demo.t), *demo.streams.items()):
        arr = np.ascontiguousarray(arr)
        field(name.encode("utf-8"))
        field(f"{arr.dtype.str} {arr.shape}".encode())
        field(arr.tobytes())
    field(to_json(demo.metadata).encode("utf-8"))
    return h.hexdigest()
