"""What ``library import`` trusts in an exported folder: nothing, until it is checked.

An export folder may come from anyone. :func:`read_export` checks all of it
before the import's transaction begins, so a bad folder changes nothing:

- every path the manifest names must resolve, after following links, to a
  regular file inside the folder; a path leading outside, a folder, a FIFO
  or a device is refused after ``os.stat``, without being opened;
- the manifest is at most :data:`MAX_MANIFEST_BYTES` and nested at most
  :data:`MAX_DEPTH` deep, and is validated against its schema (types,
  ranges, unique ids);
- every NPZ file is read without unpickling, each array's header checked
  against the data it holds before anything is allocated, and checked
  against the manifest (bounds within their demonstration, members naming
  listed primitives, clusters within range, array shapes consistent).

Messages name the manifest entry (``demonstrations[3].file``) and never
quote a file's bytes.
"""

from __future__ import annotations

import json
import os
import stat
import zipfile
import zlib

import numpy as np

from ..core import Demonstration
from ..core._validation import check_array
from ._schema import SCHEMA_VERSION

__all__ = ["read_export", "check_manifest", "parse_manifest", "MANIFEST", "FORMAT", "MAX_MANIFEST_BYTES",
           "MAX_DEPTH"]

MANIFEST = "manifest.json"
FORMAT = "skillbank-library"
#: Largest manifest read: 64 MiB, about 600,000 primitives at ~100 bytes each (parsing takes ~3x in memory).
MAX_MANIFEST_BYTES = 64 * 2 ** 20
#: Deepest JSON nesting accepted (an export nests 6 deep plus the segmentation parameters).
MAX_DEPTH = 64
_MAX_ID = 2 ** 63 - 1  # SQLite's INTEGER
_MAX_PATH = 4096
_ASSIGNED = ("fit", "incremental")
_VERSION_ARRAYS = ("centers", "pca_mean", "pca_components", "member_ids", "member_clusters",
                   "member_features", "member_assigned")
_READ_ERRORS = (ValueError, OSError, EOFError, KeyError, TypeError, RuntimeError, NotImplementedError,
                MemoryError, zipfile.BadZipFile, zlib.error, UnicodeError)
_JSON_TYPES = {str: "string", int: "integer", float: "number", bool: "boolean", list: "array",
               dict: "object", type(None): "null"}


def _describe(value) -> str:
    kind = _JSON_TYPES.get(type(value), type(value).__name__)
    if isinstance(value, (list, dict)):
        return f"an {kind} of {len(value)} item(s)" if kind == "array" else f"an {kind}"
    text = repr(value)
    return f"{kind} {text if len(text) <= 40 else text[:37] + '...'}"


def _fail(where: str, expected: str, got: str):
    raise ValueError(f"{MANIFEST} {where}: expected {expected}, got {got}")


def _key(obj: dict, key: str, where: str):
    if key not in obj:
        _fail(where, f"a key {key!r}", "none")
    return obj[key]


def _object(value, where: str) -> dict:
    if not isinstance(value, dict):
        _fail(where, "an object", _describe(value))
    return value


def _array(value, where: str) -> list:
    if not isinstance(value, list):
        _fail(where, "an array", _describe(value))
    return value


def _integer(value, where: str, low: int, high: int = _MAX_ID) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        too_large = isinstance(value, int) and value > high
        _fail(where, f"an integer >= {low}" if high == _MAX_ID and not too_large else
              f"an integer in {low}..{high}", _describe(value))
    return value


def _text(value, where: str, *, optional: bool = False):
    if value is None and optional:
        return None
    if not isinstance(value, str) or not value.strip():
        _fail(where, "a non-empty string" + (" or null" if optional else ""), _describe(value))
    return value


def _unique(values, where: str, what: str) -> None:
    seen = set()
    for k, v in enumerate(values):
        if v in seen:
            _fail(f"{where}[{k}]", f"a unique {what}", f"{v}, which an earlier entry has too")
        seen.add(v)


def json_depth(value) -> int:
    """Nesting depth of a parsed JSON value, without recursion.

    Examples
    --------
    >>> json_depth({"a": [1, [2]]}), json_depth(3)
    (3, 0)
    """
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, (list, dict)):
            deepest = max(deepest, depth)
            stack.extend((v, depth + 1) for v in (item.values() if isinstance(item, dict) else item))
    return deepest


def _no_constant(name):
    raise ValueError(f"non-finite number {name} (JSON has none)")


def _finite_float(text):
    value = float(text)
    if not np.isfinite(value):
        raise ValueError("a number too large for a float")
    return value


