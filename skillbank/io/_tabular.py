"""Generic formats: CSV (one stream), NPZ (all streams + metadata) and JSON results."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..core import Demonstration
from ..core._validation import check_array
from ._confine import atomic_output
from ._errors import ZIP_MAGICS, FormatError, as_file, expect_magic, open_regular, reading

__all__ = [
    "read_csv", "read_feature_matrix", "write_csv", "read_npz", "write_npz", "write_json", "to_jsonable",
]


def _check_demo(demo) -> None:
    if not isinstance(demo, Demonstration):
        raise TypeError(f"demo: expected a Demonstration, got {type(demo).__name__}")


def _csv_problem(lines: list[str], width: int, header: bool = True, skipped: int = 0) -> str:
    """Find the first malformed data row, for an error message numpy cannot give (``skipped``: comment
    lines before ``lines`` in the file, for the line numbers)."""
    first = 2 if header else 1
    for lineno, line in enumerate(lines[first - 1:], start=first + skipped):
        if not line.strip():
            continue
        cells = line.split(",")
        if len(cells) != width:
            what = "in the header" if header else "in the first row"
            return f"line {lineno}: expected {width} values as {what}, found {len(cells)}"
        for col, cell in enumerate(cells, start=1):
            try:
                float(cell)
            except ValueError:
                return f"line {lineno}, column {col}: expected a number, found {cell.strip()[:30]!r}"
    return "expected a numeric table"


def _table(p, lines: list[str], header: bool, skipped: int = 0) -> np.ndarray:
    """The numeric rows of a comma-separated table (after a header row when ``header``)."""
    rows = lines[1:] if header else lines
    width = len(lines[0].split(","))
    try:
        table = np.loadtxt(rows, delimiter=",", dtype=float, ndmin=2)
    except ValueError:
        raise FormatError(p, _csv_problem(lines, width, header, skipped)) from None
    if table.shape[1] != width:
        raise FormatError(p, _csv_problem(lines, width, header, skipped))
    return table


def _text_lines(p) -> list[str]:
    with open_regular(p) as fh, reading(p, "expected a UTF-8 text file"):
        text = fh.read().decode("utf-8-sig")
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    return lines


#: How an exported trajectory's comment line states the law and limits it was timed for (JSON follows).
TIMING_COMMENT = "# skillbank timing: "


def _timing_comment(comments: list[str]):
    """The ``timing`` metadata a comment line states (:data:`TIMING_COMMENT`), else None."""
    for line in comments:
        if line.startswith(TIMING_COMMENT):
            try:
                value = json.loads(line[len(TIMING_COMMENT):])
            except ValueError:
                return None  # a comment, not ours to refuse
            return value if isinstance(value, dict) else None
    return None


def read_csv(path) -> Demonstration:
    """Read a CSV file: a header row, a first column ``t``, then one stream (or a written reproduction).

    Returns
    -------
    Demonstration
        Stream ``position`` holds every column after ``t``. A file written
        by :func:`skillbank.io.write_trajectory` (columns ``position_...``,
        then ``orientation_x..w``, ``gripper_0``, ``joints_<name>``, ...) is
        read back stream by stream, with ``metadata["joint_names"]``.
        Metadata holds ``source``, ``format`` (``"csv"``) and ``columns``
        (the header names of the columns after ``t``). Lines starting with
        ``#`` before the header are comments; an export's timing line
        (:data:`TIMING_COMMENT`) comes back as ``metadata["timing"]``.

    Raises
    ------
    FormatError
        If the file is empty, has no header, or has a non-numeric cell or a
        row of the wrong length (the message gives the line), or if ``t`` is
        not strictly increasing.

    Examples
    --------
    >>> import os, tempfile
    >>> path = write_csv(Demonstration.from_array(np.eye(2)), os.path.join(tempfile.mkdtemp(), "d.csv"))
    >>> read_csv(path)["position"].tolist()
    [[1.0, 0.0], [0.0, 1.0]]
    """
    p = as_file(path)
    lines = _text_lines(p)
    # comment lines before the header: an exported trajectory states its timing there
    comments = next((i for i, line in enumerate(lines) if not line.startswith("#")), len(lines))
    timing = _timing_comment(lines[:comments])
    lines = lines[comments:]
    if not lines:
        raise FormatError(p, "expected a header row starting with 't', found an empty file")
    header = [cell.strip() for cell in lines[0].split(",")]
    if header[0].lower() != "t":
        raise FormatError(p, f"line {comments + 1}: expected a header row starting with 't', found "
                             f"{lines[0][:60]!r}")
    if len(header) < 2:
        raise FormatError(p, "line 1: expected 't' and at least one data column, found only 't'")
    if len(lines) < 2:
        raise FormatError(p, "expected at least one data row after the header, found none")
    table = _table(p, lines, header=True, skipped=comments)
    metadata = {"source": str(p), "format": "csv", "columns": header[1:]}
    if timing is not None:
        metadata["timing"] = timing
    groups = _stream_groups(header[1:])
    with reading(p, "invalid data"):
        if groups is None:
            return Demonstration(table[:, 0], {"position": table[:, 1:]}, metadata)
        streams = {name: table[:, 1 + a:1 + b] for name, (a, b) in groups.items()}
        if "joints" in groups:
            a, b = groups["joints"]
            metadata["joint_names"] = [c[len("joints_"):] for c in header[1 + a:1 + b]]
        return Demonstration(table[:, 0], streams, metadata)


def _stream_groups(columns) -> dict | None:
    """Columns ``<stream>_<suffix>`` grouped by stream, as a reproduction is written; None otherwise.

    Only a file whose first columns are ``position_...`` and that holds at
    least two streams, each in one block of columns, is read as several
    streams (what :func:`skillbank.io.write_trajectory` writes); anything else
    stays one ``position`` stream, as CSV files always were read.

    Examples
    --------
    >>> _stream_groups(["position_0", "position_1", "gripper_0"])
    {'position': (0, 2), 'gripper': (2, 3)}
    >>> _stream_groups(["x", "y"]) is None
    True
    """
    names = [c.split("_", 1)[0] if "_" in c else None for c in columns]
    if None in names or names[0] != "position" or len(set(names)) < 2:
        return None
    groups: dict = {}
    for k, name in enumerate(names):
        if name in groups and groups[name][1] != k:
            return None  # a stream's columns apart: not a file written stream by stream
        groups[name] = (groups[name][0] if name in groups else k, k + 1)
    return groups


def read_feature_matrix(path) -> np.ndarray:
    """A feature matrix ``(n_samples, n_features)`` from ``.npy`` (no pickles) or ``.csv`` (header optional).

    Raises
    ------
    FormatError
        If the file cannot be parsed as a 2-D finite numeric matrix (the
        message gives the first bad line).

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "f.csv")
    >>> _ = open(path, "w").write("a,b\\n1,2\\n3,4\\n")
    >>> read_feature_matrix(path).tolist()
    [[1.0, 2.0], [3.0, 4.0]]
    """
    p = as_file(path)
    suffix = p.suffix.lower()
    if suffix == ".npy":
        with reading(p, "expected a numeric .npy array"):
            data = np.load(p, allow_pickle=False)
    elif suffix in (".csv", ".txt"):
        lines = [line for line in _text_lines(p) if line.strip()]
        if not lines:
            raise FormatError(p, "expected a numeric feature matrix, found an empty file")
        try:
            [float(cell) for cell in lines[0].split(",")]
            header = False
        except ValueError:
            header = True
        if header and len(lines) < 2:
            raise FormatError(p, "expected data rows after the header, found none")
        data = _table(p, lines, header=header)
    else:
        suffix = p.suffix or "(none)"
        raise FormatError(p, f"expected a feature matrix (.csv, .npy), got extension {suffix!r}")
    with reading(p, "expected a 2-D finite numeric matrix"):
        return check_array(data, name="features", ndim=2, min_samples=1)


def write_csv(demo, path, *, stream: str | None = None) -> Path:
    """Write ``t`` and one stream as CSV with full float precision.

    Parameters
    ----------
    demo : Demonstration
    path : str or path-like
    stream : str, optional
        The stream to write; default ``"position"`` if present, else the first.

    Returns
    -------
    pathlib.Path
        The written file. The header is ``t,<stream>_0,<stream>_1,...``;
        values use ``%.17g`` so :func:`read_csv` gets them back exactly.

    Examples
    --------
    >>> import os, tempfile
    >>> path = write_csv(Demonstration.from_array(np.eye(2)), os.path.join(tempfile.mkdtemp(), "d.csv"))
    >>> path.read_text().splitlines()[0]
    't,position_0,position_1'
    """
    _check_demo(demo)
    if not demo.streams:
        raise ValueError("demo: expected at least one stream to write, got none")
    if stream is None:
        stream = "position" if "position" in demo.streams else demo.stream_names[0]
    if stream not in demo.streams:
        raise ValueError(f"stream: expected one of {demo.stream_names}, got {stream!r}")
    data = demo.streams[stream]
    header = ",".join(["t"] + [f"{stream}_{k}" for k in range(data.shape[1])])
    p = Path(path)
    with atomic_output(p, name="path") as tmp:
        np.savetxt(tmp, np.column_stack([demo.t, data]), fmt="%.17g", delimiter=",", header=header,
                   comments="")
    return p


def read_npz(path) -> Demonstration:
    """Read a Demonstration written by :func:`write_npz`.

    The archive holds ``t``, one array per stream named by its key, and
    optionally ``metadata``: a JSON string. Nothing is ever unpickled.

    Returns
    -------
    Demonstration
        Metadata is exactly what was stored; a file without ``metadata`` gets
        ``{"source": <path>, "format": "npz"}``.

    Raises
    ------
    FormatError
        If the file is not an NPZ archive, lacks ``t``, holds an object
        (pickled) array, or has malformed metadata.

    Examples
    --------
    >>> import os, tempfile
    >>> demo = Demonstration.from_array(np.ones((4, 2)), metadata={"label": "x"})
    >>> read_npz(write_npz(demo, os.path.join(tempfile.mkdtemp(), "d.npz"))).metadata
    {'label': 'x'}
    """
    p = as_file(path)
    expect_magic(p, ZIP_MAGICS, "an NPZ (zip) archive")
    arrays = {}
    with reading(p, "corrupt NPZ archive"), np.load(p, allow_pickle=False) as archive:
        for key in archive.files:
            try:
                arrays[key] = archive[key]
            except ValueError as exc:
                if "allow_pickle" not in str(exc):
                    raise
                raise FormatError(
                    p, f"array {key!r} holds Python objects, which are never unpickled (allow_pickle=False)"
                ) from None
    if "t" not in arrays:
        raise FormatError(p, f"expected an array 't', found arrays {sorted(arrays)}")
    metadata = {"source": str(p), "format": "npz"}
    if "metadata" in arrays:
        raw = arrays.pop("metadata")
        if raw.ndim != 0 or raw.dtype.kind != "U":
            found = f"{raw.dtype} of shape {raw.shape}"
            raise FormatError(p, f"expected 'metadata' as a 0-d JSON string, found {found}")
        with reading(p, "expected 'metadata' to hold valid JSON"):
            metadata = json.loads(str(raw))
        if not isinstance(metadata, dict):
            raise FormatError(p, f"expected 'metadata' to be a JSON object, found {type(metadata).__name__}")
    t = arrays.pop("t")
    with reading(p, "invalid data"):
        return Demonstration(t, arrays, metadata)


def write_npz(demo, path) -> Path:
    """Write ``t``, every stream and the metadata (as JSON) to a compressed NPZ.

    Parameters
    ----------
    demo : Demonstration
        Its metadata must be JSON-serialisable (numpy values and paths are
        converted, see :func:`to_jsonable`); tuples come back as lists.
    path : str or path-like
        Written as given: no ``.npz`` suffix is appended.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> import os, tempfile
    >>> path = write_npz(Demonstration.from_array(np.ones((4, 2))), os.path.join(tempfile.mkdtemp(), "d.npz"))
    >>> read_npz(path).stream_names
    ['position']
    """
    _check_demo(demo)
    clash = [name for name in demo.streams if name in ("t", "metadata")]
    if clash:
        raise ValueError(f"demo: stream names 't' and 'metadata' are reserved in NPZ files, got {clash}")
    try:
        meta = json.dumps(to_jsonable(demo.metadata), allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"demo.metadata: expected JSON-serialisable values, got {exc}") from None
    p = Path(path)
    # An open handle stops numpy from appending ".npz" to the name.
    with atomic_output(p, name="path") as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, t=demo.t, **demo.streams, metadata=np.array(meta))
    return p


def to_jsonable(obj):
    """Convert numpy scalars and arrays (recursively) to plain Python for JSON.

    Dict keys become strings, tuples and sets become lists, paths become
    strings and a Demonstration becomes ``{"t", "streams", "metadata"}``.

    Raises
    ------
    TypeError
        For objects with no JSON form.

    Examples
    --------
    >>> to_jsonable({"n": np.int64(3), "x": np.array([0.5, 1.5]), 1: (np.float32(2),)})
    {'n': 3, 'x': [0.5, 1.5], '1': [2.0]}
    """
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, (set, frozenset)):
        return [to_jsonable(v) for v in sorted(obj, key=repr)]
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, Demonstration):
        return to_jsonable({"t": obj.t, "streams": obj.streams, "metadata": obj.metadata})
    raise TypeError(f"cannot convert {type(obj).__name__} to JSON")


def write_json(obj, path) -> Path:
    """Write ``obj`` as indented JSON after :func:`to_jsonable`.

    Examples
    --------
    >>> import os, tempfile
    >>> path = write_json({"k": np.arange(2)}, os.path.join(tempfile.mkdtemp(), "r.json"))
    >>> path.read_text()
    '{\\n  "k": [\\n    0,\\n    1\\n  ]\\n}\\n'
    """
    p = Path(path)
    text = json.dumps(to_jsonable(obj), indent=2)
    with atomic_output(p, name="path") as tmp:
        tmp.write_text(text + "\n", encoding="utf-8")
    return p
