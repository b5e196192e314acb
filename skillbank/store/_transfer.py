"""Export a library to a folder of NPZ files plus ``manifest.json``, and import it back."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..io import read_npz, write_npz
from ._arrays import from_json, from_npy, to_json, to_npy
from ._records import load_demonstrations
from ._schema import SCHEMA_VERSION, now, transaction

__all__ = ["export_library", "import_library", "MANIFEST", "FORMAT"]

MANIFEST = "manifest.json"
FORMAT = "skillbank-library"


def export_library(conn, folder) -> Path:
    """Write every demonstration, primitive, clustering version, label and provenance to ``folder``.

    Layout: ``demonstrations/demo_<id>.npz`` (``t``, every stream, metadata;
    see :func:`skillbank.io.write_npz`), ``versions/version_<n>.npz`` (centres,
    PCA arrays, members, their clusters and features) and ``manifest.json``
    (everything else). Runs in one read transaction, so it is a consistent
    snapshot even while other processes write.

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
        for did, source, created, kind, params, p_created in rows:
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


def _read_manifest(folder: Path) -> dict:
    path = folder / MANIFEST
    if not path.is_file():
        raise ValueError(f"folder: expected {MANIFEST} in {str(folder)!r} (written by 'library export')")
    try:
        manifest = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{str(path)!r}: not valid JSON ({exc})") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise ValueError(f"{str(path)!r}: expected format {FORMAT!r}")
    if int(manifest.get("schema_version", 0)) > SCHEMA_VERSION:
        raise ValueError(f"{str(path)!r}: exported by a newer skillbank (schema version "
                         f"{manifest['schema_version']}, this one reads up to {SCHEMA_VERSION})")
    return manifest


def _npz(path: Path) -> dict:
    if not path.is_file():
        raise ValueError(f"import: missing file {str(path)!r} named in the manifest")
    with np.load(path, allow_pickle=False) as archive:
        return {k: archive[k] for k in archive.files}


def import_library(conn, folder) -> dict:
    """Add the contents of an exported folder in one transaction; returns the id maps.

    Into an empty library every id is kept, so an export/import round trip
    reproduces the library exactly. Into a non-empty one, ids are renumbered
    and the imported clustering versions are appended after the existing ones
    (the last imported version becomes current).
    """
    folder = Path(folder)
    manifest = _read_manifest(folder)
    demos = [(doc, read_npz(folder / doc["file"])) for doc in manifest.get("demonstrations", [])]
    versions = [(doc, _npz(folder / doc["file"])) for doc in manifest.get("versions", [])]
    maps = {"demonstrations": {}, "primitives": {}, "versions": {}}
    with transaction(conn):
        empty = conn.execute("SELECT (SELECT COUNT(*) FROM demonstrations) + "
                             "(SELECT COUNT(*) FROM cluster_versions)").fetchone()[0] == 0
        for doc, demo in demos:
            prov = doc.get("provenance")
            pid = None
            if prov is not None:
                pid = conn.execute("INSERT INTO provenance (kind, params, created) VALUES (?, ?, ?)",
                                   (prov["kind"], to_json(prov["params"]), prov["created"])).lastrowid
            did = conn.execute(
                "INSERT INTO demonstrations (id, source, n_steps, t, metadata, created, provenance_id) "
                "VALUES (?, ?, ?, ?, ?, ?, ?)",
                (doc["id"] if empty else None, doc.get("source"), demo.n_steps, to_npy(demo.t),
                 to_json(demo.metadata), doc.get("created") or now(), pid)).lastrowid
            maps["demonstrations"][int(doc["id"])] = did
            conn.executemany("INSERT INTO streams (demonstration_id, name, position, data) "
                             "VALUES (?, ?, ?, ?)",
                             [(did, n, k, to_npy(a)) for k, (n, a) in enumerate(demo.streams.items())])
            for p in doc.get("primitives", []):
                new = conn.execute("INSERT INTO primitives (id, demonstration_id, start, stop, label) "
                                   "VALUES (?, ?, ?, ?, ?)",
                                   (p["id"] if empty else None, did, p["start"], p["stop"],
                                    p.get("label"))).lastrowid
                maps["primitives"][int(p["id"])] = new
        for doc, arrays in versions:
            v = conn.execute(
                "INSERT INTO cluster_versions (version, created, params, n_clusters, centers, pca_mean, "
                "pca_components) VALUES (?, ?, ?, ?, ?, ?, ?)",
                (doc["version"] if empty else None, doc["created"], to_json(doc["params"]),
                 doc["n_clusters"], to_npy(arrays["centers"]), to_npy(arrays["pca_mean"]),
                 to_npy(arrays["pca_components"]))).lastrowid
            maps["versions"][int(doc["version"])] = v
            unknown = [int(i) for i in arrays["member_ids"] if int(i) not in maps["primitives"]]
            if unknown:
                raise ValueError(f"import: version {doc['version']} names primitive {unknown[0]}, "
                                 "which the manifest does not list")
            conn.executemany(
                "INSERT INTO cluster_members (version, primitive_id, cluster, features, assigned) "
                "VALUES (?, ?, ?, ?, ?)",
                [(v, maps["primitives"][int(i)], int(c), to_npy(f), str(a)) for i, c, f, a in zip(
                    arrays["member_ids"], arrays["member_clusters"], arrays["member_features"],
                    arrays["member_assigned"], strict=True)])
            conn.executemany("INSERT INTO cluster_labels (version, cluster, label) VALUES (?, ?, ?)",
                             [(v, int(lab["cluster"]), lab["label"]) for lab in doc.get("labels", [])])
    return maps
