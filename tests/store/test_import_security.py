"""``import_folder`` trusts nothing in an exported folder: paths stay inside it, the manifest is validated.

Each hostile folder is imported into an empty and into a non-empty library;
the import must fail with one line naming the manifest entry, never quoting
the outside file (it holds a recognisable secret), and leave every row of the
library as it was, the library still opening.
"""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import threading
import zipfile

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank import Demonstration
from skillbank.cli import _main
from skillbank.io import write_npz
from skillbank.store import SQLiteStore
from skillbank.store import _manifest as manifest_module
from skillbank.store._arrays import content_hash
from skillbank.store._manifest import check_manifest, json_depth

SECRET = "TOPSECRET-7f3a-do-not-print"


def _demo(k, n=40):
    t = np.linspace(0.0, 1.0, n)
    return Demonstration(t, {"position": np.column_stack([t, k * t ** 2])}, {"source": f"d{k}", "k": k})


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """A folder exported from a library of 3 demonstrations (2 primitives each) and one clustering."""
    root = tmp_path_factory.mktemp("src")
    with SQLiteStore(root / "src.db") as store:
        pids = [p for k in range(3) for p in store.add_demonstration(_demo(k), [(0, 20), (20, 40)])[1]]
        rng = np.random.default_rng(0)
        store.add_version(params={"features": "default", "n_points": 16}, centers=rng.normal(size=(2, 2)),
                          pca_mean=rng.normal(size=4), pca_components=rng.normal(size=(2, 4)),
                          members=[(p, k % 2, rng.normal(size=2)) for k, p in enumerate(pids)],
                          labels={0: "reach"})
        store.set_label("odd", primitive=3)
        store.export(root / "export")
    return root / "export"


@pytest.fixture
def outside(tmp_path):
    """Files outside the export folder that hold the secret: an NPZ and a text file."""
    where = tmp_path / "outside"
    where.mkdir()
    write_npz(Demonstration(np.linspace(0, 1, 40), {"position": np.zeros((40, 2))}, {"secret": SECRET}),
              where / "secret.npz")
    (where / "secret.txt").write_text(f"{SECRET}:x:0:0:root\n")
    return where


def _target(tmp_path, kind):
    path = tmp_path / f"{kind}.db"
    with SQLiteStore(path) as store:
        if kind == "filled":
            store.add_demonstration(_demo(7, n=30), [(0, 30)], label="mine")
    return path


def _guarded(call, folder, timeout=30.0):
    """``call()`` in a thread joined with a timeout, so an import that blocks (on a FIFO) fails the test."""
    out = {}

    def run():
        try:
            out["result"] = call()
        except BaseException as exc:  # noqa: BLE001 - handed to the test thread
            out["error"] = exc

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(timeout)
    if thread.is_alive():
        for fifo in folder.rglob("*"):  # unblock a reader waiting on a FIFO, then fail
            if fifo.is_fifo():
                os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        thread.join(5)
        pytest.fail(f"import of {folder} blocked for {timeout} s")
    if "error" in out:
        raise out["error"]
    return out["result"]


def _import(db, folder):
    def call():
        with SQLiteStore(db) as store:  # opened in the thread: a SQLite connection stays in its thread
            return store.import_folder(folder)
    return _guarded(call, folder)


def _version_file(folder, **changes):
    """Rewrite the version NPZ with some arrays changed."""
    path = folder / "versions" / "version_0001.npz"
    with np.load(path, allow_pickle=False) as archive:
        arrays = {k: archive[k] for k in archive.files}
    arrays.update(changes)
    np.savez(path, **arrays)


def _crafted_npy_zip(path, header_shape, n_bytes):
    """An NPZ whose ``t.npy`` header promises ``header_shape`` float64 values but holds ``n_bytes``."""
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": header_shape})
    buf.write(b"\x00" * n_bytes)
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("t.npy", buf.getvalue())


def _set(path, value):
    def mutate(doc, folder, outside):
        *parents, last = path
        node = doc
        for key in parents:
            node = node[key]
        node[last] = value(outside) if callable(value) else value
    return mutate


def _delete(path):
    def mutate(doc, folder, outside):
        *parents, last = path
        node = doc
        for key in parents:
            node = node[key]
        del node[last]
    return mutate


def _then(*steps):
    def mutate(doc, folder, outside):
        for step in steps:
            out = step(doc, folder, outside)
            if out is not None:
                return out
    return mutate


