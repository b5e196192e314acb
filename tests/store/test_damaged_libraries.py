"""A damaged library gives one line, through ``library list``, ``reuse``, ``copy`` and ``export``.

Each library is built by skillbank, then damaged by writing into its
database with the database's own driver (foreign keys off, as a crash, a
foreign tool or a hand edit would leave it): a blob that is text, a ``.npy``
header declaring 10^11 values, a sample count or primitive bound that
contradicts the samples, an orphan primitive, and the like. Every command
that reads the damaged row must exit with status 2 and one line naming the
library, the row and what is wrong, saying what to do, and change nothing: the
library stays as it was, a copy's destination and an export's folder are not
created.
"""

from __future__ import annotations

import io
import json
import re
import sqlite3

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from skillbank import Constraints, Demonstration
from skillbank.pipeline import Library
from skillbank.store import copy_library, open_store
from skillbank.store._arrays import from_npy, to_npy


def _curve(k, n=80):
    t = np.linspace(0.0, 1.0, n)
    bend = 0.6 if k % 2 else 0.0
    Y = np.column_stack([t * (1 + 0.05 * k), bend * np.sin(np.pi * t) + 0.01 * k, 0.1 * t])
    return Demonstration(t, {"position": Y}, {"k": k})


def _huge_header() -> bytes:
    """A .npy header declaring 10^11 float64 values (745 GiB), followed by 64 bytes."""
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (10 ** 11,)})
    return buf.getvalue() + bytes(64)


def _build(location) -> None:
    with Library(location) as lib:
        for k in range(6):
            lib.add(_curve(k), segment=False)
        lib.cluster(random_state=0)
        lib.label("straight", cluster=lib.primitives(demonstration=1, load=False)[0].cluster)


def _damage(location, sql: str, params=()) -> None:
    """Run ``sql`` (``?`` markers) on the library's database with its own driver, foreign keys off."""
    if str(location).startswith("postgresql://"):
        import psycopg  # the test extra's

        with psycopg.connect(str(location), autocommit=True) as conn:
            conn.execute("SET session_replication_role = replica")  # as superuser: no foreign-key triggers
            conn.execute(sql.replace("?", "%s"), params)
    else:
        conn = sqlite3.connect(location)
        try:
            conn.execute("PRAGMA foreign_keys = OFF")
            conn.execute(sql, params)
            conn.commit()
        finally:
            conn.close()


_REMOVE = r"; remove demonstration 1 \('skillbank library remove .+ 1'\) or restore the library from a " \
          "backup$"
_RESTORE = r"; restore it from a backup$"
READS_SAMPLES = ("reuse", "copy", "export")
READS_ROWS = ("list", "reuse", "copy", "export")

# (name, SQL, parameters, commands that must refuse, what the line says after "is damaged: ")
CASES = [
    ("stream is text", "UPDATE streams SET data = ? WHERE demonstration_id = 1",
     (b"plain text, not an array",), READS_SAMPLES, r"demonstration 1 \(stream 'position'\): expected \.npy "
     r"array bytes, got bytes that are not \(no \.npy magic\)" + _REMOVE),
    ("stream is a TEXT value", "UPDATE streams SET data = ? WHERE demonstration_id = 1",
     ("plain text, not an array",), READS_SAMPLES, r"demonstration 1 \(stream 'position'\): expected \.npy "
     r"array bytes, got (text|bytes that are not \(no \.npy magic\))" + _REMOVE),
    ("t declares 10^11 values", "UPDATE demonstrations SET t = ? WHERE id = 1", (_huge_header(),),
     READS_SAMPLES, r"demonstration 1 \(its t\): expected a \.npy array whose header matches its data, got "
     r"a header declaring 800000000000 bytes of data \(<f8 of shape \(100000000000,\)\) followed by 64"
     + _REMOVE),
    ("t is empty bytes", "UPDATE demonstrations SET t = ? WHERE id = 1", (b"",),
     READS_SAMPLES, r"demonstration 1 \(its t\): expected \.npy array bytes, got bytes that are not "
     r"\(no \.npy magic\)" + _REMOVE),
    ("features declare 10^11 values", "UPDATE cluster_members SET features = ? WHERE primitive_id = 1",
     (_huge_header(),), READS_ROWS, r"clustering version 1 member 1 \(its features\): expected a \.npy array "
     r"whose header matches its data, got a header declaring 800000000000 bytes" + r".*" + _RESTORE),
    # list shows each demonstration's point of the robot (its metadata's pose_of): it reads the metadata
    ("metadata is not JSON", "UPDATE demonstrations SET metadata = ? WHERE id = 1", ("{not json",),
     READS_ROWS, r"demonstration 1 \(its metadata\): expected JSON text, got text that is not" + _REMOVE),
    ("metadata is a list", "UPDATE demonstrations SET metadata = ? WHERE id = 1", ("[1, 2]",),
     READS_ROWS, r"demonstration 1 \(its metadata\): expected a JSON object, got a JSON list" + _REMOVE),
    ("n_steps = -5", "UPDATE demonstrations SET n_steps = -5 WHERE id = 1", (),
     READS_ROWS, r"demonstration 1: expected n_steps (>= 1|80 \(the samples of its t\)), got -5"),
    ("n_steps longer than t", "UPDATE demonstrations SET n_steps = 500 WHERE id = 1", (),
     READS_SAMPLES, r"demonstration 1: expected n_steps 80 \(the samples of its t\), got 500" + _REMOVE),
    ("primitive ends past its demonstration", "UPDATE primitives SET stop = 500 WHERE id = 1", (),
     READS_ROWS, r"(demonstration 1 )?primitive 1: expected 0 <= start < stop <= 80 \(the samples of "
     r"demonstration 1\), got start 0, stop 500"),
    ("orphan primitive", "UPDATE primitives SET demonstration_id = 99 WHERE id = 1", (),
     READS_ROWS, r"primitive 1: expected its demonstration 99, got none \(an orphan primitive\)" + _RESTORE),
    ("member in no cluster", "UPDATE cluster_members SET cluster = 7 WHERE primitive_id = 2", (),
     ("copy", "export"), r"clustering version 1: expected member_clusters to hold clusters in 0\.\.\d, got 1 "
     r"that do not \(first 7\); nothing was (copied|exported)" + _RESTORE),
]
IDS = [c[0] for c in CASES]


