"""What ``library import`` trusts in an exported folder: nothing, until it is checked.

An export folder may come from anyone. :func:`read_export` checks all of it
before the import's transaction begins, so a bad folder changes nothing:

- every path the manifest names must be a regular file of its own inside
  the folder: a path leading outside, a symbolic link, a hard link, a
  folder, a FIFO or a device is refused, the last ones without being opened
  (:mod:`skillbank.store._npz` says why); no two entries may name one file;
- the arrays of all its NPZ files together may take at most
  :func:`max_import_bytes` once decompressed (:data:`MAX_IMPORT_BYTES`, 1 GiB,
  by default; ``max_bytes=`` or ``$SKILLBANK_MAX_IMPORT_BYTES`` raise it),
  measured from the archives' directories and the arrays' headers before
  any array is read;
- the manifest is at most :data:`MAX_MANIFEST_BYTES` and nested at most
  :data:`MAX_DEPTH` deep, and is validated against its schema (types,
  ranges, unique ids);
- every NPZ file is read without unpickling, each array's header checked
  against the data it holds before anything is allocated, and checked
  against the manifest with the validators every stored row passes
  (:mod:`skillbank.store._rows`: ids in ``1..2^53 - 1``, bounds within their
  demonstration, members naming listed primitives, clusters within range,
  array shapes consistent, clustering parameters a later add can use).

Messages name the manifest entry (``demonstrations[3].file``) and never
quote a file's bytes.
"""

from __future__ import annotations

import functools
import json
import os

import numpy as np

from ..core import Demonstration
from ..core._validation import check_array
from ._arrays import content_hash
from ._npz import load_arrays, measure_npz, open_confined
from ._rows import MAX_ID, check_demonstration_record, check_version_params, check_version_record
from ._schema import SCHEMA_VERSION

__all__ = ["read_export", "check_manifest", "parse_manifest", "max_import_bytes", "MANIFEST", "FORMAT",
           "MAX_MANIFEST_BYTES", "MAX_DEPTH", "MAX_IMPORT_BYTES"]

MANIFEST = "manifest.json"
FORMAT = "skillbank-library"
#: Largest manifest read: 64 MiB, about 600,000 primitives at ~100 bytes each (parsing takes ~3x in memory).
MAX_MANIFEST_BYTES = 64 * 2 ** 20
#: Deepest JSON nesting accepted (an export nests 6 deep plus the segmentation parameters).
MAX_DEPTH = 64
#: Default bound of the bytes one import's arrays take once decompressed: 1 GiB (a few MB of archive can
#: expand to gigabytes, each read twice, the largest held in memory). Raise it with ``max_bytes=``
#: (``library import --max-bytes``) or ``$SKILLBANK_MAX_IMPORT_BYTES``.
MAX_IMPORT_BYTES = 2 ** 30
_MAX_ID = MAX_ID  # what every store holds and a later add can number on from (skillbank.store._rows)
_MAX_PATH = 4096
_VERSION_ARRAYS = ("centers", "pca_mean", "pca_components", "member_ids", "member_clusters",
                   "member_features", "member_assigned")
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
    _key(params, "n_points", f"{where}.params")
    check_version_params(params, f"{MANIFEST} {where}.params")
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
def _shown(where: str, entry: str) -> str:
    """How a message names a manifest entry and the path it holds."""
    return f"{MANIFEST} {where} {entry!r}" if len(entry) <= 80 else f"{MANIFEST} {where} {entry[:77]!r}..."