D0, P0, V0 = ("demonstrations", 0), ("demonstrations", 0, "primitives", 0), ("versions", 0)
DEEP = b"[" * 10_000 + b"]" * 10_000


def _symlink(target, name):
    def mutate(doc, folder, outside):
        os.symlink(target(folder, outside), folder / name)
    return mutate


def _fifo(name):
    def mutate(doc, folder, outside):
        os.mkfifo(folder / name)
    return mutate


def _write(name, data):
    def mutate(doc, folder, outside):
        (folder / name).unlink(missing_ok=True)
        (folder / name).write_bytes(data(outside) if callable(data) else data)
    return mutate


def _replace_manifest(make):
    def mutate(doc, folder, outside):
        (folder / "manifest.json").unlink()
        make(folder, outside)
    return mutate


def _raw(data):
    """Replace the manifest by raw bytes."""
    return lambda doc, folder, outside: data


def _too_large(doc, folder, outside):
    return json.dumps(doc).encode() + b" " * 200


PATHS = [
    ("dotdot npz", _set(D0 + ("file",), "../secret.npz"), r"demonstrations\[0\]\.file '\.\./secret\.npz': "
     r"expected a file inside the export folder, got a path that leads outside it"),
    ("dotdot text", _set(D0 + ("file",), "../secret.txt"), r"demonstrations\[0\]\.file '\.\./secret\.txt': "
     "expected a file inside"),
    ("dotdot deep", _set(D0 + ("file",), "demonstrations/../../secret.npz"), "leads outside"),
    ("absolute", _set(D0 + ("file",), lambda o: str(o / "secret.npz")),
     r"demonstrations\[0\]\.file '/.*: expected a file inside the export folder"),  # long paths are cut
    ("symlink to outside file", _then(_symlink(lambda f, o: o / "secret.npz", "demonstrations/link.npz"),
                                      _set(D0 + ("file",), "demonstrations/link.npz")),
     r"demonstrations\[0\]\.file 'demonstrations/link\.npz': expected a file inside the export folder"),
    ("symlink to outside folder", _then(_symlink(lambda f, o: o, "elsewhere"),
                                        _set(D0 + ("file",), "elsewhere/secret.npz")), "leads outside"),
    ("symlink to inside folder", _then(_symlink(lambda f, o: f / "demonstrations", "dirlink"),
                                       _set(D0 + ("file",), "dirlink")),
     r"demonstrations\[0\]\.file 'dirlink': expected a regular file, got a path through a symbolic link"),
    ("folder", _set(D0 + ("file",), "demonstrations"), "expected a regular file, got a folder"),
    ("export folder itself", _set(D0 + ("file",), "."), "expected a regular file, got a folder"),
    ("fifo", _then(_fifo("demonstrations/pipe.npz"), _set(D0 + ("file",), "demonstrations/pipe.npz")),
     r"demonstrations\[0\]\.file 'demonstrations/pipe\.npz': expected a regular file, got a FIFO"),
    ("version fifo", _then(_fifo("versions/pipe.npz"), _set(V0 + ("file",), "versions/pipe.npz")),
     r"versions\[0\]\.file 'versions/pipe\.npz': expected a regular file, got a FIFO"),
    ("version outside", _set(V0 + ("file",), "../secret.npz"), r"versions\[0\]\.file '\.\./secret\.npz'"),
    ("missing file", _set(D0 + ("file",), "demonstrations/none.npz"), "got a missing file"),
    ("symlink loop", _then(_symlink(lambda f, o: f / "loop", "loop"), _set(D0 + ("file",), "loop")),
     r"'loop': expected a"),
    ("text inside", _write("demonstrations/demo_000001.npz", lambda o: (o / "secret.txt").read_bytes()),
     r"demonstrations\[0\]\.file 'demonstrations/demo_000001\.npz': expected an NPZ archive, got a file "
     "that is not one"),
    ("zip of text", _write("demonstrations/demo_000001.npz",
                           lambda o: _zip_of({"notes.txt": SECRET.encode()})),
     "got a member that is not a .npy array"),
    ("corrupt zip", _write("demonstrations/demo_000001.npz", b"PK\x03\x04" + SECRET.encode() * 3),
     r"got one that cannot be read \(BadZipFile\)"),
    ("pickled array", _write("demonstrations/demo_000001.npz", lambda o: _npz_bytes(
        t=np.linspace(0, 1, 40), position=np.array([{"x": SECRET}] * 40, dtype=object))),
     r"an array of Python objects: not a numeric \.npy array \(never unpickled\)"),
    ("text stream", _write("demonstrations/demo_000001.npz", lambda o: _npz_bytes(
        t=np.linspace(0, 1, 40), position=np.array([SECRET] * 40))),
     "expected numeric arrays, got a text array"),
    ("header promises more", lambda doc, folder, outside: _crafted_npy_zip(
        folder / "demonstrations" / "demo_000001.npz", (10 ** 12,), 16),
     "an array header declaring 8000000000000 bytes of data, while its member holds 16$"),
    ("no t", _write("demonstrations/demo_000001.npz", lambda o: _npz_bytes(position=np.zeros((40, 2)))),
     "expected an array 't', got none"),
    ("t not increasing", _write("demonstrations/demo_000001.npz", lambda o: _npz_bytes(
        t=np.r_[0.0, 0.25, 0.25, 1.0], position=np.zeros((4, 2)))),
     r"expected a valid demonstration, got one failing t: expected strictly increasing time \(read it with"),
    ("metadata not an object", _write("demonstrations/demo_000001.npz", lambda o: _npz_bytes(
        t=np.linspace(0, 1, 40), position=np.zeros((40, 2)), metadata=np.array(f'["{SECRET}"]'))),
     r"demonstrations\[0\] metadata: expected an object, got an array of 1 item"),
    ("metadata nested deep", _write("demonstrations/demo_000001.npz", lambda o: _npz_bytes(
        t=np.linspace(0, 1, 40), position=np.zeros((40, 2)), metadata=np.array(DEEP.decode()))),
     "metadata: expected JSON nested at most 64 deep"),
    ("manifest symlink outside",
     _replace_manifest(lambda f, o: os.symlink(o / "secret.txt", f / "manifest.json")),
     r"^manifest\.json: expected a file inside the export folder"),
    ("manifest fifo", _replace_manifest(lambda f, o: os.mkfifo(f / "manifest.json")),
     r"^manifest\.json: expected a regular file, got a FIFO"),
]


