"""Opening HDF5 files so that nothing outside the file is ever read.

HDF5 lets a file point elsewhere: an *external link* names an object in
another file, a dataset with *external storage* keeps its bytes in other
(raw) files, and a *virtual dataset* maps other files' datasets. h5py
follows all three when the object is read, so a file handed to skillbank
could make it read (and store) any file the user can read. Every reader
opens HDF5 files with :func:`open_h5`, which refuses such a file before any
dataset is read. Soft links are allowed: they name a path inside the same
file, and since the file holds no external link they cannot leave it.
"""

from __future__ import annotations

from contextlib import contextmanager

from ._errors import HDF5_MAGIC, FormatError, as_file, expect_magic, reading

__all__ = ["open_h5", "check_self_contained"]

_FIX = "skillbank reads only data stored in the file itself: copy the data into the file and read it again"


def _outside_link(name, link):
    import h5py  # slow to import; only when an HDF5 file is read

    if isinstance(link, h5py.ExternalLink):
        return f"'{name}' is an external link to '{link.path}' in file '{link.filename}'"
    if not isinstance(link, (h5py.HardLink, h5py.SoftLink)):
        return f"'{name}' is a link of an unknown class ({type(link).__name__}), which may lead outside it"
    return None


def _outside_data(name, obj):
    import h5py  # as above

    if not isinstance(obj, h5py.Dataset):
        return None
    if obj.is_virtual:
        sources = sorted({s.file_name for s in obj.virtual_sources()})
        return f"dataset '{name}' is a virtual dataset mapping data of {sources}"
    if obj.external:
        files = sorted({str(entry[0]) for entry in obj.external})
        return f"dataset '{name}' keeps its data in external file(s) {files}"
    return None


def check_self_contained(path, h5) -> None:
    """Raise a :class:`FormatError` if the open file ``h5`` refers to data outside itself.

    Every link reachable from the root is looked at without being followed
    (``visititems_links``): an external link (or a link of an unknown
    class) is refused. Then every dataset (``visititems``, hard links only,
    each object once even in a cycle) is checked for external storage and
    for being virtual. Nothing is read from a dataset.
    """
    problem = h5.visititems_links(_outside_link) or h5.visititems(_outside_data)
    if problem is not None:
        raise FormatError(path, f"{problem}: the file refers to data outside itself; {_FIX}")


@contextmanager
def open_h5(path, what: str = "corrupt HDF5 file"):
    """Open a regular HDF5 file for reading, checked to hold all its data itself.

    ``path`` must be a regular file (see :func:`~skillbank.io._errors.as_file`)
    that starts with the HDF5 signature. Errors inside the block (h5py's,
    numpy's) become one-line FormatErrors prefixed with ``what``.
    """
    import h5py  # as above

    p = as_file(path)
    expect_magic(p, HDF5_MAGIC, "HDF5 content")
    with reading(p, what), h5py.File(p, "r") as h5:
        check_self_contained(p, h5)
        yield h5