def parse_manifest(data: bytes, where: str = MANIFEST):
    """Parse JSON bytes strictly: UTF-8, finite numbers, at most :data:`MAX_DEPTH` deep.

    Raises
    ------
    ValueError
        One line naming ``where``; never quoting the bytes.

    Examples
    --------
    >>> parse_manifest(b'{"a": [1, 2]}')
    {'a': [1, 2]}
    >>> parse_manifest(b"[" * 100 + b"]" * 100)
    Traceback (most recent call last):
    ...
    ValueError: manifest.json: expected JSON nested at most 64 deep, got 100 levels
    """
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{where}: expected UTF-8 JSON text, got bytes that are not UTF-8") from None
    try:
        doc = json.loads(text, parse_constant=_no_constant, parse_float=_finite_float)
    except RecursionError:  # the C parser recurses once per level
        raise ValueError(f"{where}: expected JSON nested at most {MAX_DEPTH} deep, got deeper nesting "
                         "than Python can parse") from None
    except ValueError as exc:  # JSONDecodeError says where, never what
        raise ValueError(f"{where}: expected valid JSON, got {' '.join(str(exc).split())}") from None
    depth = json_depth(doc)
    if depth > MAX_DEPTH:
        raise ValueError(f"{where}: expected JSON nested at most {MAX_DEPTH} deep, got {depth} levels")
    return doc


def _primitive(item, where: str) -> dict:
    p = _object(item, where)
    start = _integer(_key(p, "start", where), f"{where}.start", 0)
    return {"id": _integer(_key(p, "id", where), f"{where}.id", 1),
            "start": start, "stop": _integer(_key(p, "stop", where), f"{where}.stop", start + 1),
            "label": _text(p.get("label"), f"{where}.label", optional=True)}


def _demonstration(item, where: str) -> dict:
    d = _object(item, where)
    prov = d.get("provenance")
    if prov is not None:
        _object(prov, f"{where}.provenance")
        prov = {"kind": _text(_key(prov, "kind", f"{where}.provenance"), f"{where}.provenance.kind"),
                "params": _key(prov, "params", f"{where}.provenance"),
                "created": _text(_key(prov, "created", f"{where}.provenance"), f"{where}.provenance.created")}
    prims = _array(d.get("primitives", []), f"{where}.primitives")
    return {"where": where, "id": _integer(_key(d, "id", where), f"{where}.id", 1),
            "file": _entry(_key(d, "file", where), f"{where}.file"),
            "source": _text(d.get("source"), f"{where}.source", optional=True),
            "created": _text(d.get("created"), f"{where}.created", optional=True), "provenance": prov,
            "primitives": [_primitive(p, f"{where}.primitives[{k}]") for k, p in enumerate(prims)]}


def _version(item, where: str) -> dict:
    v = _object(item, where)
    params = _object(_key(v, "params", where), f"{where}.params")
    # What a later add needs to featurise new primitives the way this version did.
    _text(_key(params, "features", f"{where}.params"), f"{where}.params.features")
    _integer(_key(params, "n_points", f"{where}.params"), f"{where}.params.n_points", 2)
    n = _integer(_key(v, "n_clusters", where), f"{where}.n_clusters", 1, 2 ** 31)
    labels = [_object(lab, f"{where}.labels[{k}]")
              for k, lab in enumerate(_array(v.get("labels", []), f"{where}.labels"))]
    labels = [(_integer(_key(lab, "cluster", f"{where}.labels[{k}]"), f"{where}.labels[{k}].cluster",
                        0, n - 1),
               _text(_key(lab, "label", f"{where}.labels[{k}]"), f"{where}.labels[{k}].label"))
              for k, lab in enumerate(labels)]
    _unique([c for c, _ in labels], f"{where}.labels", "cluster")
    return {"where": where, "version": _integer(_key(v, "version", where), f"{where}.version", 1),
            "created": _text(_key(v, "created", where), f"{where}.created"), "params": params,
            "n_clusters": n, "file": _entry(_key(v, "file", where), f"{where}.file"), "labels": labels}


def _description(item, where: str) -> dict:
    d = _object(item, where)
    action = d.get("action")
    if action is not None and not isinstance(action, str):
        _fail(f"{where}.action", "PDDL text (a string) or null", _describe(action))
    return {"label": _text(_key(d, "label", where), f"{where}.label"),
            "revision": _integer(_key(d, "revision", where), f"{where}.revision", 1),
            "created": _text(_key(d, "created", where), f"{where}.created"), "action": action,
            "binding": _object(_key(d, "binding", where), f"{where}.binding")}


