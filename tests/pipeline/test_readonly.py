"""Read-only libraries: a library in a folder nobody may write is read without writing anything.

The tests run as root, and root may write anywhere: so the folder's permissions alone would prove
nothing here. These tests make the permission check answer "not writable" (what it answers for any
other user), chmod the folder anyway, and check that nothing is written: no ``-wal``/``-shm`` file,
the library's bytes unchanged. ``tests/cli/test_library_cli.py`` runs the commands as the user
``nobody`` for the real permission check.
"""

from __future__ import annotations

import hashlib
import os
import sqlite3
import stat

import pytest

from skillbank import Constraints, Demonstration
from skillbank.pipeline import Library
from skillbank.store import SQLiteStore, _schema


def _digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _side_files(path) -> list:
    return sorted(p.name for p in path.parent.iterdir() if p.name != path.name)


@pytest.fixture
def shared(tmp_path, make_skills):
    """A clustered, labelled library alone in a folder, then chmod 0o555 (file 0o444)."""
    folder = tmp_path / "lab"
    folder.mkdir()
    path = folder / "skills.db"
    with Library(path) as lib:
        lib.add_many(make_skills(), segment=False)
        lib.cluster()
        lib.label("straight", cluster=lib.primitives(demonstration=1)[0].cluster)
    assert _side_files(path) == []  # the last connection checkpointed and removed the WAL
    os.chmod(path, 0o444)
    os.chmod(folder, 0o555)
    yield path
    os.chmod(folder, 0o755)
    os.chmod(path, 0o644)


@pytest.fixture
def not_writable(monkeypatch):
    """The folder-permission check answers as it does for a user who may not write the folder."""
    monkeypatch.setattr(_schema, "_folder_writable", lambda folder: False)


def test_a_library_in_a_read_only_folder_is_read_without_writing(shared, not_writable, tmp_path):
    digest = _digest(shared)
    with Library(shared, readonly=True) as lib:
        assert lib.store.readonly is True
        doc = lib.summary()
        assert doc["n_demonstrations"] == 12 and doc["unassigned"] == {"count": 0, "ids": []}
        assert [p.id for p in lib.primitives(label="straight")] == [1, 2, 3, 4, 5, 6]
        Y = lib.primitives(label="straight")[0].demo["position"]
        res = lib.reuse("straight", Constraints(start=Y[0], goal=Y[-1] + 0.05), method="lte")
        assert res.constraint_error < 1e-9
        manifest = lib.export(tmp_path / "copy")
        assert manifest.is_file() and len(list((tmp_path / "copy" / "demonstrations").iterdir())) == 12
        assert lib.check() == "ok"
        for write, what in [
            (lambda: lib.add(Demonstration.from_array(Y), segment=False), "add demonstrations"),
            (lambda: lib.label("x", cluster=0), "label"),
            (lambda: lib.cluster(), "record a clustering"),
            (lambda: lib.remove(1), "remove a demonstration"),
        ]:
            with pytest.raises(ValueError, match=rf"library '.*skills\.db' is open read-only: cannot {what}"):
                write()
        assert _side_files(shared) == []
    assert _side_files(shared) == [] and _digest(shared) == digest


def test_read_only_commands_open_read_only_in_a_writable_folder(tmp_path, make_skills):
    """Another process writing meanwhile is seen: a writable folder is read through the WAL, not as frozen."""
    path = tmp_path / "live.db"
    with Library(path) as writer:
        writer.add_many(make_skills()[:3], segment=False)
        with Library(path, readonly=True) as reader:
            assert reader.demonstration_ids() == [1, 2, 3]
            writer.add(make_skills()[3], segment=False)
            assert reader.demonstration_ids() == [1, 2, 3, 4]
            with pytest.raises(ValueError, match="is open read-only: cannot add demonstrations"):
                reader.add(make_skills()[4], segment=False)
        assert writer.demonstration_ids() == [1, 2, 3, 4]


def test_a_read_only_folder_with_a_live_wal_is_read_through_it(tmp_path, make_skills, monkeypatch):
    """While a writer keeps changes in the -wal file, a reader of a read-only folder still sees them."""
    path = tmp_path / "busy.db"
    with Library(path) as writer:
        writer.store.conn.execute("PRAGMA wal_autocheckpoint = 0")  # keep every commit in the WAL
        writer.add_many(make_skills()[:2], segment=False)
        assert path.with_name("busy.db-wal").stat().st_size > 0
        monkeypatch.setattr(_schema, "_folder_writable", lambda folder: False)  # for the reader
        with Library(path, readonly=True) as reader:
            assert reader.demonstration_ids() == [1, 2]


def test_read_only_opening_refuses_what_it_cannot_read(tmp_path):
    with pytest.raises(ValueError, match=r"'.*missing\.db' does not exist"):
        Library(tmp_path / "missing.db", readonly=True)
    assert not (tmp_path / "missing.db").exists()
    (tmp_path / "empty.db").touch()
    with pytest.raises(ValueError, match=r"'.*empty\.db' is empty, not a skillbank library"):
        Library(tmp_path / "empty.db", readonly=True)
    old = tmp_path / "old.db"
    Library(old).close()
    conn = sqlite3.connect(old)
    conn.execute("PRAGMA user_version = 1")
    conn.close()
    with pytest.raises(ValueError, match=r"has schema version 1.*open it once read-write"):
        SQLiteStore(old, readonly=True)
    assert sqlite3.connect(old).execute("PRAGMA user_version").fetchone()[0] == 1


def test_a_foreign_sqlite_file_is_rejected_unchanged(tmp_path):
    """Checked before anything is written: the file stays in its own journal mode, byte for byte."""
    other = tmp_path / "invoices.db"
    conn = sqlite3.connect(other)
    conn.execute("CREATE TABLE invoices (id INTEGER PRIMARY KEY, total REAL)")
    conn.execute("INSERT INTO invoices VALUES (1, 9.5)")
    conn.commit()
    conn.close()
    digest, mode = _digest(other), stat.S_IMODE(other.stat().st_mode)
    for readonly in (False, True):
        with pytest.raises(ValueError, match=r"SQLite file but not a skillbank library \(tables \['invoi"):
            Library(other, readonly=readonly)
        assert _digest(other) == digest and _side_files(other) == []
    conn = sqlite3.connect(other)
    assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "delete"
    conn.close()
    assert stat.S_IMODE(other.stat().st_mode) == mode
    # a SQLite file with a user_version but no skillbank meta is refused the same way
    tagged = tmp_path / "tagged.db"
    conn = sqlite3.connect(tagged)
    conn.execute("CREATE TABLE notes (x)")
    conn.execute("PRAGMA user_version = 2")
    conn.close()
    digest = _digest(tagged)
    with pytest.raises(ValueError, match="is a SQLite file but not a skillbank library"):
        Library(tagged)
    assert _digest(tagged) == digest


def test_writing_a_library_whose_folder_is_not_writable_says_so(shared, not_writable):
    with pytest.raises(ValueError, match=r"library '.*skills\.db' is read-only here \(its file or its folder "
                                         r"is not writable\).*'library list', 'reuse' and 'export'"):
        Library(shared)
    assert _side_files(shared) == []

