"""Durability: concurrent writers, a writer killed mid-add, damaged files, migration of an old schema."""

from __future__ import annotations

import io
import multiprocessing
import os
import signal
import sqlite3
import time

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.pipeline import Library

_CTX = multiprocessing.get_context("fork")


def _small_demo(worker: int, k: int) -> Demonstration:
    t = np.linspace(0.0, 1.0, 20)
    Y = np.column_stack([t + worker, k * t, np.sin(t)])
    return Demonstration(t, {"position": Y}, {"worker": worker, "k": k})


def _writer(path, worker, n, errors):
    try:
        with Library(path) as lib:
            for k in range(n):
                lib.add(_small_demo(worker, k), segment=False, source=f"w{worker}")
    except BaseException as exc:  # reported to the parent, which fails the test
        errors.put(f"worker {worker}: {type(exc).__name__}: {exc}")


def test_four_processes_add_fifty_demonstrations_each(tmp_path):
    path = tmp_path / "shared.db"
    Library(path).close()
    errors = _CTX.Queue()
    procs = [_CTX.Process(target=_writer, args=(path, w, 50, errors)) for w in range(4)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(120)
    assert [p.exitcode for p in procs] == [0, 0, 0, 0]
    assert errors.empty(), errors.get()
    with Library(path) as lib:
        assert lib.check() == "ok"
        doc = lib.summary()
        assert doc["n_demonstrations"] == 200 and len(doc["primitives"]) == 200
        for w in range(4):
            prims = lib.primitives(source=f"w{w}")
            assert sorted(p.demo.metadata["k"] for p in prims) == list(range(50))
            assert all(np.array_equal(p.demo["position"], _small_demo(w, p.demo.metadata["k"])["position"])
                       for p in prims)


def _slow_add(path, marker):
    # The documented test hook: sleep inside the add transaction, after the demonstration
    # and its streams are written and before its primitives are.
    os.environ["SKILLBANK_LIBRARY_TEST_PAUSE"] = "60"
    os.environ["SKILLBANK_LIBRARY_TEST_MARKER"] = str(marker)
    with Library(path) as lib:
        lib.add(_small_demo(9, 9), segment=False, source="killed")


def test_process_killed_in_the_middle_of_an_add(tmp_path):
    path, marker = tmp_path / "kill.db", tmp_path / "in_transaction"
    with Library(path) as lib:
        lib.add(_small_demo(0, 0), segment=False, source="before")
    proc = _CTX.Process(target=_slow_add, args=(path, marker))
    proc.start()
    deadline = time.monotonic() + 60
    while not marker.exists() and time.monotonic() < deadline and proc.is_alive():
        time.sleep(0.02)
    assert marker.exists(), "the child never reached the pause inside the transaction"
    os.kill(proc.pid, signal.SIGKILL)
    proc.join(10)
    assert proc.exitcode == -signal.SIGKILL
    with Library(path) as lib:
        assert lib.check() == "ok"
        assert lib.demonstration_ids() == [1]
        for table in ("demonstrations", "streams", "primitives", "provenance"):
            assert lib.store.conn.execute(f"SELECT COUNT(*) FROM {table}").fetchone()[0] == 1, table  # noqa: S608
        did = lib.add(_small_demo(9, 9), segment=False, source="killed")
        [prim] = lib.primitives(source="killed")
        assert prim.demonstration_id == did and prim.n_steps == 20


def _one_line_error(path, match):
    with pytest.raises(ValueError, match=match) as info:
        with Library(path) as lib:
            lib.summary()
    assert "\n" not in str(info.value)


def test_non_sqlite_file(tmp_path):
    path = tmp_path / "notes.db"
    path.write_text("these are not the bytes you are looking for\n" * 100)
    _one_line_error(path, "is not a SQLite file")


def test_corrupt_file(tmp_path):
    path = tmp_path / "corrupt.db"
    with Library(path) as lib:
        lib.add_many([_small_demo(0, k) for k in range(5)], segment=False)
    data = bytearray(path.read_bytes())
    data[100:2000] = b"\xa5" * 1900  # the schema page's b-tree, just after the 100-byte file header
    path.write_bytes(bytes(data))
    _one_line_error(path, "not a readable skillbank library|malformed")


def test_truncated_file(tmp_path):
    path = tmp_path / "short.db"
    with Library(path) as lib:
        lib.add_many([_small_demo(0, k) for k in range(20)], segment=False)
    path.write_bytes(path.read_bytes()[:5000])
    with pytest.raises(ValueError, match="library") as info:
        with Library(path) as lib:
            lib.primitives()
            lib.summary()
    assert "\n" not in str(info.value)


def test_newer_schema_and_foreign_database(tmp_path):
    path = tmp_path / "future.db"
    Library(path).close()
    conn = sqlite3.connect(path)
    conn.execute("PRAGMA user_version = 99")
    conn.close()
    _one_line_error(path, "schema version 99, written by a newer skillbank")
    other = tmp_path / "other.db"
    conn = sqlite3.connect(other)
    conn.execute("CREATE TABLE invoices (id INTEGER PRIMARY KEY, total REAL)")
    conn.close()
    _one_line_error(other, "not a skillbank library")


def _npy(a) -> bytes:
    buf = io.BytesIO()
    np.save(buf, np.asarray(a), allow_pickle=False)
    return buf.getvalue()


def test_migrates_a_version_1_library(tmp_path):
    """A library in the first layout (no provenance, no assignment kind), built by hand."""
    path = tmp_path / "v1.db"
    conn = sqlite3.connect(path)
    conn.executescript("""
        CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
        CREATE TABLE demonstrations (id INTEGER PRIMARY KEY AUTOINCREMENT, source TEXT,
            n_steps INTEGER NOT NULL, t BLOB NOT NULL, metadata TEXT NOT NULL, created TEXT NOT NULL);
        CREATE TABLE streams (demonstration_id INTEGER NOT NULL REFERENCES demonstrations(id)
            ON DELETE CASCADE, name TEXT NOT NULL, position INTEGER NOT NULL, data BLOB NOT NULL,
            PRIMARY KEY (demonstration_id, name));
        CREATE TABLE primitives (id INTEGER PRIMARY KEY AUTOINCREMENT, demonstration_id INTEGER NOT NULL
            REFERENCES demonstrations(id) ON DELETE CASCADE, start INTEGER NOT NULL, stop INTEGER NOT NULL,
            label TEXT);
        CREATE TABLE cluster_versions (version INTEGER PRIMARY KEY AUTOINCREMENT, created TEXT NOT NULL,
            params TEXT NOT NULL, n_clusters INTEGER NOT NULL, centers BLOB NOT NULL, pca_mean BLOB NOT NULL,
            pca_components BLOB NOT NULL);
        CREATE TABLE cluster_members (version INTEGER NOT NULL REFERENCES cluster_versions(version)
            ON DELETE CASCADE, primitive_id INTEGER NOT NULL REFERENCES primitives(id) ON DELETE CASCADE,
            cluster INTEGER NOT NULL, features BLOB NOT NULL, PRIMARY KEY (version, primitive_id));
        CREATE TABLE cluster_labels (version INTEGER NOT NULL REFERENCES cluster_versions(version)
            ON DELETE CASCADE, cluster INTEGER NOT NULL, label TEXT NOT NULL, PRIMARY KEY (version, cluster));
        PRAGMA user_version = 1;
    """)
    conn.execute("INSERT INTO meta VALUES ('application', 'skillbank')")
    t = np.linspace(0.0, 1.0, 30)
    Y = np.column_stack([t, t ** 2])
    conn.execute("INSERT INTO demonstrations VALUES (1, 'old.csv', 30, ?, '{\"user\": \"a\"}', '2024-01-01')",
                 (_npy(t),))
    conn.execute("INSERT INTO streams VALUES (1, 'position', 0, ?)", (_npy(Y),))
    conn.execute("INSERT INTO primitives VALUES (1, 1, 0, 12, NULL), (2, 1, 12, 30, 'tail')")
    # A one-feature "clustering" by hand: feature = mean x-direction, PCA identity in 1-D.
    conn.execute("INSERT INTO cluster_versions VALUES (1, '2024-01-02', ?, 2, ?, ?, ?)",
                 ('{"features": "position", "n_points": 2, "stretch": 1.2}', _npy([[-1.0], [1.0]]),
                  _npy([0.5, 0.5, 0.5, 0.5]), _npy([[1.0, 0.0, 0.0, 0.0]])))
    conn.execute("INSERT INTO cluster_members VALUES (1, 1, 0, ?), (1, 2, 1, ?)",
                 (_npy([-0.5]), _npy([0.5])))
    conn.execute("INSERT INTO cluster_labels VALUES (1, 0, 'head')")
    conn.commit()
    conn.close()

    with Library(path) as lib:
        assert lib.store.conn.execute("PRAGMA user_version").fetchone()[0] == 2
        assert lib.check() == "ok"
        assert lib.provenance(1) == {"unknown": True, "migrated_from_schema": 1}
        prims = lib.primitives()
        assert [(p.id, p.cluster, p.label) for p in prims] == [(1, 0, "head"), (2, 1, "tail")]
        assert np.array_equal(prims[1].demo["position"], Y[12:])
        assigned = lib.store.conn.execute("SELECT assigned FROM cluster_members ORDER BY primitive_id").fetchall()
        assert assigned == [("fit",), ("fit",)]
        # The migrated library takes new demonstrations, assigned with the old version's featuriser:
        # resampled to 2 points, x of the start (about 5) minus 0.5 -> nearest centre +1 -> cluster 1.
        did = lib.add(Demonstration.from_array(np.column_stack([t + 5, t])), segment=False)
        assert lib.primitives(demonstration=did)[0].cluster == 1
    with Library(path) as lib:  # opening again is a no-op
        assert lib.summary()["n_demonstrations"] == 2
