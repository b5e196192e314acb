"""Moving a library: export to a folder, import from one, and copy between stores.

Three flows over one *records* protocol. A records object reads a library's
rows as plain records, the demonstrations (id, source, created, provenance,
primitives and the :class:`~skillbank.core.Demonstration`) and the clustering
versions (number, created, params, labels and arrays), inside one consistent
snapshot; and writes such records inside one transaction, keeping their ids or
letting the library number them. A store gives its records object through
``records()`` (:class:`skillbank.store._records.SQLRecords` serves both SQL
backends). So export, import and copy are written once, for every backend and
every pair of them.
"""

from __future__ import annotations

import contextlib
import json
import shutil
from pathlib import Path

import numpy as np

from ..io import write_npz
from ._arrays import content_hash, from_json
from ._manifest import FORMAT, MANIFEST
from ._rows import MAX_ID, check_demonstration_record, check_version_record
from ._schema import SCHEMA_VERSION, now

__all__ = ["write_export", "import_records", "copy_library", "records_of", "content_hash", "MANIFEST",
           "FORMAT", "COUNTED"]

#: The tables whose ids a copy keeps counting from where the source left off (its next ids are the source's).
COUNTED = ("demonstrations", "primitives", "cluster_versions")


def current_descriptions(rows) -> list:
    """The current revision of each label among description records, removed ones (no action) left out.

    Examples
    --------
    >>> rows = [{"label": "a", "revision": 1, "action": "x"}, {"label": "a", "revision": 2, "action": None},
    ...         {"label": "b", "revision": 1, "action": "y"}]
    >>> [d["label"] for d in current_descriptions(rows)]
    ['b']
    """
    last = {}
    for d in rows:
        if d["label"] not in last or d["revision"] > last[d["label"]]["revision"]:
            last[d["label"]] = d
    return [last[k] for k in sorted(last) if last[k]["action"] is not None]


def _merge_descriptions(records, imported, *, copy: bool) -> dict:
    """Write imported description records (inside the import's transaction); ``{label: revision}`` added.

    A copy (into a library without descriptions) keeps every revision as it
    is; a merge adds an imported label's current description (or its removal)
    as a new revision where it differs from the library's current one.
    """
    if not imported:
        return {}
    if not callable(getattr(records, "insert_descriptions", None)):
        raise ValueError(f"the export holds {len(imported)} skill description(s), which this library's "
                         "backend cannot store")
    stored = records.descriptions(history=True)
    if copy and not stored:  # an empty library may still hold descriptions: then it merges them
        records.insert_descriptions(imported)
        return {d["label"]: d["revision"] for d in current_descriptions(imported)}
    last, mine, theirs = {}, {}, {}
    for d in stored:
        if d["revision"] > last.get(d["label"], 0):
            last[d["label"]], mine[d["label"]] = d["revision"], d
    for d in imported:
        if d["label"] not in theirs or d["revision"] > theirs[d["label"]]["revision"]:
            theirs[d["label"]] = d
    new = [dict(d, revision=last.get(label, 0) + 1) for label, d in sorted(theirs.items())
           if (d["action"] is not None if label not in mine else  # a removal of nothing adds nothing
               (mine[label]["action"], mine[label]["binding"]) != (d["action"], d["binding"]))]
    records.insert_descriptions(new)
    return {d["label"]: d["revision"] for d in new}


def demonstration_record(did, source, created, provenance, primitives, demo, n_steps=None) -> dict:
    """A demonstration record from rows: ``provenance`` is ``(kind, params JSON, created)``; ``n_steps``
    the sample count its row stores (checked against ``demo`` before a copy or export writes it)."""
    kind, params, p_created = provenance
    return {"id": int(did), "source": source, "created": created, "demo": demo, "n_steps": n_steps,
            "provenance": None if kind is None else {"kind": kind, "params": from_json(params),
                                                     "created": p_created},
            "primitives": [{"id": int(i), "start": int(a), "stop": int(b), "label": lab}
                           for i, a, b, lab in primitives]}