def _zip_of(members):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return buf.getvalue()


def _npz_bytes(**arrays):
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


SCHEMA = [
    ("start is a string", _set(P0 + ("start",), "a"),
     r"demonstrations\[0\]\.primitives\[0\]\.start: expected an integer >= 0, got string 'a'"),
    ("start negative", _set(P0 + ("start",), -10), r"primitives\[0\]\.start: expected an integer >= 0, "
     "got integer -10"),
    ("start boolean", _set(P0 + ("start",), True), "start: expected an integer >= 0, got boolean True"),
    ("stop beyond the demonstration", _set(P0 + ("stop",), 10 ** 9),
     r"primitives\[0\]\.stop: expected an integer in 1\.\.40 \(demonstration 1 has 40 samples\), "
     "got integer 1000000000"),
    ("stop not after start", _set(P0 + ("stop",), 0), r"primitives\[0\]\.stop: expected an integer >= 1, "
     "got integer 0"),
    ("start a float", _set(P0 + ("start",), 1.5), "start: expected an integer >= 0, got number 1.5"),
    ("id too large for SQLite", _set(D0 + ("id",), 2 ** 63),
     r"demonstrations\[0\]\.id: expected an integer in 1\.\.9007199254740991, "
     "got integer 9223372036854775808"),
    # an id a store holds, but from which a later add could not number on (SQLite's overflow)
    ("id at SQLite's largest", _set(D0 + ("id",), 2 ** 63 - 1),
     r"demonstrations\[0\]\.id: expected an integer in 1\.\.9007199254740991, "
     "got integer 9223372036854775807"),
    ("primitive id past 2^53", _set(P0 + ("id",), 2 ** 53),
     r"primitives\[0\]\.id: expected an integer in 1\.\.9007199254740991, got integer 9007199254740992"),
    ("version past 2^53", _set(V0 + ("version",), 2 ** 53),
     r"versions\[0\]\.version: expected an integer in"),
    ("id a string", _set(D0 + ("id",), "1"),
     r"demonstrations\[0\]\.id: expected an integer >= 1, got string"),
    ("missing id", _delete(D0 + ("id",)), r"demonstrations\[0\]: expected a key 'id', got none"),
    ("missing file key", _delete(D0 + ("file",)), r"demonstrations\[0\]: expected a key 'file', got none"),
    ("missing stop", _delete(P0 + ("stop",)), r"primitives\[0\]: expected a key 'stop', got none"),
    ("file a number", _set(D0 + ("file",), 5), r"demonstrations\[0\]\.file: expected a relative file path"),
    ("file with NUL", _set(D0 + ("file",), "demo\x00.npz"), r"\.file: expected a relative file path"),
    ("label a number", _set(P0 + ("label",), 5),
     r"label: expected a non-empty string or null, got integer 5"),
    ("label blank", _set(P0 + ("label",), "  "), "label: expected a non-empty string or null"),
    ("source a list", _set(D0 + ("source",), [1]),
     r"source: expected a non-empty string or null, got an array"),
    ("provenance a string", _set(D0 + ("provenance",), "x"), r"provenance: expected an object, got string"),
    ("provenance without kind", _delete(D0 + ("provenance", "kind")), r"provenance: expected a key 'kind'"),
    ("primitives an object", _set(D0 + ("primitives",), {}), r"primitives: expected an array, got an object"),
    ("demonstrations an object", _set(("demonstrations",), {}), "demonstrations: expected an array, got an "
     "object"),
    ("demonstration a number", _set(D0, 5), r"demonstrations\[0\]: expected an object, got integer 5"),
    ("duplicate demonstration ids", _set(("demonstrations", 1, "id"), 1),
     r"demonstrations\[1\]: expected a unique id, got 1, which an earlier entry has too"),
    ("duplicate primitive ids", _set(("demonstrations", 1, "primitives", 0, "id"), 1),
     r"demonstrations\[1\]\.primitives\[0\]\.id: expected a primitive id unique in the manifest, got 1"),
    ("duplicate versions", lambda d, f, o: d["versions"].append(dict(d["versions"][0])) and None,
     r"versions\[1\]: expected a unique version"),
    ("version params a list", _set(V0 + ("params",), []), r"versions\[0\]\.params: expected an object"),
    ("version without n_points", _delete(V0 + ("params", "n_points")), "params: expected a key 'n_points'"),
    ("n_clusters a string", _set(V0 + ("n_clusters",), "2"), r"n_clusters: expected an integer in 1\.\."),
    ("n_clusters zero", _set(V0 + ("n_clusters",), 0), r"n_clusters: expected an integer in 1\.\."),
    ("label cluster out of range", _set(V0 + ("labels", 0, "cluster"), 2),
     r"versions\[0\]\.labels\[0\]\.cluster: expected an integer in 0\.\.1, got integer 2"),
    ("label clusters repeated", lambda d, f, o: d["versions"][0]["labels"].append(
        {"cluster": 0, "label": "again"}) and None, r"labels\[1\]: expected a unique cluster"),
    ("members name an unlisted primitive", lambda d, f, o: d["demonstrations"].pop() and None,
     r"versions\[0\]\.file 'versions/version_0001\.npz': expected member_ids to hold ids of primitives "
     r"stored with it, got 2 that do not \(first 5\)"),
    ("member cluster out of range", lambda d, f, o: _version_file(f, member_clusters=np.full(6, 2)),
     r"expected member_clusters to hold clusters in 0\.\.1, got 6 that do not \(first 2\)"),
    ("centers of another shape", lambda d, f, o: _version_file(f, centers=np.zeros((3, 2))),
     r"expected centers \(2, d\), pca_components \(d, f\) and pca_mean \(f,\)"),
    ("features of another width", lambda d, f, o: _version_file(f, member_features=np.zeros((6, 3))),
     r"expected member_features of shape \(6, 2\)"),
    ("non-finite centre", lambda d, f, o: _version_file(f, centers=np.array([[0, np.nan], [1, 1]])),
     "array 'centers': expected finite values"),
    ("unknown assignment", lambda d, f, o: _version_file(f, member_assigned=np.array(["fit"] * 5 + ["x"])),
     r"expected member_assigned to hold values in \['fit', 'incremental'\], got 1 that do not$"),
    ("member ids as text", lambda d, f, o: _version_file(f, member_ids=np.array(["1"] * 6)),
     r"expected 'member_ids' as integers of shape \(6,\)"),
    ("version array missing",
     _write("versions/version_0001.npz", lambda o: _npz_bytes(centers=np.zeros((2, 2)))),
     "got none named 'pca_mean'"),
    ("wrong format", _set(("format",), "other"), r"format: expected 'skillbank-library'"),
    ("schema version a string", _set(("schema_version",), "2"), "schema_version: expected an integer"),
    ("newer schema", _set(("schema_version",), 99), "exported by a newer skillbank"),
    ("top level a list", lambda d, f, o: b"[]", r"\(top level\): expected an object, got an array"),
    ("nested 10,000 deep", _raw(DEEP), "expected JSON nested at most 64 deep, got deeper nesting"),
    ("provenance nested 100 deep",
     _set(D0 + ("provenance", "params"), lambda o: json.loads("[" * 100 + "]" * 100)),
     "expected JSON nested at most 64 deep, got 10[0-9] levels"),
    ("provenance nested 10,000 deep", lambda d, f, o: json.dumps(d).replace(
        '"kind"', '"deep": ' + DEEP.decode() + ', "kind"', 1).encode(), "nested at most 64 deep"),
    ("NaN", lambda d, f, o: json.dumps(d).replace('"start": 0', '"start": NaN', 1).encode(),
     "expected valid JSON, got non-finite number NaN"),
    ("huge number", lambda d, f, o: json.dumps(d).replace('"start": 0', '"start": 1e999', 1).encode(),
     "expected valid JSON, got a number too large for a float"),
    ("not UTF-8", _raw(b'{"format": "\xff\xfe"}'), "expected UTF-8 JSON text"),
    ("not JSON", _raw(b"{format: 1"), r"expected valid JSON, got Expecting property name"),
    ("too large", _too_large, "expected at most 300 bytes, got a larger file"),
]


