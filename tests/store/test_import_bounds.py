"""``library import``: links refused, decompressed bytes bounded before reading, ids and parameters in range.

Every refusal goes through the CLI: exit status 2, one line on stderr naming
what is wrong and what to do, and the library exactly as it was (a new one
not even created). The memory bound is checked in a child process limited to
1 GiB of address space, on an export of 7 MB whose arrays take 1.5 GiB.
"""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import zipfile

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.io import write_npz
from skillbank.store import SQLiteStore, open_store
from skillbank.store._manifest import MAX_IMPORT_BYTES, max_import_bytes
from skillbank.store._rows import MAX_ID, MAX_N_POINTS

SECRET = "TOPSECRET-bounds-do-not-print"


def _demo(k, n=40):
    t = np.linspace(0.0, 1.0, n)
    return Demonstration(t, {"position": np.column_stack([t, k * t ** 2, 0.1 * t])}, {"k": k})


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """An export of 3 demonstrations (2 primitives each) and one clustering version."""
    root = tmp_path_factory.mktemp("bounds")
    with SQLiteStore(root / "src.db") as store:
        pids = [p for k in range(3) for p in store.add_demonstration(_demo(k), [(0, 20), (20, 40)])[1]]
        rng = np.random.default_rng(1)
        store.add_version(params={"features": "default", "n_points": 16, "stretch": 1.2, "random_state": 0},
                          centers=rng.normal(size=(2, 2)), pca_mean=rng.normal(size=4),
                          pca_components=rng.normal(size=(2, 4)),
                          members=[(p, k % 2, rng.normal(size=2)) for k, p in enumerate(pids)])
        store.export(root / "export")
    return root / "export"


@pytest.fixture
def folder(exported, tmp_path):
    """A fresh copy of the export to change (no file in it has a second name)."""
    out = tmp_path / "export"
    shutil.copytree(exported, out)
    return out


def _manifest(folder, change):
    doc = json.loads((folder / "manifest.json").read_text())
    change(doc)
    (folder / "manifest.json").write_text(json.dumps(doc))


def _refused(cli, library_content, location, folder, match, *extra, filled=True):
    """``library import`` of ``folder`` into ``location``: exit 2, one line matching ``match``, no change."""
    if filled:
        with open_store(location) as store:
            store.add_demonstration(_demo(9, n=30), [(0, 30)])
        before = library_content(location)
    code, out, err = cli("library", "import", location, folder, *extra)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert err.startswith("skillbank library import: error: ") and SECRET not in err, err
    assert re.search(match, err), err
    if filled:
        assert library_content(location) == before
    elif not str(location).startswith("postgresql://"):
        assert not os.path.exists(location)  # a failed import leaves no new library behind
    return err


def _declared(folder) -> int:
    """What the export's arrays take decompressed, read from each archive's directory (the known answer)."""
    total = 0
    for path in sorted(folder.rglob("*.npz")):
        with zipfile.ZipFile(path) as zf:
            total += sum(i.file_size for i in zf.infolist())
    return total


# -- links -------------------------------------------------------------------------------------------
def test_a_hard_link_to_an_outside_file_is_refused(cli, new_library, library_content, folder, tmp_path):
    outside = tmp_path / "outside.npz"  # same file system as the folder, so a hard link can be made
    write_npz(Demonstration(np.linspace(0, 1, 40), {"position": np.zeros((40, 3))}, {"secret": SECRET}),
              outside)
    target = folder / "demonstrations" / "demo_000002.npz"
    target.unlink()
    os.link(outside, target)
    err = _refused(cli, library_content, new_library(), folder,
                   r"manifest\.json demonstrations\[1\]\.file 'demonstrations/demo_000002\.npz': expected a "
                   r"file of its own, got one with 2 hard links .*copy the folder with 'cp -r' to import "
                   r"it\)$")
    assert "outside.npz" not in err