def version_record(version, created, params, n_clusters, arrays, members, labels) -> dict:
    """A version record from rows: ``arrays`` the centres, PCA mean and components (decoded);
    ``members`` ``(primitive id, cluster, features, assigned)``; ``labels`` ``(cluster, label)``."""
    centers, mean, comps = arrays
    return {"version": int(version), "created": created, "params": from_json(params),
            "n_clusters": int(n_clusters), "labels": [(int(c), lab) for c, lab in labels],
            "arrays": {"centers": centers, "pca_mean": mean, "pca_components": comps,
                       "member_ids": [int(m[0]) for m in members],
                       "member_clusters": [int(m[1]) for m in members],
                       "member_features": [m[2] for m in members],
                       "member_assigned": [m[3] for m in members]}}


@contextlib.contextmanager
def _checked(location: str, what: str):
    """A row validator's ValueError as one line: which library is damaged, and what to do."""
    try:
        yield
    except ValueError as exc:
        if " is damaged: " in str(exc):
            raise
        raise ValueError(f"library {location!r} is damaged: {exc}; {what}; restore it from a backup"
                         ) from None


def check_source_demonstration(location: str, d: dict, what: str) -> None:
    """A stored demonstration record checked as an import checks one (:mod:`skillbank.store._rows`)."""
    with _checked(location, what):
        check_demonstration_record(d, f"demonstration {d['id']}", n_steps=d.get("n_steps"))


def check_source_version(location: str, v: dict, primitives, what: str) -> None:
    """A stored clustering version record checked as an import checks one."""
    with _checked(location, what):
        check_version_record(v, primitives, f"clustering version {v['version']}")


def records_of(store):
    """The records protocol of an open store (its ``records()``)."""
    own = getattr(store, "records", None)
    if callable(own):
        return own()
    raise ValueError(f"library {store.location!r}: its backend {type(store).__name__} cannot be exported, "
                     "imported or copied (it has no records())")