def _entry(value, where: str) -> str:
    if not isinstance(value, str) or not value or len(value) > _MAX_PATH or "\x00" in value:
        _fail(where, f"a relative file path of at most {_MAX_PATH} characters", _describe(value))
    return value


def check_manifest(doc) -> dict:
    """Validate a parsed manifest against its schema; returns it normalised.

    Types, ranges and uniqueness of what the manifest says on its own: the
    format and schema version; each demonstration's ``id``, ``file``,
    ``source``, ``created``, ``provenance`` and primitives (``id``,
    ``0 <= start < stop``, ``label``); each version's number, ``params``
    (with the ``features`` and ``n_points`` a later add needs),
    ``n_clusters``, ``file`` and labels (clusters in ``0..n_clusters-1``);
    each skill description's ``label``, ``revision``, ``created``, ``action``
    (text or null) and ``binding`` (an object); unique ids. :func:`read_export`
    checks what needs the files. Raises a one-line ValueError naming the entry.

    Examples
    --------
    >>> check_manifest({"format": FORMAT, "schema_version": 2})["demonstrations"]
    []
    >>> check_manifest({"format": FORMAT, "schema_version": 2, "demonstrations": [{"id": "1"}]})
    Traceback (most recent call last):
    ...
    ValueError: manifest.json demonstrations[0].id: expected an integer >= 1, got string '1'
    """
    top = _object(doc, "(top level)")
    if top.get("format") != FORMAT:
        _fail("format", f"{FORMAT!r} (a folder written by 'library export')", _describe(top.get("format")))
    schema = _integer(_key(top, "schema_version", "(top level)"), "schema_version", 1, _MAX_ID)
    if schema > SCHEMA_VERSION:
        raise ValueError(f"{MANIFEST}: exported by a newer skillbank (schema version {schema}, this one "
                         f"reads up to {SCHEMA_VERSION})")
    demos = [_demonstration(d, f"demonstrations[{k}]")
             for k, d in enumerate(_array(top.get("demonstrations", []), "demonstrations"))]
    versions = [_version(v, f"versions[{k}]")
                for k, v in enumerate(_array(top.get("versions", []), "versions"))]
    _unique([d["id"] for d in demos], "demonstrations", "id")
    prims = [(d["where"], k, p["id"]) for d in demos for k, p in enumerate(d["primitives"])]
    seen: dict = {}
    for where, k, pid in prims:
        if pid in seen:
            _fail(f"{where}.primitives[{k}].id", "a primitive id unique in the manifest",
                  f"{pid}, which {seen[pid]} has too")
        seen[pid] = where
    _unique([v["version"] for v in versions], "versions", "version")
    descriptions = [_description(d, f"descriptions[{k}]")
                    for k, d in enumerate(_array(top.get("descriptions", []), "descriptions"))]
    _unique([(d["label"], d["revision"]) for d in descriptions], "descriptions", "label and revision")
    return {"schema_version": schema, "demonstrations": demos, "versions": versions,
            "descriptions": descriptions}


# -- files -----------------------------------------------------------------------------------------
_KINDS = {stat.S_IFDIR: "a folder", stat.S_IFIFO: "a FIFO", stat.S_IFSOCK: "a socket",
          stat.S_IFCHR: "a character device", stat.S_IFBLK: "a block device"}


def _shown(where: str, entry: str) -> str:
    """How a message names a manifest entry and the path it holds."""
    return f"{MANIFEST} {where} {entry!r}" if len(entry) <= 80 else f"{MANIFEST} {where} {entry[:77]!r}..."


def open_confined(root: str, entry: str, shown: str):
    """Open ``entry`` for reading if it resolves to a regular file inside the folder ``root``.

    ``root`` is the folder's real path; ``shown`` starts every message.
    Links are followed first, then the target is checked with ``os.stat``,
    so a FIFO or device is refused without being opened; the file is then
    opened without following links and must be the very file checked.

    Returns
    -------
    binary file object
    """
    real = os.path.realpath(os.path.join(root, entry))
    if os.path.commonpath([root, real]) != root:
        raise ValueError(f"{shown}: expected a file inside the export folder, got a path "
                         "that leads outside it")
    try:
        before = os.stat(real)
    except FileNotFoundError:
        raise ValueError(f"{shown}: expected a file of the export, got a missing file") from None
    except OSError as exc:
        raise ValueError(f"{shown}: expected a readable file, got {exc.strerror or type(exc).__name__}") \
            from None
    if not stat.S_ISREG(before.st_mode):
        kind = _KINDS.get(stat.S_IFMT(before.st_mode), "something else")
        raise ValueError(f"{shown}: expected a regular file, got {kind}")
    # O_NONBLOCK: should the path be swapped for a FIFO meanwhile, opening it must not wait for a writer.
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) \
        | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(real, flags)
    except OSError as exc:
        raise ValueError(f"{shown}: expected a readable file, got {exc.strerror or type(exc).__name__}") \
            from None
    after = os.fstat(fd)
    if not stat.S_ISREG(after.st_mode) or (after.st_dev, after.st_ino) != (before.st_dev, before.st_ino):
        os.close(fd)
        raise ValueError(f"{shown}: expected a file that stays put, got one replaced while "
                         "being imported")
    return os.fdopen(fd, "rb")


