"""Reading and writing demonstrations and primitives in an open library connection."""

from __future__ import annotations

from ..core import Demonstration
from ._arrays import from_json, from_npy, to_json, to_npy
from ._schema import now

__all__ = ["insert_demonstration", "load_demonstrations", "primitive_demo", "chunks"]

_CHUNK = 500  # ids per IN (...) query, well under SQLite's variable limit


def chunks(ids):
    """Split ``ids`` into lists short enough for one ``IN (?, ...)`` query."""
    ids = list(ids)
    for i in range(0, len(ids), _CHUNK):
        yield ids[i:i + _CHUNK]


def placeholders(n: int) -> str:
    """``?, ?, ...`` for ``n`` bound parameters."""
    return ", ".join("?" * n)


def insert_demonstration(conn, demo: Demonstration, bounds, *, source, labels, provenance, created=None,
                         demo_id=None, primitive_ids=None) -> tuple:
    """Insert a demonstration, its streams and its primitives; returns ``(demo_id, primitive_ids)``.

    The one place that writes these rows, for new demonstrations and for
    imported ones. ``labels`` holds one label (or None) per bound;
    ``provenance`` is ``(kind, params, created)`` or None; ``created`` defaults
    to now; ``demo_id`` and ``primitive_ids`` keep given ids (an import into an
    empty library), else the database assigns them. The caller holds the
    transaction.
    """
    prov_id = None
    if provenance is not None:
        kind, params, prov_created = provenance
        prov_id = conn.execute("INSERT INTO provenance (kind, params, created) VALUES (?, ?, ?)",
                               (kind, to_json(params), prov_created or now())).lastrowid
    demo_id = conn.execute(
        "INSERT INTO demonstrations (id, source, n_steps, t, metadata, created, provenance_id) "
        "VALUES (?, ?, ?, ?, ?, ?, ?)",
        (demo_id, source, demo.n_steps, to_npy(demo.t), to_json(demo.metadata), created or now(),
         prov_id)).lastrowid
    conn.executemany(
        "INSERT INTO streams (demonstration_id, name, position, data) VALUES (?, ?, ?, ?)",
        [(demo_id, name, k, to_npy(arr)) for k, (name, arr) in enumerate(demo.streams.items())])
    ids = [None] * len(bounds) if primitive_ids is None else primitive_ids
    prim_ids = [conn.execute("INSERT INTO primitives (id, demonstration_id, start, stop, label) "
                             "VALUES (?, ?, ?, ?, ?)", (i, demo_id, int(a), int(b), lab)).lastrowid
                for i, (a, b), lab in zip(ids, bounds, labels, strict=True)]
    return demo_id, prim_ids


def load_demonstrations(conn, ids) -> dict:
    """Demonstrations by id, streams in their stored order."""
    ids = sorted({int(i) for i in ids})
    rows, streams = {}, {}
    for part in chunks(ids):
        q = placeholders(len(part))
        for did, t, meta in conn.execute(
                f"SELECT id, t, metadata FROM demonstrations WHERE id IN ({q})", part):
            rows[did] = (from_npy(t), from_json(meta))
        for did, name, data in conn.execute(
                f"SELECT demonstration_id, name, data FROM streams WHERE demonstration_id IN ({q}) "
                "ORDER BY demonstration_id, position", part):
            streams.setdefault(did, {})[name] = from_npy(data)
    missing = [i for i in ids if i not in rows]
    if missing:
        raise ValueError(f"demonstration: no demonstration with id {missing[0]} in the library")
    return {did: Demonstration(t, streams.get(did, {}), meta) for did, (t, meta) in rows.items()}


def primitive_demo(parent: Demonstration, pid: int, did: int, start: int, stop: int) -> Demonstration:
    """The samples of one primitive, with its ids in the metadata."""
    demo = parent.slice(start, stop)
    demo.metadata.update(primitive_id=int(pid), demonstration_id=int(did))
    return demo