def write_export(records, folder, *, progress=None) -> Path:
    """Write every demonstration, primitive, clustering version, label and provenance to ``folder``.

    Layout: ``demonstrations/demo_<id>.npz`` (``t``, every stream, metadata;
    see :func:`skillbank.io.write_npz`), ``versions/version_<n>.npz`` (centres,
    PCA arrays, members, their clusters and features) and ``manifest.json``
    (everything else). Read in one snapshot (``records.snapshot()``), so it is
    consistent even while other processes write. Every record is checked as
    an import would check it (:mod:`skillbank.store._rows`), so a damaged
    library gives one line instead of an export that cannot be imported; a
    failed export leaves nothing in ``folder`` (nor ``folder`` itself when it
    was new). ``progress``, when given, is called as ``progress(done, total)``
    with the demonstrations written so far.

    Returns
    -------
    pathlib.Path
        The manifest.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"folder: expected a folder, got the file {str(folder)!r}")
    if folder.is_dir() and any(folder.iterdir()):
        raise ValueError(f"folder: expected a new or empty folder, {str(folder)!r} is not empty")
    created = not folder.exists()
    try:
        return _write_export(records, folder, progress)
    except BaseException:  # nothing half-written: the folder was new or empty, so all in it is ours
        if created:
            shutil.rmtree(folder, ignore_errors=True)
        else:
            for part in folder.iterdir():
                shutil.rmtree(part, ignore_errors=True) if part.is_dir() else part.unlink(missing_ok=True)
        raise


def _write_export(records, folder: Path, progress) -> Path:
    location, what = getattr(getattr(records, "store", None), "location", "?"), "nothing was exported"
    (folder / "demonstrations").mkdir(parents=True, exist_ok=True)
    (folder / "versions").mkdir(exist_ok=True)
    demos_doc, versions_doc = [], []
    with records.snapshot():
        total, demos = records.demonstrations()
        if progress is not None:
            progress(0, total)
        primitives = set()
        for done, d in enumerate(demos, 1):
            check_source_demonstration(location, d, what)  # what an import would refuse is not written
            primitives.update(p["id"] for p in d["primitives"])
            name = f"demonstrations/demo_{d['id']:06d}.npz"
            write_npz(d["demo"], folder / name)
            demos_doc.append({"id": d["id"], "file": name, "source": d["source"], "created": d["created"],
                              "provenance": d["provenance"], "primitives": d["primitives"]})
            if progress is not None:
                progress(done, total)
        for v in records.versions():
            check_source_version(location, v, primitives, what)
            a = v["arrays"]
            feats, m = a["member_features"], len(a["member_ids"])
            width = feats[0].shape[0] if m else a["pca_components"].shape[0]
            name = f"versions/version_{v['version']:04d}.npz"
            np.savez_compressed(
                folder / name, centers=a["centers"], pca_mean=a["pca_mean"],
                pca_components=a["pca_components"],
                member_ids=np.array(a["member_ids"], dtype=np.int64),
                member_clusters=np.array(a["member_clusters"], dtype=np.int64),
                member_features=np.array(feats, dtype=float).reshape(m, width),
                member_assigned=np.array(a["member_assigned"], dtype=str))
            versions_doc.append({"version": v["version"], "created": v["created"], "params": v["params"],
                                 "n_clusters": v["n_clusters"], "file": name,
                                 "labels": [{"cluster": c, "label": lab} for c, lab in v["labels"]]})
        described = getattr(records, "descriptions", None)
        descriptions = described(history=True) if callable(described) else []
    manifest = {"format": FORMAT, "schema_version": SCHEMA_VERSION, "exported": now(),
                "demonstrations": demos_doc, "versions": versions_doc, "descriptions": descriptions}
    path = folder / MANIFEST
    path.write_text(json.dumps(manifest, indent=1, allow_nan=False))
    return path


def _existing_hashes(records, n_steps) -> dict:
    """``{content hash: id}`` of the stored demonstrations with one of the lengths ``n_steps``."""
    out = {}
    for part in records.lengths(n_steps):
        for did, demo in sorted(part.items()):
            out.setdefault(content_hash(demo), did)
    return out


def import_records(records, doc) -> dict:
    """Write a checked export ``doc`` (:func:`~skillbank.store._manifest.read_export`) in one transaction.

    - Into an **empty** library (no demonstrations, no clustering versions),
      an exact copy: ids, versions, memberships and labels are kept;
    - into a **non-empty** library, a merge: a demonstration whose content
      (:func:`content_hash`) the library already holds is skipped; every other
      one is added, renumbered, with its primitives and their own labels. The
      imported clustering versions are not added (they describe another
      population): the library's current version stays current, with its
      labels, and the new primitives stay unclustered here
      (:meth:`skillbank.pipeline.Library.import_folder` assigns them).

    Returns
    -------
    dict
        ``{"mode": "copy" or "merge", "demonstrations": {old: new},
        "primitives": {old: new}, "versions": {old: new},
        "skipped": {old demonstration id: id of the copy already stored}}``.
    """
    hashes = {d["id"]: d["hash"] for d in doc["demonstrations"]}
    maps = {"mode": "copy", "demonstrations": {}, "primitives": {}, "versions": {}, "skipped": {}}
    with records.writing():
        empty = sum(records.counts()) == 0
        lengths = [d["n_steps"] for d in doc["demonstrations"]]
        stored = {} if empty else _existing_hashes(records, lengths)
        maps["mode"] = "copy" if empty else "merge"
        for d in doc["demonstrations"]:
            if hashes[d["id"]] in stored:
                maps["skipped"][d["id"]] = stored[hashes[d["id"]]]
                continue
            # read again here, one at a time (checked to be what was measured and hashed): memory holds
            # one demonstration, not the export
            did, prims = records.insert_demonstration(dict(d, demo=d["read"]()), keep_id=empty)
            maps["demonstrations"][d["id"]] = did
            maps["primitives"].update(prims)
        for v in doc["versions"] if empty else ():
            maps["versions"][v["version"]] = records.insert_version(v, maps["primitives"])
        maps["descriptions"] = _merge_descriptions(records, doc.get("descriptions", []), copy=empty)
    return maps


def copy_library(source, destination, *, progress=None) -> dict:
    """Copy the library ``source`` into the empty library ``destination``: ids and versions kept.

    Any two stores (:class:`~skillbank.store.SQLiteStore`,
    :class:`~skillbank.store.PostgresStore`, either direction). The source is
    read in one snapshot, a demonstration at a time (memory stays bounded),
    and the destination written in one transaction: a failed copy leaves it
    empty. Every demonstration (streams, metadata, source, created time,
    provenance), primitive (range, own label), clustering version (params,
    arrays, members with their features and how they joined, cluster
    labels) and the id counters are copied, so the next demonstration added
    to either gets the same id. Every row is checked as an import checks it
    (:mod:`skillbank.store._rows`: sample counts, bounds inside their
    demonstration, array shapes, finite values, ids and counters in
    ``0..2^53 - 1``), and a damaged source (also a blob that is not ``.npy``
    or an orphan primitive) raises one line naming the library and the row;
    the destination stays empty.

    Parameters
    ----------
    source, destination : Store
        Open stores; ``source`` may be read-only.
    progress : callable, optional
        Called as ``progress(done, total)`` with the demonstrations copied so far.

    Returns
    -------
    dict
        ``{"demonstrations": n, "primitives": n, "versions": n}`` copied.

    Raises
    ------
    ValueError
        When ``destination`` already holds demonstrations or clustering
        versions (nothing is written; to merge, export and import), or when
        ``source`` is damaged.

    Examples
    --------
    >>> import os, tempfile
    >>> from skillbank import Demonstration
    >>> from skillbank.store import open_store
    >>> folder = tempfile.mkdtemp()
    >>> t = np.linspace(0.0, 1.0, 20)
    >>> with open_store(os.path.join(folder, "a.db")) as a, open_store(os.path.join(folder, "b.db")) as b:
    ...     _ = a.add_demonstration(Demonstration.from_array(np.c_[t, t], t), [(0, 10), (10, 20)])
    ...     copy_library(a, b), b.demonstration_ids()
    ({'demonstrations': 1, 'primitives': 2, 'versions': 0}, [1])
    """
    src, dst = records_of(source), records_of(destination)
    counts = {"demonstrations": 0, "primitives": 0, "versions": 0}
    with src.snapshot(), dst.writing():
        n_demos, n_versions = dst.counts()
        if n_demos or n_versions:
            raise ValueError(f"destination: expected an empty library, {destination.location!r} holds "
                             f"{n_demos} demonstration(s) and {n_versions} clustering version(s); "
                             "'library copy' writes only into an empty library (to merge, 'library export' "
                             "then 'library import')")
        total, demos = src.demonstrations()
        if progress is not None:
            progress(0, total)
        primitives, where, what = {}, source.location, "nothing was copied"
        for done, d in enumerate(demos, 1):
            check_source_demonstration(where, d, what)  # rows an import would refuse are not copied either
            _, prims = dst.insert_demonstration(d, keep_id=True)
            primitives.update(prims)
            counts["demonstrations"] = done
            if progress is not None:
                progress(done, total)
        counts["primitives"] = len(primitives)
        for v in src.versions():
            check_source_version(where, v, primitives, what)
            dst.insert_version(v, primitives)
            counts["versions"] += 1
        described = getattr(src, "descriptions", None)
        _merge_descriptions(dst, described(history=True) if callable(described) else [], copy=True)
        counters = src.counters()
        for table, last in counters.items():  # the copy's next add numbers on from them
            if not 0 <= int(last) <= MAX_ID:
                raise ValueError(f"library {where!r} is damaged: its {table} id counter: expected an id in "
                                 f"0..{MAX_ID} (2^53 - 1), got {last}; {what}; restore it from a backup")
        dst.set_counters(counters)
    return counts