def test_a_hard_link_between_two_names_inside_the_folder_is_refused(cli, library_content, folder, tmp_path):
    os.link(folder / "versions" / "version_0001.npz", tmp_path / "second-name.npz")
    _refused(cli, library_content, tmp_path / "lib.db", folder,
             r"versions\[0\]\.file 'versions/version_0001\.npz': expected a file of its own, got one with 2 "
             "hard links", filled=False)


def test_a_hard_linked_manifest_is_refused(cli, library_content, folder, tmp_path):
    os.link(folder / "manifest.json", tmp_path / "manifest-copy.json")
    _refused(cli, library_content, tmp_path / "lib.db", folder,
             r"error: manifest\.json: expected a file of its own, got one with 2 hard links", filled=False)


def test_a_symlinked_folder_inside_is_refused(cli, library_content, folder, tmp_path):
    (folder / "demonstrations").rename(folder / "real")
    os.symlink(folder / "real", folder / "demonstrations")
    _refused(cli, library_content, tmp_path / "lib.db", folder,
             r"demonstrations\[0\]\.file 'demonstrations/demo_000001\.npz': expected a regular file, got a "
             "path through a symbolic link", filled=False)


def test_a_copied_folder_imports(cli, folder, tmp_path):
    """What the hard-link message says to do works: a copy (cp -r) has files of their own."""
    os.link(folder / "manifest.json", tmp_path / "second-name.json")
    copy = tmp_path / "copied"
    shutil.copytree(folder, copy)
    code, out, err = cli("library", "import", tmp_path / "lib.db", copy, "--json")
    assert code == 0, err
    assert json.loads(out)["added"] == {"demonstrations": 3, "primitives": 6, "versions": 1}


def test_one_file_named_by_two_entries_is_refused(cli, new_library, library_content, folder):
    _manifest(folder, lambda d: d["demonstrations"][2].update(file=d["demonstrations"][0]["file"]))
    _refused(cli, library_content, new_library(), folder,
             r"demonstrations\[2\]\.file 'demonstrations/demo_000001\.npz': expected a file no other entry "
             r"names \(an export writes one per demonstration and version\), got the file of "
             r"demonstrations\[0\]\.file")


# -- the bound on decompressed bytes ----------------------------------------------------------------------
def test_the_bound_is_the_export_total_exactly(cli, library_content, folder, tmp_path, monkeypatch):
    total = _declared(folder)
    assert 0 < total < 20_000
    err = _refused(cli, library_content, tmp_path / "a.db", folder,
                   rf"folder: expected an export whose arrays take at most {total - 1} bytes once "
                   r"decompressed \(the import's bound\), got at least \d+ by versions\[0\]\.file; .*raise "
                   "the bound with --max-bytes .* or SKILLBANK_MAX_IMPORT_BYTES$", "--max-bytes", total - 1,
                   filled=False)
    assert f"got at least {total} by" in err  # the version file is the last one measured
    code, out, err = cli("library", "import", tmp_path / "b.db", folder, "--max-bytes", total, "--json")
    assert code == 0 and json.loads(out)["added"]["demonstrations"] == 3, err
    monkeypatch.setenv("SKILLBANK_MAX_IMPORT_BYTES", str(total - 1))
    _refused(cli, library_content, tmp_path / "c.db", folder, rf"at most {total - 1} bytes", filled=False)
    monkeypatch.setenv("SKILLBANK_MAX_IMPORT_BYTES", f"{total:.6e}")  # 1.2345e4 notation is taken too
    assert max_import_bytes() == float(f"{total:.6e}")


@pytest.mark.parametrize(("value", "match"), [
    ("0", r"max_bytes: expected a whole number of bytes >= 1 \(e\.g\. 4e9\), got 0\.0"),
    ("-5", "max_bytes: expected a whole number of bytes >= 1"),
    ("1.5", "got 1.5"),
    ("inf", "got inf"),
])
def test_a_bad_max_bytes_is_one_line(cli, folder, tmp_path, value, match):
    code, out, err = cli("library", "import", tmp_path / "lib.db", folder, "--max-bytes", value)
    assert code == 2 and err.count("\n") == 1 and re.search(match, err), err
    assert not (tmp_path / "lib.db").exists()