CASES = {name: (mutate, match) for name, mutate, match in PATHS + SCHEMA}
assert len(CASES) == len(PATHS) + len(SCHEMA)  # names are unique


def _prepare(exported, tmp_path, outside, mutate):
    folder = tmp_path / "hostile"
    shutil.copytree(exported, folder)
    doc = json.loads((folder / "manifest.json").read_text())
    raw = mutate(doc, folder, outside)
    if (folder / "manifest.json").is_symlink() or (folder / "manifest.json").is_fifo():
        return folder
    (folder / "manifest.json").write_bytes(raw if isinstance(raw, bytes) else json.dumps(doc).encode())
    return folder


@pytest.mark.parametrize("kind", ["empty", "filled"])
@pytest.mark.parametrize(("mutate", "match"), list(CASES.values()), ids=list(CASES))
def test_hostile_folder_is_refused_and_changes_nothing(exported, outside, tmp_path, monkeypatch, kind, mutate,
                                                       match, table_rows):
    monkeypatch.setattr(manifest_module, "MAX_MANIFEST_BYTES", 300 if mutate is _too_large else
                        manifest_module.MAX_MANIFEST_BYTES)
    db = _target(tmp_path, kind)
    before = table_rows(db)
    folder = _prepare(exported, tmp_path, outside, mutate)
    with pytest.raises(ValueError, match=match) as info:
        _import(db, folder)
    message = str(info.value)
    assert "\n" not in message and SECRET not in message and "TOPSECRET" not in message
    assert len(message) < 400, message
    assert table_rows(db) == before
    with SQLiteStore(db, create=False) as store:
        assert store.check() == "ok"