def max_import_bytes(max_bytes=None) -> int:
    """The bound of one import's decompressed bytes: ``max_bytes``, else ``$SKILLBANK_MAX_IMPORT_BYTES``,
    else :data:`MAX_IMPORT_BYTES`.

    Examples
    --------
    >>> max_import_bytes(5e9)
    5000000000
    """
    where, value = "max_bytes", max_bytes
    if value is None:
        where, value = "SKILLBANK_MAX_IMPORT_BYTES", os.environ.get("SKILLBANK_MAX_IMPORT_BYTES")
        if value is None or not value.strip():
            return MAX_IMPORT_BYTES
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = float("nan")
    if isinstance(value, bool) or not np.isfinite(number) or number < 1 or number != int(number):
        raise ValueError(f"{where}: expected a whole number of bytes >= 1 (e.g. 4e9), got {value!r}"[:200])
    return int(number)


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
    m = arrays["member_ids"].shape
    if len(m) != 1:
        raise ValueError(f"{shown}: expected 'member_ids' as a 1-D array, got shape {m}")
    ids = _integers(arrays, "member_ids", m, shown)
    clusters = _integers(arrays, "member_clusters", m, shown)
    features = _floats(arrays, "member_features", 2, shown)
    assigned = arrays["member_assigned"]
    d = comps.shape[0]
    if features.shape != (m[0], d) or assigned.shape != m or assigned.dtype.kind != "U":
        raise ValueError(f"{shown}: expected member_features of shape {(m[0], d)} and "
                         f"member_assigned as {m[0]} strings, got shapes {features.shape} and "
                         f"{assigned.shape}")
    out = {"centers": centers, "pca_mean": mean, "pca_components": comps, "member_ids": ids.tolist(),
           "member_clusters": clusters.tolist(), "member_features": features,
           "member_assigned": assigned.tolist()}
    check_version_record({**v, "arrays": out}, primitives, shown)  # what a copy checks too
    return out


def _read_again(root, d, shown, identity) -> Demonstration:
    """A demonstration of the export read again for the import's transaction: the very file checked."""
    demo = _demo(load_arrays(root, d["file"], shown, identity), d, shown)
    if content_hash(demo) != d["hash"]:
        raise ValueError(f"{shown}: expected a file that stays put, got one changed while being imported")
    return demo


def read_export(folder, *, max_bytes=None) -> dict:
    """Read and check everything in an exported folder, changing nothing.

    Parameters
    ----------
    folder : path-like
    max_bytes : int, optional
        The most bytes the export's arrays may take once decompressed, all
        NPZ files together (default :func:`max_import_bytes`: 1 GiB, or
        ``$SKILLBANK_MAX_IMPORT_BYTES``). Measured from the archives'
        directories and headers before any array is read.

    Returns
    -------
    dict
        The normalised manifest (:func:`check_manifest`) with each
        demonstration's ``"n_steps"``, ``"hash"`` (its :func:`content_hash`)
        and ``"read"`` (a function returning it as a Demonstration, read
        again and checked to be the file measured, so an import holds one
        demonstration at a time, not the export) and each version's
        ``"arrays"`` (``centers``, ``pca_mean``, ``pca_components``,
        ``member_ids``, ``member_clusters``, ``member_features``,
        ``member_assigned``).

    Raises a one-line ValueError naming the folder or the manifest entry,
    never quoting a file's contents.
    """
    bound = max_import_bytes(max_bytes)
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
    entries = [(d, f"{d['where']}.file") for d in doc["demonstrations"]] + \
              [(v, f"{v['where']}.file") for v in doc["versions"]]
    # Measured first, all of it: the bound is known to hold before a single array is decompressed.
    total, named, identity = 0, {}, {}
    for item, where in entries:
        shown = _shown(where, item["file"])
        real = os.path.realpath(os.path.join(root, item["file"]))
        if real in named:  # an export writes one file per entry; a shared one would be read again each time
            raise ValueError(f"{shown}: expected a file no other entry names (an export writes one per "
                             f"demonstration and version), got the file of {named[real]}")
        named[real] = where
        size, identity[where] = measure_npz(root, item["file"], shown)
        total += size
        if total > bound:
            raise ValueError(f"folder: expected an export whose arrays take at most {bound} bytes once "
                             f"decompressed (the import's bound), got at least {total} by {where}; if the "
                             "export is trusted and memory allows, raise the bound with --max-bytes (Python: "
                             "max_bytes=) or SKILLBANK_MAX_IMPORT_BYTES")
    for d in doc["demonstrations"]:
        where = f"{d['where']}.file"
        shown = _shown(where, d["file"])
        demo = _demo(load_arrays(root, d["file"], shown, identity[where]), d, shown)
        check_demonstration_record({**d, "demo": demo}, f"{MANIFEST} {d['where']}")  # as a copy checks
        d.update(n_steps=demo.n_steps, hash=content_hash(demo),
                 read=functools.partial(_read_again, root, d, shown, identity[where]))
    primitives = {p["id"] for d in doc["demonstrations"] for p in d["primitives"]}
    for v in doc["versions"]:
        where = f"{v['where']}.file"
        shown = _shown(where, v["file"])
        v["arrays"] = _version_arrays(load_arrays(root, v["file"], shown, identity[where]), v, primitives,
                                      shown)
    return doc
