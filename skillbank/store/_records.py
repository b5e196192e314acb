"""A library's rows, written once for every SQL backend: demonstrations, primitives, and the transfer records.

Every function here takes a :class:`~skillbank.store._sql.Session` open in
the caller's transaction: SQL written with ``?`` markers, which the session
gives the driver in its own style, and ``db.new_ids`` for the backend's id
counters. Arrays are ``.npy`` bytes (never pickles), JSON is text.
:class:`SQLRecords` is the records protocol of :mod:`skillbank.store._transfer`
(export, import, copy) over any :class:`~skillbank.store._sql.SQLStore`.
"""

from __future__ import annotations

import contextlib

from ..core import Demonstration
from ._arrays import from_json, from_npy, to_json, to_npy
from ._rows import damaged
from ._schema import now
from ._transfer import COUNTED, current_descriptions, demonstration_record, version_record

__all__ = ["encode", "insert", "load_demonstrations", "primitive_demo", "chunks", "placeholders",
           "SQLRecords", "stored_array", "stored_json", "orphan_check", "remedy"]

_CHUNK = 500  # ids per IN (...) query (well under SQLite's variable limit), and demonstrations read at a time


def chunks(ids):
    """Split ``ids`` into lists short enough for one ``IN (?, ...)`` query."""
    ids = list(ids)
    for i in range(0, len(ids), _CHUNK):
        yield ids[i:i + _CHUNK]


def placeholders(n: int) -> str:
    """``?, ?, ...`` for ``n`` bound parameters.

    Examples
    --------
    >>> placeholders(3)
    '?, ?, ?'
    """
    return ", ".join("?" * n)


def encode(demo: Demonstration, bounds, *, source, labels, provenance, created=None) -> dict:
    """A demonstration's rows, serialised before the transaction (so the write lock is held shorter).

    ``labels`` holds one label (or None) per bound; ``provenance`` is
    ``(kind, params, created)`` or None; ``created`` defaults to now.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 1.0, 5)
    >>> e = encode(Demonstration.from_array(np.c_[t, t], t), [(0, 5)], source=None, labels=[None],
    ...            provenance=None)
    >>> e["n_steps"], e["bounds"], [name for name, _, _ in e["streams"]]
    (5, [(0, 5)], ['position'])
    """
    return {"source": source, "n_steps": demo.n_steps, "t": to_npy(demo.t),
            "metadata": to_json(demo.metadata), "created": created or now(), "labels": list(labels),
            "streams": [(name, k, to_npy(arr)) for k, (name, arr) in enumerate(demo.streams.items())],
            "bounds": [(int(a), int(b)) for a, b in bounds],
            "provenance": None if provenance is None else (provenance[0], to_json(provenance[1]),
                                                           provenance[2] or now())}


_INSERTS = (
    ("provenance", "INSERT INTO provenance (id, kind, params, created) VALUES (?, ?, ?, ?)"),
    ("demonstrations", "INSERT INTO demonstrations (id, source, n_steps, t, metadata, created, "
                       "provenance_id) VALUES (?, ?, ?, ?, ?, ?, ?)"),
    ("streams", "INSERT INTO streams (demonstration_id, name, position, data) VALUES (?, ?, ?, ?)"),
    ("primitives", "INSERT INTO primitives (id, demonstration_id, start, stop, label) "
                   "VALUES (?, ?, ?, ?, ?)"),
)


