"""Reader for the RAIL benchmark (MATLAB v5 files ``<SKILL>/<user>.mat``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core import Demonstration
from ..core._validation import summarise
from ._errors import (
    MAT5_MAGIC,
    FormatError,
    as_file,
    check_clock,
    check_repair_time,
    expect_magic,
    reading,
    real_array,
)

__all__ = ["read_rail_file", "load_rail", "RAIL_CLASSES"]

RAIL_CLASSES = ("reaching", "pushing", "pressing", "writing")
_FIELDS = {"time": None, "pos": "position", "vel": "velocity", "acc": "acceleration"}


def _field(path, record, field: str, i: int) -> np.ndarray:
    if not hasattr(record, field):
        found = summarise(map(repr, getattr(record, "_fieldnames", [])))
        raise FormatError(path, f"expected a field '{field}' in dataset[{i}], found fields [{found}]")
    with reading(path, f"invalid field dataset[{i}].{field}"):
        return real_array(path, getattr(record, field), f"dataset[{i}].{field}")


def read_rail_file(path, *, repair_time=None) -> list[Demonstration]:
    """Read every demonstration of one RAIL user file.

    Parameters
    ----------
    path : str or path-like
        A MATLAB v5 file ``<SKILL>/<user>.mat`` holding an ``(n_demos, 1)``
        struct array ``dataset`` with fields ``time``, ``pos``, ``vel`` and
        ``acc``.
    repair_time : {None, "drop"}, default=None
        Time stamps that repeat, run backwards or never advance are an error
        naming the demonstration and the sample. ``"drop"`` drops samples
        that repeat the previous stamp (keeping the first), counted in
        ``metadata["dropped_samples"]``; the published files need no repair.

    Returns
    -------
    list of Demonstration
        Streams ``position``, ``velocity`` and ``acceleration``; metadata
        ``label`` (the parent folder lower-cased, e.g. ``"reaching"``),
        ``user`` (the file stem), ``index`` (position in the file), ``source``
        and ``format`` (``"rail-mat"``).

    Raises
    ------
    FormatError
        If the file is not MATLAB v5 or lacks ``dataset`` or its fields, or a
        demonstration's time stamps do not increase (see ``repair_time``).

    Examples
    --------
    >>> demos = read_rail_file("rail/REACHING/1.mat")  # doctest: +SKIP
    >>> demos[0].metadata["label"], demos[0]["position"].shape  # doctest: +SKIP
    ('reaching', (1000, 3))
    """
    from scipy.io import loadmat, whosmat  # scipy is slow to import; only for .mat files

    check_repair_time(repair_time)
    p = as_file(path)
    expect_magic(p, MAT5_MAGIC, "a MATLAB 5.0 file")
    with reading(p, "invalid MATLAB file"):
        # Reading only ``dataset`` skips the much larger raw recordings.
        mat = loadmat(p, struct_as_record=False, squeeze_me=False, variable_names=["dataset"])
    if "dataset" not in mat:
        with reading(p, "invalid MATLAB file"):
            found = summarise(map(repr, sorted(name for name, _, _ in whosmat(p))))
        raise FormatError(p, f"expected a variable 'dataset', found [{found}]")
    records = np.asarray(mat["dataset"])
    if records.dtype != object or records.size == 0:
        raise FormatError(
            p, f"expected 'dataset' to be a non-empty struct array, found {records.dtype} "
            f"of shape {records.shape}"
        )
    label, user = p.parent.name.lower(), p.stem
    demos = []
    for i, record in enumerate(records.ravel()):
        arrays = {key: _field(p, record, key, i) for key in _FIELDS}
        metadata = {"label": label, "user": user, "index": i, "source": str(p), "format": "rail-mat"}
        with reading(p, f"invalid demonstration dataset[{i}]"):
            t = arrays.pop("time").ravel()
            # Streams are stored (n, 3); a 1-D field becomes one column.
            columns = [arr.reshape(arr.shape[0], -1) for arr in arrays.values()]
            t, *columns, dropped = check_clock(p, t, *columns, repair_time=repair_time,
                                               where=f"demonstration dataset[{i}] (its 'time')")
            if dropped:
                metadata["dropped_samples"] = dropped
            streams = dict(zip((_FIELDS[key] for key in arrays), columns, strict=True))
            demos.append(Demonstration(t, streams, metadata))
    return demos


def _user_key(order: str):
    if order == "authors":
        return lambda f: f.stem
    # Natural order: numeric stems as numbers, anything else after them.
    return lambda f: (0, int(f.stem), "") if f.stem.isdigit() else (1, 0, f.stem)


def load_rail(folder, *, classes=None, order: str = "authors", repair_time=None) -> list[Demonstration]:
    """Load the RAIL dataset from its folder, class by class and user by user.

    Parameters
    ----------
    folder : str or path-like
        The folder holding ``REACHING/``, ``PUSHING/``, ``PRESSING/`` and
        ``WRITING/``, each with ``1.mat`` ... ``10.mat``.
    classes : iterable of str, optional
        The skills to load, case-insensitive, in this order. Default: reaching,
        pushing, pressing, writing.
    order : {"authors", "natural"}, default="authors"
        ``"authors"`` sorts the user files as strings (``1, 10, 2, ..., 9``),
        the order in which the RAIL paper's authors index demonstrations;
        ``"natural"`` sorts them as numbers.
    repair_time : {None, "drop"}, default=None
        Passed to :func:`read_rail_file`.

    Returns
    -------
    list of Demonstration
        See :func:`read_rail_file` for the streams and metadata. The full set
        holds 60 reaching, 60 pushing, 59 pressing and 30 writing demos.

    Raises
    ------
    FormatError
        If the folder or a class sub-folder is missing, or a file is unreadable.
    ValueError
        If ``order`` is not one of the two choices.

    Examples
    --------
    >>> demos = load_rail("rail", classes=["reaching", "pushing", "writing"])  # doctest: +SKIP
    >>> len(demos), demos[28].metadata["label"]  # doctest: +SKIP
    (150, 'reaching')
    """
    if order not in ("authors", "natural"):
        raise ValueError(f"order: expected 'authors' or 'natural', got {order!r}")
    check_repair_time(repair_time)
    root = Path(folder)
    if not root.is_dir():
        raise FormatError(root, "expected a RAIL folder with one sub-folder per skill, found no directory")
    if classes is None:
        classes = RAIL_CLASSES
    elif isinstance(classes, str):
        classes = [classes]
    subdirs = {d.name.lower(): d for d in root.iterdir() if d.is_dir()}
    demos = []
    for name in classes:
        key = str(name).lower()
        if key not in subdirs:
            found = summarise(map(repr, sorted(d.name for d in subdirs.values())))
            raise FormatError(root, f"expected a sub-folder for class {name!r}, found [{found}]")
        files = sorted(
            (f for f in subdirs[key].iterdir() if f.suffix.lower() == ".mat" and f.is_file()),
            key=_user_key(order),
        )
        if not files:
            raise FormatError(subdirs[key], "expected user files '<user>.mat', found none")
        for f in files:
            demos.extend(read_rail_file(f, repair_time=repair_time))
    return demos