def test_the_default_bound_and_the_environment(monkeypatch):
    monkeypatch.delenv("SKILLBANK_MAX_IMPORT_BYTES", raising=False)
    assert max_import_bytes() == MAX_IMPORT_BYTES == 2 ** 30
    monkeypatch.setenv("SKILLBANK_MAX_IMPORT_BYTES", "8e9")
    assert max_import_bytes() == 8 * 10 ** 9 and max_import_bytes(100) == 100
    monkeypatch.setenv("SKILLBANK_MAX_IMPORT_BYTES", "lots")
    with pytest.raises(ValueError, match=r"^SKILLBANK_MAX_IMPORT_BYTES: expected a whole number of bytes "
                                         r">= 1 \(e\.g\. 4e9\), got 'lots'$"):
        max_import_bytes()


def _bomb(path, rows):
    """An NPZ holding ``rows`` x 3 float64 zeros, written as it is compressed (never all in memory)."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (rows, 3)})
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as zf, \
            zf.open("position.npy", "w", force_zip64=True) as fh:
        fh.write(header.getvalue())
        chunk, left = bytes(1 << 24), rows * 3 * 8
        while left:
            fh.write(chunk[:min(left, len(chunk))])
            left -= min(left, len(chunk))


@pytest.fixture(scope="module")
def bomb(exported, tmp_path_factory):
    """An export of 7 MB whose first demonstration's arrays take 1.5 GiB once decompressed."""
    folder = tmp_path_factory.mktemp("bomb") / "export"
    shutil.copytree(exported, folder)
    _bomb(folder / "demonstrations" / "demo_000001.npz", 2 ** 26)
    assert os.path.getsize(folder / "demonstrations" / "demo_000001.npz") < 10 * 2 ** 20
    return folder


def test_a_small_export_of_huge_arrays_is_refused_within_a_1_gib_limit(limited, bomb, tmp_path):
    db = tmp_path / "lib.db"
    code, out, err = limited("library", "import", db, bomb, memory=1 << 30, timeout=120)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert (f"expected an export whose arrays take at most {2 ** 30} bytes once decompressed (the import's "
            f"bound), got at least {2 ** 26 * 24 + 128} by demonstrations[0].file") in err, err
    assert not db.exists()


def test_a_header_declaring_a_terabyte_is_refused_within_a_1_gib_limit(limited, folder, tmp_path):
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False,
                                                  "shape": (10 ** 11,)})
    with zipfile.ZipFile(folder / "demonstrations" / "demo_000002.npz", "w") as zf:
        zf.writestr("t.npy", header.getvalue() + bytes(64))
    code, out, err = limited("library", "import", tmp_path / "lib.db", folder, "--max-bytes", "1e15",
                             memory=1 << 30, timeout=120)
    assert code == 2 and err.count("\n") == 1, err
    assert ("demonstrations[1].file 'demonstrations/demo_000002.npz': expected an NPZ archive of numeric "
            "arrays, got an array header declaring 800000000000 bytes of data, while its member holds 64"
            ) in err, err


