"""An add that reclusters refuses a demonstration of another dimension before it writes (issue 44).

The clustering after the add cannot mix 2-D and 3-D positions; the add used
to write the demonstrations first and fail in the recluster, leaving the
library half-added. Now the library is exactly as it was.
"""

from __future__ import annotations

import numpy as np
import pytest

from skillbank import Demonstration, Library


def _path(dims: int, k: int) -> Demonstration:
    t = np.linspace(0.0, 1.0, 60)
    cols = [t, (0.5 + 0.1 * k) * t, 0.2 + 0.1 * np.sin(np.pi * t)][:dims]
    return Demonstration.from_array(np.column_stack(cols), t)


def _csvs(folder, names):
    """CSV recordings written in ``folder`` by name: ``a`` and ``b`` 3-D paths, ``flat`` a 2-D one."""
    t = np.linspace(0.0, 1.0, 60)
    columns = {"a": [t, t, 0.2 * t], "flat": [t, t], "b": [t, 0.5 * t, 0.1 * t]}
    files = []
    for name in names:
        files.append(folder / f"{name}.csv")
        header = "t," + ",".join(f"position_{i}" for i in range(len(columns[name])))
        np.savetxt(files[-1], np.column_stack([t, *columns[name]]), delimiter=",", header=header,
                   comments="")
    return files


@pytest.mark.parametrize("how", ["add", "add_many", "add_files"])
def test_a_2d_demonstration_in_a_3d_library_leaves_it_unchanged(new_library, library_content, tmp_path, how):
    db = new_library()
    with Library(db) as lib:
        lib.add_many([_path(3, k) for k in range(3)], segment=False, assign="recluster")
    before = library_content(db)
    with Library(db) as lib:
        match = (r"^library: cannot cluster positions of different dimensions together: "
                 r"[34] primitive\(s\) are 3-D[^,]*, 1 are 2-D \(1 being added\); .*; nothing was added$")
        with pytest.raises(ValueError, match=match):
            if how == "add":
                lib.add(_path(2, 0), segment=False, assign="recluster")
            elif how == "add_many":  # a 3-D one with it is not added either
                lib.add_many([_path(3, 9), _path(2, 0)], segment=False, assign="recluster")
            else:
                csv = tmp_path / "flat.csv"
                t = np.linspace(0.0, 1.0, 60)
                np.savetxt(csv, np.c_[t, t, 0.5 * t], delimiter=",", header="t,position_0,position_1",
                           comments="")
                lib.add_files([csv], segment=False, assign="recluster")
    assert library_content(db) == before


def test_the_command_line_says_so_in_one_line_and_adds_nothing(cli, tmp_path, library_content):
    db = tmp_path / "lib.db"
    t = np.linspace(0.0, 1.0, 60)
    files = []
    for name, cols in [("a", [t, t, 0.2 * t]), ("b", [t, 0.5 * t, 0.3 * t]), ("flat", [t, t])]:
        files.append(tmp_path / f"{name}.csv")
        header = "t," + ",".join(f"position_{i}" for i in range(len(cols)))
        np.savetxt(files[-1], np.column_stack([t, *cols]), delimiter=",", header=header, comments="")
    assert cli("library", "init", db)[0] == 0
    assert cli("library", "add", db, *files[:2], "--whole", "--assign", "recluster")[0] == 0
    before = library_content(db)
    code, out, err = cli("library", "add", db, files[2], "--whole", "--assign", "recluster")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "2 primitive(s) are 3-D, 1 are 2-D (1 being added)" in err
    assert err.rstrip().endswith("nothing was added")
    assert library_content(db) == before


def test_a_library_already_mixed_is_named_by_ids():
    from skillbank.pipeline._adding import check_one_dimension

    class Stored:
        def __init__(self, pid, dims):
            self.id, self.demo = pid, _path(dims, pid)

    prims = [Stored(1, 3), Stored(2, 3), Stored(3, 2)]
    with pytest.raises(ValueError, match=r"2 primitive\(s\) are 3-D, 1 are 2-D \(ids 3\); remove"):
        check_one_dimension(prims)
    item = {"demo": _path(2, 7), "bounds": [(0, 30), (30, 60)]}
    with pytest.raises(ValueError, match=r": 3 primitive\(s\) are 2-D \(2 of them being added\), "
                                         r"2 are 3-D \(ids 1, 2\); remove"):
        check_one_dimension(prims, [item])
    check_one_dimension(prims[:2])  # one dimension: nothing to say


def test_a_recluster_of_one_primitive_adds_nothing_either(cli, tmp_path):
    db = tmp_path / "lib.db"
    t = np.linspace(0.0, 1.0, 60)
    csv = tmp_path / "one.csv"
    np.savetxt(csv, np.c_[t, t, 0.5 * t, 0.2 * t], delimiter=",", header="t,position_0,position_1,position_2",
               comments="")
    assert cli("library", "init", db)[0] == 0
    code, out, err = cli("library", "add", db, csv, "--whole", "--assign", "recluster")
    assert code == 2 and out == ""
    assert err.endswith("library: expected at least 2 primitives to cluster, got 1; nothing was added\n")
    with Library(db) as lib:
        assert lib.store.demonstration_ids() == []
        lib.add_many([_path(3, 0), _path(3, 1)], segment=False, assign="recluster")  # two can be
        assert len(lib.primitives()) == 2 and lib.clustering_params() is not None


def test_a_parallel_add_refuses_it_before_it_writes(tmp_path, library_content):
    pytest.importorskip("distributed")
    db = tmp_path / "lib.db"
    with Library(db) as lib:
        lib.add_many([_path(3, k) for k in range(3)], segment=False, assign="recluster")
    before = library_content(db)
    files = _csvs(tmp_path, ["a", "flat"])
    with Library(db) as lib, pytest.raises(ValueError, match=r"4 primitive\(s\) are 3-D \(1 of them being "
                                                             r"added\), 1 are 2-D \(1 being added\); .*; "
                                                             r"nothing was added$"):
        lib.add_files(files, workers=1, segment=False, assign="recluster")
    assert library_content(db) == before


def test_keep_going_sets_the_other_dimension_aside_and_adds_the_rest(tmp_path):
    db = tmp_path / "lib.db"
    with Library(db) as lib:
        lib.add_many([_path(3, k) for k in range(3)], segment=False, assign="recluster")
    files = _csvs(tmp_path, ["a", "flat", "b"])
    with Library(db) as lib:
        report = lib.add_files(files, segment=False, assign="recluster", keep_going=True)
        assert report["failed"] == {str(files[1]): "its positions are 2-D, the library's are 3-D: one "
                                                   "clustering cannot mix them"}
        assert len(report["demonstrations"]) == 2 and report["version"] == 2
        assert len(lib.primitives()) == 5


def test_a_parallel_keep_going_add_sets_it_aside_too(tmp_path):
    pytest.importorskip("distributed")
    db = tmp_path / "lib.db"
    with Library(db) as lib:
        lib.add_many([_path(3, k) for k in range(3)], segment=False, assign="recluster")
    files = _csvs(tmp_path, ["a", "flat", "b"])
    with Library(db) as lib:
        report = lib.add_files(files, workers=1, segment=False, assign="recluster", keep_going=True)
        assert report["failed"] == {str(files[1]): "its positions are 2-D, the library's are 3-D: one "
                                                   "clustering cannot mix them"}
        assert len(report["demonstrations"]) == 2 and report["version"] == 2
