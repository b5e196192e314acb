"""``copy_library``: SQLite <-> PostgreSQL in both directions, ids, versions and counters kept.

"Identical" is checked on the rows themselves, read with each database's own driver: every
demonstration (with its provenance), stream, primitive, clustering version, member, label, and the
id counters, byte for byte.
"""

from __future__ import annotations

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.pipeline import Library
from skillbank.store import copy_library, open_store


def _curve(k, n=80):
    t = np.linspace(0.0, 1.0, n)
    bend = 0.6 if k % 2 else 0.0
    Y = np.column_stack([t * (1 + 0.05 * k), bend * np.sin(np.pi * t) + 0.01 * k, 0.1 * t])
    return Demonstration(t, {"position": Y, "gripper": (t > 0.5).astype(float)}, {"k": k})


def _build(location) -> None:
    """A library with everything a copy must carry: two clustering versions, labels of both kinds,
    primitives that joined incrementally, one left unclustered, a removed demonstration (an id gap) and
    two revisions of a skill description."""
    with Library(location) as lib:
        for k in range(6):
            lib.add(_curve(k), segment=False, source=f"c{k}.h5")
        lib.cluster(random_state=0)
        lib.cluster(random_state=0)  # version 2; version 1 stays in the store
        lib.label("straight", cluster=lib.primitives(demonstration=1, load=False)[0].cluster)
        lib.add(_curve(6), segment=False, label="own")  # joins version 2 incrementally
        lib.add(_curve(7), segment=False, assign="none")
        lib.add(_curve(8), segment=False)
        lib.remove(9)  # the highest id: only the counter remembers it
        lib.store.set_description("straight", "(:action straight)", {"goal": [1.0, 0.0, 0.1]})
        lib.store.set_description("straight", "(:action straight :parameters (?g))", {})


def test_sqlite_to_postgres_to_sqlite_is_identical(tmp_path, postgres_server, postgres_url, table_rows,
                                                   library_content):
    a, b = tmp_path / "a.db", tmp_path / "b.db"
    _build(a)
    original = library_content(a)
    assert len(original["cluster_versions"]) == 2 and original["counters"][0] == ("cluster_versions", 2)
    assert {r[4] for r in original["cluster_members"]} == {"fit", "incremental"}
    before = table_rows(a)
    with open_store(a, readonly=True) as src, open_store(postgres_url) as dst:
        assert copy_library(src, dst) == {"demonstrations": 8, "primitives": 8, "versions": 2}
        assert dst.check() == "ok"
    assert table_rows(a) == before  # the source is only read
    assert library_content(postgres_url) == original
    with open_store(postgres_url, readonly=True) as src, open_store(b) as dst:
        copy_library(src, dst)
    assert library_content(b) == original
    with Library(a) as la, Library(b) as lb, Library(postgres_url) as lp:
        assert la.summary() == lb.summary() == lp.summary()
        # the counters came along: the next demonstration gets the same id everywhere (not the removed 9)
        assert la.add(_curve(9), segment=False) == lb.add(_curve(9), segment=False) == \
            lp.add(_curve(9), segment=False) == 10


def test_postgres_to_sqlite_to_postgres_is_identical(tmp_path, postgres_server, postgres_url,
                                                     library_content):
    _build(postgres_url)
    original = library_content(postgres_url)
    second = postgres_server.url("copy_" + postgres_url.rsplit("/", 1)[1])
    postgres_server.create_database(second.rsplit("/", 1)[1])
    try:
        with open_store(postgres_url, readonly=True) as src, open_store(tmp_path / "mid.db") as dst:
            copy_library(src, dst)
        assert library_content(tmp_path / "mid.db") == original
        with open_store(tmp_path / "mid.db", readonly=True) as src, open_store(second) as dst:
            copy_library(src, dst)
        assert library_content(second) == original
    finally:
        postgres_server.drop_database(second.rsplit("/", 1)[1])


@pytest.mark.parametrize("into", ["sqlite", "postgresql"])
def test_a_non_empty_destination_is_refused_unchanged(tmp_path, postgres_url, into, library_content):
    source, target = tmp_path / "src.db", (tmp_path / "dst.db" if into == "sqlite" else postgres_url)
    _build(source)
    with open_store(target) as dst:
        dst.add_demonstration(_curve(0), [(0, 80)])
    before = library_content(target)
    with open_store(source, readonly=True) as src, open_store(target) as dst:
        with pytest.raises(ValueError, match=r"^destination: expected an empty library, '.*' holds 1 "
                                             r"demonstration\(s\) and 0 clustering version\(s\); 'library "
                                             r"copy' writes only into an empty library \(to merge, 'library "
                                             r"export' then 'library import'\)$"):
            copy_library(src, dst)
    assert library_content(target) == before


def test_a_failed_copy_leaves_the_destination_empty(tmp_path, postgres_url, monkeypatch):
    _build(tmp_path / "src.db")
    from skillbank.store import _records

    calls = []

    def broken(*args, **kwargs):  # the third demonstration fails to go in
        calls.append(1)
        if len(calls) == 3:
            raise OSError("disk full")
        return real(*args, **kwargs)

    real = _records.insert
    monkeypatch.setattr(_records, "insert", broken)
    with open_store(tmp_path / "src.db", readonly=True) as src, open_store(postgres_url) as dst:
        with pytest.raises(OSError, match="disk full"):
            copy_library(src, dst, progress=lambda done, total: None)
        assert dst.demonstration_ids() == [] and dst.versions() == []
        monkeypatch.setattr(_records, "insert", real)
        seen = []
        copy_library(src, dst, progress=lambda done, total: seen.append((done, total)))
        assert seen == [(k, 8) for k in range(9)] and len(dst.demonstration_ids()) == 8


def test_export_and_import_through_postgres(tmp_path, postgres_server, postgres_url, library_content):
    _build(tmp_path / "a.db")
    with Library(tmp_path / "a.db") as lib:
        lib.export(tmp_path / "exp")
    with Library(postgres_url) as lib:
        result = lib.import_folder(tmp_path / "exp")
        assert result["mode"] == "copy" and len(result["versions"]) == 2
        lib.export(tmp_path / "exp2")
        again = lib.import_folder(tmp_path / "exp2")  # a merge: everything is already there
        assert again["mode"] == "merge" and len(again["skipped"]) == 8 and again["demonstrations"] == {}
    without_counters = {k: v for k, v in library_content(tmp_path / "a.db").items() if k != "counters"}
    assert {k: v for k, v in library_content(postgres_url).items() if k != "counters"} == \
        without_counters
    with Library(tmp_path / "b.db") as lib:
        lib.import_folder(tmp_path / "exp2")
    assert {k: v for k, v in library_content(tmp_path / "b.db").items() if k != "counters"} == \
        without_counters