# -- ids and parameters in range ------------------------------------------------------------------------
@pytest.mark.parametrize(("change", "match"), [
    (lambda d: d["demonstrations"][0].update(id=2 ** 63 - 1),
     r"demonstrations\[0\]\.id: expected an integer in 1\.\.9007199254740991, "
     "got integer 9223372036854775807"),
    (lambda d: d["demonstrations"][1]["primitives"][0].update(id=MAX_ID + 1),
     r"demonstrations\[1\]\.primitives\[0\]\.id: expected an integer in 1\.\.9007199254740991"),
    (lambda d: d["versions"][0]["params"].update(n_points=10 ** 12),
     r"versions\[0\]\.params\.n_points: expected an integer in 2\.\.10000 \(the store's MAX_N_POINTS\), "
     "got 1000000000000$"),
    (lambda d: d["versions"][0]["params"].update(n_points=MAX_N_POINTS + 1), "got 10001$"),
    (lambda d: d["versions"][0]["params"].update(n_points=1), "n_points: expected an integer in 2..10000"),
    (lambda d: d["versions"][0]["params"].update(features="velocity"),
     r"versions\[0\]\.params\.features: expected one of \['default', 'position'\], got 'velocity'$"),
    (lambda d: d["versions"][0]["params"].update(stretch=-1.0),
     r"params\.stretch: expected a finite number > 0, got -1\.0$"),
    (lambda d: d["versions"][0]["params"].update(random_state=-1),
     r"params\.random_state: expected null or an integer in 0\.\.4294967295, got -1$"),
    (lambda d: d["versions"][0]["params"].update(n_components=0),
     r"params\.n_components: expected a positive"),
    (lambda d: d["versions"][0].update(version=2 ** 53),
     r"versions\[0\]\.version: expected an integer in 1\.\."),
])
def test_ids_and_parameters_out_of_range_are_refused(cli, new_library, library_content, folder, change,
                                                     match):
    _manifest(folder, change)
    _refused(cli, library_content, new_library(), folder, match)


def test_the_largest_id_imports_and_a_later_add_numbers_on_from_it(cli, new_library, folder, tmp_path):
    """At 2^53 - 1 a store still holds the id and the next add gets 2^53 (at 2^63 - 1 SQLite overflowed)."""
    def change(doc):
        doc["demonstrations"][2]["id"] = MAX_ID
        doc["demonstrations"][2]["primitives"][1]["id"] = MAX_ID
        for v in doc["versions"]:  # the member that was primitive 6 is now MAX_ID
            path = folder / v["file"]
            with np.load(path, allow_pickle=False) as archive:
                arrays = {k: archive[k] for k in archive.files}
            arrays["member_ids"] = np.where(arrays["member_ids"] == 6, MAX_ID, arrays["member_ids"])
            path.unlink()
            np.savez(path, **arrays)

    _manifest(folder, change)
    location = new_library()
    code, out, err = cli("library", "import", location, folder, "--json")
    assert code == 0 and json.loads(out)["demonstrations"]["9007199254740991"] == MAX_ID, err
    write_npz(_demo(5, n=50), tmp_path / "more.npz")
    code, out, err = cli("library", "add", location, tmp_path / "more.npz", "--whole", "--json")
    assert code == 0, err
    report = json.loads(out)
    assert report["demonstrations"] == [MAX_ID + 1] and report["primitives"] == [[MAX_ID + 1]]


def test_cluster_refuses_what_a_copy_or_an_import_would(tmp_path):
    """A library clustered by skillbank can always be copied, exported and imported: n_points is bounded."""
    from skillbank.pipeline import Library  # the pipeline, for this one test of what it records

    with Library(tmp_path / "lib.db") as lib:
        with pytest.raises(ValueError, match=r"^n_points: expected an integer in 2\.\.10000, got 10001$"):
            lib.cluster(n_points=MAX_N_POINTS + 1)


# -- one demonstration at a time ------------------------------------------------------------------------
def test_a_file_changed_between_the_check_and_the_write_is_refused(folder, tmp_path, table_rows):
    """The import reads each demonstration again inside its transaction: it must be the very file checked."""
    from skillbank.store._manifest import read_export
    from skillbank.store._transfer import import_records

    doc = read_export(folder)
    assert all("demo" not in d and d["n_steps"] == 40 for d in doc["demonstrations"])  # none held in memory
    write_npz(_demo(7), folder / "demonstrations" / "demo_000002.npz")  # another valid demonstration
    with SQLiteStore(tmp_path / "lib.db") as store:
        store.add_demonstration(_demo(9, n=30), [(0, 30)])
        before = table_rows(tmp_path / "lib.db")
        with pytest.raises(ValueError, match=r"^manifest\.json demonstrations\[1\]\.file 'demonstrations/"
                                             r"demo_000002\.npz': expected a file that stays put, got one "
                                             "changed while being imported$"):
            import_records(store.records(), doc)
    assert table_rows(tmp_path / "lib.db") == before