class _Refused(Exception):
    """A reason of our own (quoting nothing from the file) to refuse an NPZ file."""


def _read_member(zf: zipfile.ZipFile, info: zipfile.ZipInfo) -> np.ndarray:
    with zf.open(info) as fh:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
        elif version == (2, 0):
            shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
        else:
            raise _Refused(f"a .npy member of format version {version}, which exports never write")
    # Refused before numpy allocates: pickles, and headers promising more data than the member holds.
    if dtype.hasobject:
        raise _Refused("an array of Python objects, which are never unpickled")
    if dtype.kind not in "biufU":
        raise _Refused(f"an array of {dtype.kind}-kind values, neither numbers nor text")
    if int(np.prod(shape, dtype=object)) * dtype.itemsize > info.file_size:
        raise _Refused("an array header promising more data than its member holds")
    with zf.open(info) as fh:
        return np.lib.format.read_array(fh, allow_pickle=False)


def load_arrays(root: str, entry: str, shown: str) -> dict:
    """The arrays of an NPZ file of the export, read without unpickling; messages start with ``shown``."""
    with open_confined(root, entry, shown) as fh:
        if fh.read(4) not in (b"PK\x03\x04", b"PK\x05\x06"):
            raise ValueError(f"{shown}: expected an NPZ archive, got a file that is not one")
        fh.seek(0)
        try:
            arrays = {}
            with zipfile.ZipFile(fh) as zf:
                for info in zf.infolist():
                    if not info.filename.endswith(".npy") or info.filename[:-4] in arrays:
                        raise _Refused("a member that is not a .npy array, or one repeated")
                    arrays[info.filename[:-4]] = _read_member(zf, info)
        except _Refused as exc:
            raise ValueError(f"{shown}: expected an NPZ archive of numeric arrays, "
                             f"got {exc}") from None
        except _READ_ERRORS as exc:  # their messages may quote the file's bytes: name the kind only
            raise ValueError(f"{shown}: expected an NPZ archive written by 'library export', "
                             f"got one that cannot be read ({type(exc).__name__})") from None
    return arrays


def _demo(arrays: dict, d: dict, shown: str) -> Demonstration:
    if "t" not in arrays:
        raise ValueError(f"{shown}: expected an array 't', got none")
    metadata = {}
    raw = arrays.pop("metadata", None)
    if raw is not None:
        if raw.ndim != 0 or raw.dtype.kind != "U":
            raise ValueError(f"{shown}: expected 'metadata' as a JSON string, got a "
                             f"{raw.dtype.kind}-kind array of shape {raw.shape}")
        metadata = _object(parse_manifest(str(raw).encode("utf-8"), f"{shown} metadata"),
                           f"{d['where']} metadata")
    if any(a.dtype.kind not in "biuf" for a in arrays.values()):
        raise ValueError(f"{shown}: expected numeric arrays, got a text array")
    try:
        demo = Demonstration(arrays.pop("t"), arrays, metadata)
    except ValueError as exc:  # keep the argument and the expectation, drop the values it quotes
        raise ValueError(f"{shown}: expected a valid demonstration, got one failing "
                         f"{str(exc).split(', got', 1)[0]} (read it with skillbank.io.read_npz)") from None
    for k, p in enumerate(d["primitives"]):
        if p["stop"] > demo.n_steps:
            _fail(f"{d['where']}.primitives[{k}].stop", f"an integer in {p['start'] + 1}..{demo.n_steps} "
                  f"(demonstration {d['id']} has {demo.n_steps} samples)", _describe(p["stop"]))
    return demo


def _integers(arrays, name, shape, shown):
    a = arrays[name]
    if a.dtype.kind not in "iu" or a.shape != shape:
        raise ValueError(f"{shown}: expected {name!r} as integers of shape {shape}, got a "
                         f"{a.dtype.kind}-kind array of shape {a.shape}")
    return a.astype(np.int64)


