"""Export a library to a folder of NPZ files plus ``manifest.json``, and import it back."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from ..core import Demonstration
from ..io import write_npz
from ._arrays import from_json, from_npy, to_json, to_npy
from ._manifest import FORMAT, MANIFEST, read_export
from ._records import chunks, insert_demonstration, load_demonstrations, placeholders
from ._schema import SCHEMA_VERSION, now, transaction

__all__ = ["export_library", "import_library", "content_hash", "MANIFEST", "FORMAT"]


def export_library(conn, folder, *, progress=None) -> Path:
    """Write every demonstration, primitive, clustering version, label and provenance to ``folder``.

    Layout: ``demonstrations/demo_<id>.npz`` (``t``, every stream, metadata;
    see :func:`skillbank.io.write_npz`), ``versions/version_<n>.npz`` (centres,
    PCA arrays, members, their clusters and features) and ``manifest.json``
    (everything else). Runs in one read transaction, so it is a consistent
    snapshot even while other processes write. ``progress``, when given, is
    called as ``progress(done, total)`` with the demonstrations written so far.

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
    (folder / "demonstrations").mkdir(parents=True, exist_ok=True)
    (folder / "versions").mkdir(exist_ok=True)
    conn.execute("BEGIN")  # a snapshot: readers see one consistent state in WAL mode
    try:
        demos_doc, versions_doc = [], []
        rows = conn.execute("SELECT d.id, d.source, d.created, p.kind, p.params, p.created "
                            "FROM demonstrations d LEFT JOIN provenance p ON p.id = d.provenance_id "
                            "ORDER BY d.id").fetchall()
        if progress is not None:
            progress(0, len(rows))
        for done, (did, source, created, kind, params, p_created) in enumerate(rows, 1):
            demo = load_demonstrations(conn, [did])[did]
            name = f"demonstrations/demo_{did:06d}.npz"
            write_npz(demo, folder / name)
            prims = conn.execute("SELECT id, start, stop, label FROM primitives WHERE demonstration_id = ? "
                                 "ORDER BY id", (did,)).fetchall()
            demos_doc.append({
                "id": did, "file": name, "source": source, "created": created,
                "provenance": None if kind is None else {"kind": kind, "params": from_json(params),
                                                         "created": p_created},
                "primitives": [{"id": i, "start": a, "stop": b, "label": lab} for i, a, b, lab in prims]})
            if progress is not None:
                progress(done, len(rows))
        for v, created, params, n, centers, mean, comps in conn.execute(
                "SELECT version, created, params, n_clusters, centers, pca_mean, pca_components "
                "FROM cluster_versions ORDER BY version").fetchall():
            members = conn.execute("SELECT primitive_id, cluster, features, assigned FROM cluster_members "
                                   "WHERE version = ? ORDER BY primitive_id", (v,)).fetchall()
            feats = [from_npy(m[2]) for m in members]
            width = feats[0].shape[0] if feats else from_npy(comps).shape[0]
            name = f"versions/version_{v:04d}.npz"
            np.savez_compressed(
                folder / name, centers=from_npy(centers), pca_mean=from_npy(mean),
                pca_components=from_npy(comps),
                member_ids=np.array([m[0] for m in members], dtype=np.int64),
                member_clusters=np.array([m[1] for m in members], dtype=np.int64),
                member_features=np.array(feats, dtype=float).reshape(len(members), width),
                member_assigned=np.array([m[3] for m in members], dtype=str))
            labels = conn.execute("SELECT cluster, label FROM cluster_labels WHERE version = ? "
                                  "ORDER BY cluster", (v,)).fetchall()
            versions_doc.append({"version": v, "created": created, "params": from_json(params),
                                 "n_clusters": n, "file": name,
                                 "labels": [{"cluster": c, "label": lab} for c, lab in labels]})
    finally:
        conn.execute("COMMIT")
    manifest = {"format": FORMAT, "schema_version": SCHEMA_VERSION, "exported": now(),
                "demonstrations": demos_doc, "versions": versions_doc}
    path = folder / MANIFEST
    path.write_text(json.dumps(manifest, indent=1, allow_nan=False))
    return path