def insert(db, encoded: list, *, demo_ids=None, primitive_ids=None) -> list:
    """Insert :func:`encode`-d demonstrations with their streams, primitives and provenance.

    The one place that writes these rows, for new demonstrations and for
    imported ones. Ids come from the backend's counters (``db.new_ids``), or
    ``demo_ids`` and ``primitive_ids`` keep given ones (an import into an
    empty library). One batched statement per table. Returns
    ``[(demonstration id, [primitive ids])]``.
    """
    prov = iter(db.new_ids("provenance", sum(e["provenance"] is not None for e in encoded)))
    dids = db.new_ids("demonstrations", len(encoded), demo_ids)
    pids = iter(db.new_ids("primitives", sum(len(e["bounds"]) for e in encoded), primitive_ids))
    rows: dict = {table: [] for table, _ in _INSERTS}
    out = []
    for e, did in zip(encoded, dids, strict=True):
        prov_id = None
        if e["provenance"] is not None:
            prov_id = next(prov)
            rows["provenance"].append((prov_id, *e["provenance"]))
        rows["demonstrations"].append((did, e["source"], e["n_steps"], e["t"], e["metadata"], e["created"],
                                       prov_id))
        rows["streams"] += [(did, name, k, data) for name, k, data in e["streams"]]
        mine = [next(pids) for _ in e["bounds"]]
        rows["primitives"] += [(p, did, a, b, lab)
                               for p, (a, b), lab in zip(mine, e["bounds"], e["labels"], strict=True)]
        out.append((did, mine))
    for table, sql in _INSERTS:
        db.executemany(sql, rows[table])
    return out


def remedy(location: str, did=None) -> str:
    """What to do about a damaged row: a demonstration's can be removed, anything else restored."""
    if did is None:
        return "restore it from a backup"
    return (f"remove demonstration {did} ('skillbank library remove {location} {did}') or restore the "
            "library from a backup")


def stored_array(db, blob, row: str, did=None):
    """A stored ``.npy`` blob decoded; a damaged one is one line naming the library and ``row``."""
    try:
        return from_npy(blob)
    except ValueError as exc:
        raise damaged(db.store.location, row, str(exc), remedy(db.store.location, did)) from None


def stored_json(db, text, row: str, did=None):
    """Stored JSON text parsed; a damaged one is one line naming the library and ``row``."""
    try:
        return from_json(text)
    except (ValueError, TypeError, RecursionError):  # what the text holds is not quoted
        raise damaged(db.store.location, row, "expected JSON text, got text that is not",
                      remedy(db.store.location, did)) from None


def orphan_check(db) -> None:
    """One line naming the first primitive whose demonstration the library lacks (foreign keys were off)."""
    row = db.execute("SELECT p.id, p.demonstration_id FROM primitives p LEFT JOIN demonstrations d "
                     "ON d.id = p.demonstration_id WHERE d.id IS NULL ORDER BY p.id LIMIT 1").fetchone()
    if row is not None:
        raise damaged(db.store.location, f"primitive {row[0]}",
                      f"expected its demonstration {row[1]}, got none (an orphan primitive)")


def stored_metadata(db, raw, did) -> dict:
    """A demonstration's stored metadata, a JSON object; a damaged one is one line naming the row."""
    meta = stored_json(db, raw, f"demonstration {did} (its metadata)", did)
    if not isinstance(meta, dict):
        raise damaged(db.store.location, f"demonstration {did} (its metadata)", "expected a JSON "
                      f"object, got a JSON {type(meta).__name__}", remedy(db.store.location, did))
    return meta


def load_demonstrations(db, ids) -> dict:
    """Demonstrations by id, streams in their stored order; ValueError naming a missing one.

    A damaged row (a blob that is not ``.npy``, a header declaring more than
    the blob holds, a stored ``n_steps`` other than its ``t``'s, arrays that
    make no demonstration) is one line naming the library and the row.
    """
    ids = sorted({int(i) for i in ids})
    rows, streams = {}, {}
    for part in chunks(ids):
        q = placeholders(len(part))
        for did, n, t, meta in db.execute(
                f"SELECT id, n_steps, t, metadata FROM demonstrations WHERE id IN ({q})", part).fetchall():
            t = stored_array(db, t, f"demonstration {did} (its t)", did)
            if n != len(t):
                raise damaged(db.store.location, f"demonstration {did}", f"expected n_steps {len(t)} (the "
                              f"samples of its t), got {n!r}"[:200], remedy(db.store.location, did))
            rows[did] = (t, stored_metadata(db, meta, did))
        for did, name, data in db.execute(
                f"SELECT demonstration_id, name, data FROM streams WHERE demonstration_id IN ({q}) "
                "ORDER BY demonstration_id, position", part).fetchall():
            streams.setdefault(did, {})[name] = stored_array(db, data, f"demonstration {did} (stream "
                                                             f"{str(name)[:40]!r})", did)
    missing = [i for i in ids if i not in rows]
    if missing:
        raise ValueError(f"demonstration: no demonstration with id {missing[0]} in the library")
    out = {}
    for did, (t, meta) in rows.items():
        try:
            out[did] = Demonstration(t, streams.get(did, {}), meta)
        except ValueError as exc:  # keep the argument and the expectation, not the values it quotes
            raise damaged(db.store.location, f"demonstration {did}", "expected a valid demonstration, got "
                          f"one failing {str(exc).split(', got', 1)[0][:120]}",
                          remedy(db.store.location, did)) from None
    return out