def _run(cli, command, location, tmp_path):
    """``(exit status, out, err)`` of one command on the library, and what it must not have created."""
    made = tmp_path / {"copy": "copy.db", "export": "exported"}.get(command, "none")
    argv = {"list": ("library", "list", location),
            "reuse": ("library", "reuse", location, "--skill", "straight", "--goal", "1,0,0.1"),
            "copy": ("library", "copy", location, made),
            "export": ("library", "export", location, made)}[command]
    return (*cli(*argv), made)


@pytest.mark.parametrize(("name", "sql", "params", "refusing", "match"), CASES, ids=IDS)
def test_a_damaged_library_is_one_line_through_every_command(cli, new_library, library_content, tmp_path,
                                                             name, sql, params, refusing, match):
    location = new_library()
    _build(location)
    _damage(location, sql, params)
    before = library_content(location)
    with open_store(location, readonly=True) as store:
        shown = re.escape(store.location)  # as messages show it (a URL without its password)
    for command in READS_ROWS:
        code, out, err, made = _run(cli, command, location, tmp_path)
        if command not in refusing:  # list reads no samples: it lists what the rows and metadata say
            assert code == 0, (command, err)
            continue
        assert code == 2 and out == "" and err.count("\n") == 1, (command, err)
        assert re.match(rf"skillbank library {command}: error: library '{shown}' is damaged: {match}", err), \
            (command, err)
        assert not made.exists(), command  # no copy, no export folder left behind
    assert library_content(location) == before


def test_a_header_declaring_745_gib_is_refused_within_a_1_gib_limit(limited, tmp_path):
    location = tmp_path / "lib.db"
    _build(location)
    _damage(location, "UPDATE demonstrations SET t = ? WHERE id = 1", (_huge_header(),))
    code, out, err = limited("library", "reuse", location, "--skill", "straight", "--goal", "1,0,0.1",
                             memory=1 << 30, timeout=120)
    assert code == 2 and err.count("\n") == 1 and "declaring 800000000000 bytes of data" in err, err


def test_a_damaged_source_leaves_an_existing_destination_unchanged(cli, new_library, library_content,
                                                                   tmp_path):
    source, destination = tmp_path / "src.db", new_library("dst")
    _build(source)
    _damage(source, "UPDATE primitives SET stop = 500 WHERE id = 4")
    assert cli("library", "init", destination)[0] == 0
    before = library_content(destination)
    code, out, err = cli("library", "copy", source, destination)
    assert code == 2 and err.count("\n") == 1, err
    assert "is damaged: demonstration 4 primitive 4: expected 0 <= start < stop <= 80" in err, err
    assert "nothing was copied" in err and library_content(destination) == before


def test_a_counter_past_2_53_is_not_copied(cli, new_library, library_content, tmp_path):
    """The copy's next add would overflow SQLite's integer from a counter of 2^63 - 1."""
    source = new_library("src")
    _build(source)
    if str(source).startswith("postgresql://"):
        _damage(source, "UPDATE sequences SET last = ? WHERE name = 'demonstrations'", (2 ** 63 - 1,))
    else:
        _damage(source, "UPDATE sqlite_sequence SET seq = ? WHERE name = 'demonstrations'", (2 ** 63 - 1,))
    code, out, err = cli("library", "copy", source, tmp_path / "copy.db")
    assert code == 2 and err.count("\n") == 1, err
    assert re.search(r"is damaged: its demonstrations id counter: expected an id in 0\.\.9007199254740991 "
                     r"\(2\^53 - 1\), got 9223372036854775807; nothing was copied", err), err
    assert not (tmp_path / "copy.db").exists()