def content_hash(demo: Demonstration) -> str:
    """SHA-256 over ``t``, every stream (name, dtype, shape, bytes, in order) and the metadata JSON.

    Two demonstrations with the same hash hold the same samples, streams and
    metadata; ``library import`` uses it to skip what a library already holds.

    Examples
    --------
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


def _existing_hashes(conn, n_steps) -> dict:
    """``{content hash: id}`` of the stored demonstrations with one of the lengths ``n_steps``."""
    lengths = sorted(set(n_steps))
    ids = [r[0] for part in chunks(lengths) for r in conn.execute(
        f"SELECT id FROM demonstrations WHERE n_steps IN ({placeholders(len(part))})", part)]
    out = {}
    for part in chunks(sorted(ids)):  # a chunk at a time: memory stays bounded on a large library
        for did, demo in sorted(load_demonstrations(conn, part).items()):
            out.setdefault(content_hash(demo), did)
    return out


def _insert_demonstration(conn, d, *, keep_id: bool) -> tuple:
    prov = d["provenance"]
    prims = d["primitives"]
    did, pids = insert_demonstration(
        conn, d["demo"], [(p["start"], p["stop"]) for p in prims], source=d["source"],
        labels=[p["label"] for p in prims],
        provenance=None if prov is None else (prov["kind"], prov["params"], prov["created"]),
        created=d["created"], demo_id=d["id"] if keep_id else None,
        primitive_ids=[p["id"] for p in prims] if keep_id else None)
    return did, {p["id"]: new for p, new in zip(prims, pids, strict=True)}


def _insert_version(conn, v, primitives: dict) -> int:
    a = v["arrays"]
    conn.execute(
        "INSERT INTO cluster_versions (version, created, params, n_clusters, centers, pca_mean, "
        "pca_components) VALUES (?, ?, ?, ?, ?, ?, ?)",
        (v["version"], v["created"], to_json(v["params"]), v["n_clusters"], to_npy(a["centers"]),
         to_npy(a["pca_mean"]), to_npy(a["pca_components"])))
    conn.executemany(
        "INSERT INTO cluster_members (version, primitive_id, cluster, features, assigned) "
        "VALUES (?, ?, ?, ?, ?)",
        [(v["version"], primitives[i], c, to_npy(f), s) for i, c, f, s in zip(
            a["member_ids"], a["member_clusters"], a["member_features"], a["member_assigned"], strict=True)])
    conn.executemany("INSERT INTO cluster_labels (version, cluster, label) VALUES (?, ?, ?)",
                     [(v["version"], c, lab) for c, lab in v["labels"]])
    return v["version"]


def import_library(conn, folder) -> dict:
    """Import an exported folder in one transaction, after checking all of it.

    Everything is read and checked first (:func:`~skillbank.store._manifest.read_export`:
    paths confined to the folder, the manifest validated, the files checked
    against it), so a bad folder changes nothing. Then:

    - into an **empty** library (no demonstrations, no clustering versions),
      an exact copy: ids, versions, memberships and labels are kept;
    - into a **non-empty** library, a merge: a demonstration whose content
      (:func:`~skillbank.store._manifest.content_hash`) the library already
      holds is skipped; every other one is added, renumbered, with its
      primitives and their own labels. The imported clustering versions are
      not added (they describe another population): the library's current
      version stays current, with its labels, and the new primitives stay
      unclustered here (:meth:`skillbank.pipeline.Library.import_folder`
      assigns them).

    Returns
    -------
    dict
        ``{"mode": "copy" or "merge", "demonstrations": {old: new},
        "primitives": {old: new}, "versions": {old: new},
        "skipped": {old demonstration id: id of the copy already stored}}``.
    """
    doc = read_export(folder)
    hashes = {d["id"]: content_hash(d["demo"]) for d in doc["demonstrations"]}
    maps = {"mode": "copy", "demonstrations": {}, "primitives": {}, "versions": {}, "skipped": {}}
    with transaction(conn):
        empty = conn.execute("SELECT (SELECT COUNT(*) FROM demonstrations) + "
                             "(SELECT COUNT(*) FROM cluster_versions)").fetchone()[0] == 0
        stored = {} if empty else _existing_hashes(conn, [d["demo"].n_steps for d in doc["demonstrations"]])
        maps["mode"] = "copy" if empty else "merge"
        for d in doc["demonstrations"]:
            if hashes[d["id"]] in stored:
                maps["skipped"][d["id"]] = stored[hashes[d["id"]]]
                continue
            did, prims = _insert_demonstration(conn, d, keep_id=empty)
            maps["demonstrations"][d["id"]] = did
            maps["primitives"].update(prims)
        for v in doc["versions"] if empty else ():
            maps["versions"][v["version"]] = _insert_version(conn, v, maps["primitives"])
    return maps