def _floats(arrays, name, ndim, shown):
    a = arrays[name]
    if a.dtype.kind not in "iuf":
        raise ValueError(f"{shown}: expected {name!r} as numbers, got a {a.dtype.kind}-kind array")
    return check_array(a, name=f"{shown} array {name!r}", ndim=ndim, min_samples=0)


def _version_arrays(arrays: dict, v: dict, primitives: set, shown: str) -> dict:
    missing = [name for name in _VERSION_ARRAYS if name not in arrays]
    if missing:
        raise ValueError(f"{shown}: expected arrays {list(_VERSION_ARRAYS)}, "
                         f"got none named {missing[0]!r}")
    centers = _floats(arrays, "centers", 2, shown)
    mean = _floats(arrays, "pca_mean", 1, shown)
    comps = _floats(arrays, "pca_components", 2, shown)
    n, d = v["n_clusters"], comps.shape[0]
    if centers.shape != (n, d) or comps.shape[1] != mean.shape[0] or d == 0:
        raise ValueError(f"{shown}: expected centers ({n}, d), pca_components (d, f) and pca_mean "
                         f"(f,) with d >= 1, got shapes {centers.shape}, {comps.shape} and {mean.shape}")
    m = arrays["member_ids"].shape
    if len(m) != 1:
        raise ValueError(f"{shown}: expected 'member_ids' as a 1-D array, got shape {m}")
    ids = _integers(arrays, "member_ids", m, shown)
    clusters = _integers(arrays, "member_clusters", m, shown)
    features = _floats(arrays, "member_features", 2, shown)
    assigned = arrays["member_assigned"]
    if features.shape != (m[0], d) or assigned.shape != m or assigned.dtype.kind != "U":
        raise ValueError(f"{shown}: expected member_features of shape {(m[0], d)} and "
                         f"member_assigned as {m[0]} strings, got shapes {features.shape} and "
                         f"{assigned.shape}")
    ids, clusters, assigned = ids.tolist(), clusters.tolist(), assigned.tolist()
    for name, expected, bad in (
            ("member_ids", "ids of primitives the manifest lists", [i for i in ids if i not in primitives]),
            ("member_clusters", f"clusters in 0..{n - 1}", [c for c in clusters if not 0 <= c < n]),
            ("member_assigned", f"values in {list(_ASSIGNED)}", [a for a in assigned if a not in _ASSIGNED])):
        if bad:  # a bad member_assigned string is file content: counted, not quoted
            first = f" (first {bad[0]})" if name != "member_assigned" else ""
            raise ValueError(f"{shown}: expected {name} to hold {expected}, got {len(bad)} that do "
                             f"not{first}")
    if len(set(ids)) != len(ids):
        raise ValueError(f"{shown}: expected member_ids to be unique, got a primitive twice")
    return {"centers": centers, "pca_mean": mean, "pca_components": comps, "member_ids": ids,
            "member_clusters": clusters, "member_features": features, "member_assigned": assigned}


def read_export(folder) -> dict:
    """Read and check everything in an exported folder, changing nothing.

    Returns
    -------
    dict
        The normalised manifest (:func:`check_manifest`) with each
        demonstration's ``"demo"`` (a Demonstration) and each version's
        ``"arrays"`` (``centers``, ``pca_mean``, ``pca_components``,
        ``member_ids``, ``member_clusters``, ``member_features``,
        ``member_assigned``).

    Raises a one-line ValueError naming the folder or the manifest entry,
    never quoting a file's contents.
    """
    root = os.path.realpath(os.fspath(folder))
    if not os.path.isdir(root):
        raise ValueError(f"folder: expected a folder written by 'library export', got {str(folder)!r}, "
                         "which is not a folder")
    if not os.path.lexists(os.path.join(root, MANIFEST)):
        raise ValueError(f"folder: expected {MANIFEST} in {str(folder)!r} (written by 'library export')")
    with open_confined(root, MANIFEST, MANIFEST) as fh:
        data = fh.read(MAX_MANIFEST_BYTES + 1)
    if len(data) > MAX_MANIFEST_BYTES:
        raise ValueError(f"{MANIFEST}: expected at most {MAX_MANIFEST_BYTES} bytes, got a larger file")
    doc = check_manifest(parse_manifest(data))
    for d in doc["demonstrations"]:
        shown = _shown(f"{d['where']}.file", d["file"])
        d["demo"] = _demo(load_arrays(root, d["file"], shown), d, shown)
    primitives = {p["id"] for d in doc["demonstrations"] for p in d["primitives"]}
    for v in doc["versions"]:
        shown = _shown(f"{v['where']}.file", v["file"])
        v["arrays"] = _version_arrays(load_arrays(root, v["file"], shown), v, primitives, shown)
    return doc