def primitive_demo(parent: Demonstration, pid: int, did: int, start: int, stop: int) -> Demonstration:
    """The samples of one primitive, with its ids in the metadata."""
    demo = parent.slice(start, stop)
    demo.metadata.update(primitive_id=int(pid), demonstration_id=int(did))
    return demo


class SQLRecords:
    """The records protocol of :mod:`skillbank.store._transfer` over a SQL store (both backends).

    ``store`` (a :class:`~skillbank.store._sql.SQLStore`) gives the
    transactions: :meth:`snapshot` is its ``_read()`` (one consistent state
    while others write), :meth:`writing` its ``_write("import")`` (one
    transaction under the library's write lock); its id counters come in
    through the session's ``new_ids`` and the store's ``_counters`` /
    ``_set_counters``.
    """

    def __init__(self, store):
        self.store = store
        self.db = None

    @contextlib.contextmanager
    def snapshot(self):
        """A read transaction: one consistent state while others write."""
        with self.store._read() as self.db:
            yield self

    @contextlib.contextmanager
    def writing(self):
        """One write transaction (concurrent writers queue on the library's lock)."""
        with self.store._write("import") as self.db:
            yield self

    def counts(self) -> tuple:
        """``(demonstrations, clustering versions)`` stored."""
        return tuple(self.db.execute("SELECT (SELECT COUNT(*) FROM demonstrations), "
                                     "(SELECT COUNT(*) FROM cluster_versions)").fetchone())

    def demonstrations(self) -> tuple:
        """``(count, iterator of demonstration records by id)``, read one at a time."""
        db = self.db
        orphan_check(db)  # a primitive without its demonstration would be left out unseen
        rows = db.execute("SELECT d.id, d.source, d.created, p.kind, p.params, p.created, d.n_steps "
                          "FROM demonstrations d LEFT JOIN provenance p ON p.id = d.provenance_id "
                          "ORDER BY d.id").fetchall()

        def records():
            for did, source, created, kind, params, p_created, n in rows:
                prims = db.execute("SELECT id, start, stop, label FROM primitives "
                                   "WHERE demonstration_id = ? ORDER BY id", (did,)).fetchall()
                params = None if kind is None else to_json(stored_json(db, params, f"demonstration {did} "
                                                                       "(its provenance)", did))
                yield demonstration_record(did, source, created, (kind, params, p_created), prims,
                                           load_demonstrations(db, [did])[did], n)

        return len(rows), records()

    def versions(self):
        """Clustering version records, oldest first."""
        db = self.db
        for v, created, params, n, centers, mean, comps in db.execute(
                "SELECT version, created, params, n_clusters, centers, pca_mean, pca_components "
                "FROM cluster_versions ORDER BY version").fetchall():
            members = db.execute("SELECT primitive_id, cluster, features, assigned FROM cluster_members "
                                 "WHERE version = ? ORDER BY primitive_id", (v,)).fetchall()
            labels = db.execute("SELECT cluster, label FROM cluster_labels WHERE version = ? "
                                "ORDER BY cluster", (v,)).fetchall()
            row = f"clustering version {v}"
            arrays = [stored_array(db, b, f"{row} (its {name})")
                      for b, name in ((centers, "centers"), (mean, "pca_mean"), (comps, "pca_components"))]
            members = [(p, c, stored_array(db, f, f"{row} member {p} (its features)"), s)
                       for p, c, f, s in members]
            yield version_record(v, created, to_json(stored_json(db, params, f"{row} (its params)")), n,
                                 arrays, members, labels)

    def lengths(self, n_steps):
        """``{id: Demonstration}`` chunks of the stored demonstrations with one of the lengths ``n_steps``."""
        lengths = sorted({int(n) for n in n_steps})
        ids = [r[0] for part in chunks(lengths) for r in self.db.execute(
            f"SELECT id FROM demonstrations WHERE n_steps IN ({placeholders(len(part))})", part).fetchall()]
        for part in chunks(sorted(ids)):  # a chunk at a time: memory stays bounded on a large library
            yield load_demonstrations(self.db, part)

    def insert_demonstration(self, d, *, keep_id: bool) -> tuple:
        """Insert a demonstration record; returns ``(its id, {old primitive id: new})``."""
        prov, prims = d["provenance"], d["primitives"]
        encoded = encode(d["demo"], [(p["start"], p["stop"]) for p in prims], source=d["source"],
                         labels=[p["label"] for p in prims], created=d["created"],
                         provenance=None if prov is None else (prov["kind"], prov["params"], prov["created"]))
        [(did, pids)] = insert(self.db, [encoded], demo_ids=[d["id"]] if keep_id else None,
                               primitive_ids=[p["id"] for p in prims] if keep_id else None)
        return did, {p["id"]: new for p, new in zip(prims, pids, strict=True)}

    def insert_version(self, v, primitives: dict) -> int:
        """Insert a version record with its number; ``primitives`` maps its member ids to stored ones."""
        a, db = v["arrays"], self.db
        db.new_ids("cluster_versions", 1, [v["version"]])
        db.execute("INSERT INTO cluster_versions (version, created, params, n_clusters, centers, pca_mean, "
                   "pca_components) VALUES (?, ?, ?, ?, ?, ?, ?)",
                   (v["version"], v["created"], to_json(v["params"]), v["n_clusters"], to_npy(a["centers"]),
                    to_npy(a["pca_mean"]), to_npy(a["pca_components"])))
        db.executemany("INSERT INTO cluster_members (version, primitive_id, cluster, features, assigned) "
                       "VALUES (?, ?, ?, ?, ?)",
                       [(v["version"], primitives[int(i)], int(c), to_npy(f), s) for i, c, f, s in zip(
                           a["member_ids"], a["member_clusters"], a["member_features"], a["member_assigned"],
                           strict=True)])
        db.executemany("INSERT INTO cluster_labels (version, cluster, label) VALUES (?, ?, ?)",
                       [(v["version"], int(c), lab) for c, lab in v["labels"]])
        return v["version"]

    def counters(self) -> dict:
        """``{table: last id handed out}`` of the tables in :data:`~skillbank.store._transfer.COUNTED`."""
        return {t: n for t, n in self.store._counters(self.db).items() if t in COUNTED}

    def set_counters(self, counters: dict) -> None:
        """Make the next ids follow ``counters`` (never lowering one)."""
        self.store._set_counters(self.db, {t: int(counters.get(t, 0)) for t in COUNTED})

    def descriptions(self, *, history: bool = True) -> list:
        """Skill description records ``{"label", "revision", "created", "action", "binding"}`` by label,
        revision: every revision, or (``history=False``) each label's current one unless removed."""
        rows = self.db.execute("SELECT label, revision, created, action, binding FROM skill_descriptions "
                               "ORDER BY label, revision").fetchall()
        out = [{"label": lab, "revision": int(r), "created": c, "action": a, "binding": from_json(b)}
               for lab, r, c, a, b in rows]
        return out if history else current_descriptions(out)

    def insert_descriptions(self, rows) -> None:
        """Insert description records with their revision numbers (inside the caller's transaction)."""
        rows = [(d["label"], int(d["revision"]), d["created"], d["action"], to_json(d["binding"]))
                for d in rows]
        self.db.executemany("INSERT INTO skill_descriptions (label, revision, created, action, binding) "
                            "VALUES (?, ?, ?, ?, ?)", rows)