def test_the_python_api_raises_the_same_line(tmp_path):
    location = tmp_path / "lib.db"
    _build(location)
    _damage(location, "UPDATE streams SET data = ? WHERE demonstration_id = 1", (b"text",))
    with Library(location, readonly=True) as lib:
        with pytest.raises(ValueError, match=r"^library '.*lib\.db' is damaged: demonstration 1 \(stream "
                                             r"'position'\): expected \.npy array bytes"):
            lib.reuse("straight", Constraints(goal=[1.0, 0.0, 0.1]))
        with pytest.raises(ValueError, match=r"is damaged: demonstration 1 \(stream 'position'\)"):
            lib.demonstration(1)
        assert len(lib.primitives(load=False)) == 6  # the rows themselves are sound
    with open_store(location, readonly=True) as src, open_store(tmp_path / "b.db") as dst:
        with pytest.raises(ValueError, match=r"is damaged: demonstration 1 \(stream 'position'\)"):
            copy_library(src, dst)
        assert dst.demonstration_ids() == []


def test_removing_the_damaged_demonstration_repairs_the_library(cli, tmp_path):
    """What the message says to do works: remove the demonstration, and every command runs again."""
    location = tmp_path / "lib.db"
    _build(location)
    _damage(location, "UPDATE demonstrations SET t = ? WHERE id = 3", (_huge_header(),))
    assert cli("library", "copy", location, tmp_path / "a.db")[0] == 2
    assert cli("library", "remove", location, "3")[0] == 0
    code, out, err = cli("library", "copy", location, tmp_path / "b.db", "--json")
    assert code == 0 and json.loads(out)["demonstrations"] == 5, err


# -- from_npy on its own ----------------------------------------------------------------------------------
@pytest.mark.parametrize(("blob", "match"), [
    (None, r"^expected \.npy array bytes, got NULL$"),
    ("text", r"^expected \.npy array bytes, got text$"),
    (b"", r"^expected \.npy array bytes, got bytes that are not \(no \.npy magic\)$"),
    (b"\x93NUMPY\x09\x00", r"^expected a \.npy array of format 1\.0 or 2\.0, got format 9\.0$"),
    (_huge_header(), r"header declaring 800000000000 bytes of data \(<f8 of shape \(100000000000,\)\) "
                     "followed by 64$"),
    (to_npy(np.arange(3.0))[:-1], r"declaring 24 bytes of data \(<f8 of shape \(3,\)\) followed by 23$"),
    (to_npy(np.arange(3.0)) + b"\x00", r"declaring 24 bytes of data .* followed by 25$"),
])
def test_from_npy_refuses_in_one_line(blob, match):
    with pytest.raises(ValueError, match=match):
        from_npy(blob)


def test_from_npy_refuses_pickles_without_unpickling():
    buf = io.BytesIO()
    np.save(buf, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError, match=r"an array of Python objects: not a numeric \.npy array"):
        from_npy(buf.getvalue())


_DTYPES = st.sampled_from(["<f8", "<f4", ">f8", "<i8", "<i4", "|u1", "|b1", "<U3"])


@settings(max_examples=120, deadline=None)
@given(array=_DTYPES.flatmap(lambda dt: hnp.arrays(np.dtype(dt), hnp.array_shapes(min_dims=0, max_dims=3,
                                                                                    min_side=0, max_side=4))),
       fortran=st.booleans())
def test_from_npy_gives_back_the_bytes_it_was_given(array, fortran):
    """Decoding then encoding again is byte for byte the identity (a copy keeps every blob as it was)."""
    array = np.asfortranarray(array) if fortran else array
    blob = to_npy(array)
    back = from_npy(blob)
    assert back.dtype == array.dtype and back.shape == array.shape and back.flags.writeable
    assert to_npy(back) == blob and from_npy(memoryview(blob)).tobytes() == back.tobytes()


@pytest.mark.parametrize(("sql", "params", "command", "match"), [
    ("UPDATE streams SET data = 5 WHERE demonstration_id = 1", (), "reuse",
     r"demonstration 1 \(stream 'position'\): expected \.npy array bytes, got a value of type int"),
    ("UPDATE primitives SET stop = 40.5 WHERE id = 1", (), "list",
     r"primitive 1: expected 0 <= start < stop <= 80 \(the samples of demonstration 1\), got start 0, "
     r"stop 40\.5"),
])
def test_values_of_another_type_in_a_sqlite_column(cli, tmp_path, sql, params, command, match):
    """SQLite keeps a value of any type in any column: one of the wrong type is named, not used."""
    location = tmp_path / "lib.db"
    _build(location)
    _damage(location, sql, params)
    code, out, err, _ = _run(cli, command, location, tmp_path)
    assert code == 2 and err.count("\n") == 1 and re.search(f"is damaged: {match}", err), err