def test_the_untouched_export_imports(exported, tmp_path):
    """The hostile cases differ from this folder by one change each: it imports, as a copy then a merge."""
    db = _target(tmp_path, "empty")
    first = _import(db, exported)
    assert first["mode"] == "copy" and first["demonstrations"] == {1: 1, 2: 2, 3: 3}
    assert first["versions"] == {1: 1} and first["skipped"] == {}
    again = _import(db, exported)
    assert again == {"mode": "merge", "demonstrations": {}, "primitives": {}, "versions": {},
                     "skipped": {1: 1, 2: 2, 3: 3}, "descriptions": {}}


def test_a_symlink_even_to_a_file_inside_the_folder_is_refused(exported, tmp_path, table_rows):
    """An export made by skillbank holds no link: one is hand-made or hostile, so it is not followed."""
    folder = tmp_path / "linked"
    shutil.copytree(exported, folder)
    os.symlink(folder / "demonstrations" / "demo_000001.npz", folder / "alias.npz")
    doc = json.loads((folder / "manifest.json").read_text())
    doc["demonstrations"][0]["file"] = "alias.npz"
    (folder / "manifest.json").write_text(json.dumps(doc))
    db = _target(tmp_path, "empty")
    before = table_rows(db)
    with pytest.raises(ValueError, match=r"^manifest\.json demonstrations\[0\]\.file 'alias\.npz': "
                                         "expected a regular file, got a path through a symbolic link"):
        _import(db, folder)
    assert table_rows(db) == before


