"""Batches: all-or-nothing by default, keep_going file by file; primitives that are left unclustered."""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.io import write_csv
from skillbank.pipeline import Library

from ._processes import writer_process


def _wave(n=200, k=1.0):
    t = np.linspace(0.0, 1.0, n)
    return Demonstration.from_array(np.column_stack([np.sin(3 * k * t), np.cos(2 * t), t]), t)


@pytest.fixture
def files(tmp_path):
    """The reported batch: three good CSV files and, third of four, one too short to segment."""
    paths = []
    for name, n, k in [("good", 200, 1.0), ("g0", 200, 1.5), ("four_rows", 4, 1.0), ("g1", 200, 2.0)]:
        paths.append(write_csv(_wave(n, k), tmp_path / f"{name}.csv"))
    return paths


@pytest.fixture
def counts(table_count):
    """``counts(lib)``: rows of the tables a batch writes, on either backend."""
    return lambda lib: {table: table_count(lib, table)
                        for table in ("demonstrations", "streams", "primitives", "provenance")}


def test_a_bad_file_adds_nothing_and_is_named(new_library, files, counts):
    with Library(new_library()) as lib:
        before = counts(lib)
        for _ in range(2):  # running it again neither adds nor duplicates anything
            with pytest.raises(ValueError, match=r"four_rows\.csv: .*expected at least 16 samples.*"
                                                 r"nothing was added") as info:
                lib.add_files(files)
            assert "\n" not in str(info.value)
            assert counts(lib) == before


def test_keep_going_adds_every_good_file_and_lists_each_bad_one(tmp_path, new_library, files):
    junk = tmp_path / "junk.csv"
    junk.write_text("t,x\n0,1\n1,oops\n")
    missing = tmp_path / "missing.csv"
    with Library(new_library()) as lib:
        report = lib.add_files([*files, junk, missing], keep_going=True)
        good = [files[0], files[1], files[3]]
        assert list(report["failed"]) == [str(files[2]), str(junk), str(missing)]
        assert "expected at least 16 samples" in report["failed"][str(files[2])]
        assert report["failed"][str(junk)] == \
            "cannot read it: line 3, column 2: expected a number, found 'oops'"
        assert report["failed"][str(missing)] == "cannot read it: no such file"
        assert report["demonstrations"] == lib.demonstration_ids() == [1, 2, 3]
        assert [lib.demonstration(i).metadata["source"] for i in report["demonstrations"]] == \
            [str(p) for p in good]
        assert report["primitives"] == [[p.id for p in lib.primitives(demonstration=i, load=False)]
                                         for i in report["demonstrations"]]
        assert report["unclustered"] == {}


def test_add_many_writes_the_batch_in_one_transaction(new_library, counts):
    with Library(new_library()) as lib:
        lib.add(_wave(), segment=False)
        before = counts(lib)
        batch = [_wave(k=1.1), _wave(k=1.2), _wave(k=1.3)]
        batch[2].metadata["handle"] = object()  # fails to serialise inside the write, after the first two
        with pytest.raises(TypeError, match="cannot convert object to JSON"):
            lib.add_many(batch, segment=False)
        assert counts(lib) == before
        too_short = _wave(n=4)
        with pytest.raises(ValueError, match=r"demos\[1\] \(source 'short'\): .*expected at least 16 "
                                             r"samples.*nothing was added"):
            lib.add_many([_wave(), Demonstration(too_short.t, too_short.streams, {"source": "short"})])
        assert counts(lib) == before
        assert lib.add_many(batch[:2], segment=False) == [2, 3]


def _kill_before_recluster(path, demos):
    def killed(self, **kwargs):  # the process dies where the recluster would start
        os.kill(os.getpid(), signal.SIGKILL)

    Library.cluster = killed
    with Library(path) as lib:
        lib.add_many(demos, segment=False, assign="recluster")


def test_primitives_left_by_an_interrupted_recluster_are_listed_and_clustered(new_library, make_skills):
    path = new_library("kill")
    demos = make_skills()
    with Library(path) as lib:
        lib.add_many(demos[:4] + demos[6:10], segment=False)
        first = lib.cluster()
        assert lib.summary()["unassigned"] == {"count": 0, "ids": []}
    proc = writer_process(_kill_before_recluster, (path, demos[4:6] + demos[10:]))
    proc.start()
    proc.join(60)
    assert proc.exitcode == -signal.SIGKILL
    with Library(path) as lib:
        assert lib.check() == "ok" and lib.store.current_version() == first
        doc = lib.summary()
        assert doc["unassigned"] == {"count": 4, "ids": [9, 10, 11, 12]}
        assert [p["cluster"] is None for p in doc["primitives"]] == [False] * 8 + [True] * 4
        version = lib.cluster()
        assert version == first + 1 and lib.summary()["unassigned"] == {"count": 0, "ids": []}
        assert set(lib.store.members(version)) == set(range(1, 13))
        assert sum(s["count"] for s in lib.summary()["skills"]) == 12


def test_a_primitive_that_cannot_join_is_reported_and_recorded(tmp_path, new_library, make_skills):
    with Library(new_library()) as lib:
        lib.add_many(make_skills(), segment=False)
        version = lib.cluster()
        t = np.linspace(0.0, 1.0, 60)
        flat = Demonstration.from_array(np.column_stack([t, t ** 2]), t)
        reason = rf"2 dimension\(s\), clustering version {version} was fitted on 3-D positions"
        warning = rf"demonstration 13: 1 primitive\(s\) left unclustered: .*{reason}"
        with pytest.warns(UserWarning, match=warning):
            [did] = lib.add_many([flat], segment=False)
        assert lib.primitives(demonstration=did)[0].cluster is None
        assert lib.provenance(did)["assignment"] == {
            "version": version, "clustered": False,
            "reason": f"its positions have 2 dimension(s), clustering version {version} was fitted on 3-D "
                      "positions"}
        assert lib.summary()["unassigned"] == {"count": 1, "ids": [13]}
        report = lib.add_files([write_csv(flat, tmp_path / "flat.csv")], segment=False)
        assert list(report["unclustered"]) == [14] and "fitted on 3-D" in report["unclustered"][14]
        # a primitive that does join records nothing extra
        [ok] = lib.add_many([make_skills()[0]], segment=False)
        assert "assignment" not in lib.provenance(ok)
        with pytest.raises(ValueError, match=r"cannot cluster positions of different dimensions together: 13 "
                                             r"primitive\(s\) are 3-D, 2 are 2-D \(ids 13, 14\)"):
            lib.cluster()