def test_a_fifo_is_refused_without_being_opened(exported, tmp_path, outside, monkeypatch):
    """The refusal comes from os.stat: opening the FIFO (which would block) is never tried."""
    opened = []
    real_open = os.open
    monkeypatch.setattr(os, "open",
                        lambda path, *a, **k: opened.append(str(path)) or real_open(path, *a, **k))
    folder = _prepare(exported, tmp_path, outside, CASES["fifo"][0])
    with pytest.raises(ValueError, match="got a FIFO"):
        _import(_target(tmp_path, "filled"), folder)
    assert any(p.endswith("manifest.json") for p in opened)  # the spy sees the opens that happen
    assert not any(p.endswith("pipe.npz") for p in opened)


@pytest.mark.parametrize(("case", "match"), [
    ("dotdot npz", "leads outside it"), ("fifo", "got a FIFO"), ("text inside", "that is not one"),
    ("start is a string", "start: expected an integer"), ("nested 10,000 deep", "nested at most 64 deep"),
])
def test_cli_exits_2_with_one_line(exported, outside, tmp_path, capsys, case, match, table_rows):
    mutate = CASES[case][0]
    db = _target(tmp_path, "filled")
    before = table_rows(db)
    folder = _prepare(exported, tmp_path, outside, mutate)
    capsys.readouterr()
    code = _guarded(lambda: _main.main(["library", "import", str(db), str(folder)]), folder)
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and err.count("\n") == 1 and match in err, err
    assert re.match(r"skillbank library( import)?: error: manifest\.json", err) and SECRET not in err
    assert table_rows(db) == before


# -- the validators on their own -------------------------------------------------------------------
_JSON = st.recursive(st.none() | st.booleans() | st.integers(-3, 2 ** 64) | st.floats(allow_nan=False,
                     allow_infinity=False) | st.text(max_size=5),
                     lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner,
                                                                                    max_size=4),
                     max_leaves=20)


def _valid_manifest():
    return {"format": "skillbank-library", "schema_version": 2, "demonstrations": [
        {"id": 1, "file": "d.npz", "source": None, "created": "now", "provenance": {"kind": "k", "params": {},
                                                                                  "created": "now"},
         "primitives": [{"id": 1, "start": 0, "stop": 5, "label": None}, {"id": 2, "start": 5, "stop": 9,
                                                                          "label": "x"}]}],
        "versions": [{"version": 1, "created": "now", "params": {"features": "default", "n_points": 16},
                      "n_clusters": 2, "file": "v.npz", "labels": [{"cluster": 1, "label": "reach"}]}]}


def _paths(node, prefix=()):
    yield prefix
    children = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, child in children:
        yield from _paths(child, (*prefix, key))


@settings(max_examples=150, deadline=None)
@given(doc=_JSON)
def test_check_manifest_on_any_json_raises_only_valueerror(doc):
    with pytest.raises(ValueError, match=r"^manifest\.json[ :]"):
        check_manifest(doc)


@settings(max_examples=300, deadline=None)
@given(data=st.data())
def test_check_manifest_with_one_value_replaced_accepts_or_names_the_entry(data):
    doc = _valid_manifest()
    path = data.draw(st.sampled_from(list(_paths(doc))[1:]))
    value = data.draw(_JSON)
    node = doc
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    try:
        out = check_manifest(doc)
    except ValueError as exc:
        assert str(exc).startswith(("manifest.json ", "manifest.json:")) and "\n" not in str(exc)
    else:  # what it accepts has the types the import relies on
        for d in out["demonstrations"]:
            assert isinstance(d["id"], int) and isinstance(d["file"], str)
            assert all(0 <= p["start"] < p["stop"] and isinstance(p["id"], int) for p in d["primitives"])
        for v in out["versions"]:
            assert all(0 <= c < v["n_clusters"] for c, _ in v["labels"])


def test_json_depth_and_content_hash_known_answers():
    assert json_depth([]) == 1 and json_depth({"a": {"b": [1]}}) == 3 and json_depth("x") == 0
    assert json_depth(json.loads("[" * 500 + "]" * 500)) == 500
    demo = Demonstration(np.array([0.0, 1.0]), {"p": np.array([[1.0], [2.0]])}, {"u": 1})
    import hashlib

    h = hashlib.sha256()
    for part in (b"t", b"<f8 (2,)", np.array([0.0, 1.0]).tobytes(), b"p", b"<f8 (2, 1)",
                 np.array([1.0, 2.0]).tobytes(), b'{"u": 1}'):
        h.update(len(part).to_bytes(8, "little") + part)
    assert content_hash(demo) == h.hexdigest()
    renamed = Demonstration(demo.t, {"q": demo["p"]}, {"u": 1})
    assert content_hash(renamed) != content_hash(demo)
