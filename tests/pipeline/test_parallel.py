"""Parallel adds on a real Dask cluster: the same library as without, workers that die, the missing extra.

The cluster is a ``distributed.LocalCluster`` of two single-threaded worker
processes, started once for these tests and closed at the end. Its scheduler
gives up on a task after one retry (``allowed-failures`` 1, default 3), so a
file that kills every worker it runs on costs two worker restarts, not four,
and gives a worker one task at a time (``worker-saturation`` 1.0, as the
local clusters of ``workers=N`` do), so a dying worker takes no other file
with it.
Dask is in the ``test`` extra: these tests run everywhere, they never skip.
"""

from __future__ import annotations

import json
import logging
import os
import sys
from pathlib import Path

import dask
import distributed
import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.cli import main
from skillbank.io import write_npz
from skillbank.pipeline import Library
from skillbank.pipeline._parallel import add_in_parallel


@pytest.fixture(scope="session")
def dask_cluster():
    with dask.config.set({"distributed.scheduler.allowed-failures": 1,
                          "distributed.scheduler.worker-saturation": 1.0}):
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                           dashboard_address=":0", silence_logs=logging.ERROR)
    try:
        yield cluster
    finally:
        cluster.close()


@pytest.fixture
def client(dask_cluster):
    with distributed.Client(dask_cluster, set_as_default=False) as c:
        yield c


def chain(k, n=200, dims=3):
    """Two reaches joined at rest (two primitives), the second straight or bowed (two skills)."""
    rng = np.random.default_rng(k)
    s = np.linspace(0.0, 1.0, n // 2)
    s = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5
    a = rng.uniform(-1, 1, dims)
    b = a + np.r_[rng.uniform(0.5, 1, 2) * rng.choice([-1, 1], 2), np.zeros(dims - 2)]
    c = b + np.r_[rng.uniform(0.5, 1, 2) * rng.choice([-1, 1], 2), np.zeros(dims - 2)]
    bow = np.zeros(dims)
    bow[-1] = 0.8 * (k % 2) * np.linalg.norm(c - b)
    Y = np.vstack([a + s[:, None] * (b - a), b + s[:, None] * (c - b) + np.sin(np.pi * s)[:, None] * bow])
    Y += 1e-6 * rng.standard_normal(Y.shape)
    return Demonstration(np.linspace(0.0, 2.0, n), {"position": Y}, {"k": k})


def write_files(folder: Path, count: int, *, first=0, bad=(), flat=()) -> list:
    """``count`` NPZ files of one demonstration each; ``bad``: unreadable CSVs; ``flat``: 2-D positions."""
    folder.mkdir(exist_ok=True)
    paths = []
    for k in range(first, first + count):
        path = folder / f"{k:03d}.npz"
        if k in bad:
            path = path.with_suffix(".csv")
            path.write_text("t,x\n0,1\n0,2\n")  # a repeated time stamp: cannot be read
        else:
            write_npz(chain(k, dims=2 if k in flat else 3), path)
        paths.append(path)
    return paths


def library(path, seed_files) -> Library:
    lib = Library(path)
    lib.add_files(seed_files, segmentation={"window": 16})
    lib.cluster(random_state=0)
    return lib


def content(lib: Library) -> dict:
    """Everything an add writes, without time stamps: ids, sources, provenance, bounds, clusters, features.

    The features are apart (``"features"``, by primitive id): they are compared to 1e-12, not bit for bit.
    """
    demos = lib.store.demonstration_ids()
    prims = lib.primitives(load=True)
    return {
        "demos": {did: (lib.demonstration(did).metadata, lib.provenance(did)) for did in demos},
        "primitives": [(p.id, p.demonstration_id, p.start, p.stop, p.cluster, p.label, p.features is None)
                       for p in prims],
        "sources": [p.demo.metadata.get("source") for p in prims],
        "features": {p.id: p.features for p in prims if p.features is not None},
    }


def same_features(have: dict, want: dict) -> bool:
    """The same primitives have features, equal to 1e-12.

    Not bit for bit: numpy's SIMD loops add in an order that depends on where an array starts in memory
    (16- or 32-byte aligned), which differs between the worker that featurised a primitive and this
    process, so the last bits of a feature may differ (seen once in about 40 runs of this test).
    """
    return have.keys() == want.keys() and all(
        np.allclose(have[k], want[k], rtol=1e-12, atol=1e-12) for k in want)


def check_clean(path, n_demos):
    with Library(path, readonly=True) as lib:
        assert lib.check() == "ok"
        assert len(lib.store.demonstration_ids()) == n_demos
        for did in lib.store.demonstration_ids():  # every demonstration whole, with all its primitives
            prims = lib.primitives(demonstration=did)
            assert prims and prims[0].start == 0 and prims[-1].stop == lib.demonstration(did).n_steps


# -- the same library as without workers -----------------------------------------------------------

@pytest.mark.parametrize("keep_going", [False, True])
def test_parallel_add_gives_the_library_a_sequential_add_gives(tmp_path, new_library, dask_cluster,
                                                               keep_going):
    seed = write_files(tmp_path / "seed", 6)
    bad = (13,) if keep_going else ()
    new = write_files(tmp_path / "new", 8, first=10, bad=bad, flat=(12,))
    options = {"segmentation": {"window": 16}, "keep_going": keep_going}
    with library(new_library("seq"), seed) as lib:
        expected = lib.add_files(new, **options)
        want = content(lib)
    with library(new_library("par"), seed) as lib:
        got = lib.add_files(new, scheduler=dask_cluster.scheduler_address, batch_size=3, **options)
        have = content(lib)
    assert got.pop("scheduler") == dask_cluster.scheduler_address
    assert got == expected  # ids, primitives, failed files, unclustered demonstrations
    assert same_features(have.pop("features"), want.pop("features"))
    assert have == want  # the same rows: bounds, provenance, clusters of every primitive
    assert len(expected["demonstrations"]) == 8 - len(bad)
    assert list(expected["unclustered"]) == [expected["demonstrations"][2]]  # the 2-D one
    assert list(expected["failed"]) == [str(p) for p in new if p.suffix == ".csv"]


def test_workers_start_a_local_cluster_and_recluster(tmp_path):
    files = write_files(tmp_path / "in", 4)
    with Library(tmp_path / "lib.db") as lib:
        report = lib.add_files(files, workers=1, segmentation={"window": 16}, assign="recluster")
        assert report["scheduler"].startswith("tcp://127.0.0.1:")
        assert report["demonstrations"] == [1, 2, 3, 4] and report["version"] == 1
        assert all(p.cluster is not None for p in lib.primitives())


def test_all_or_nothing_with_workers_adds_nothing_when_a_file_is_bad(tmp_path, new_library, dask_cluster):
    db = new_library()
    files = write_files(tmp_path / "in", 6, bad=(4,))
    with Library(db) as lib:
        with pytest.raises(ValueError, match=r"004\.csv: cannot read it: .*; nothing was added"):
            lib.add_files(files, scheduler=dask_cluster.scheduler_address)
    check_clean(db, 0)


def test_progress_covers_the_whole_batch(tmp_path, new_library, dask_cluster, capsys):
    db = new_library()
    files = write_files(tmp_path / "in", 5)
    with Library(db) as lib:
        lib.add_files(files, scheduler=dask_cluster.scheduler_address, progress=True, keep_going=True,
                      batch_size=2)
    err = capsys.readouterr().err
    assert "adding: 100%" in err and "5/5" in err and "4 demonstration(s) written" in err


# -- workers that die ------------------------------------------------------------------------------

def plant(client, poison: str, mode: str, marker=None):
    """Make every worker (and every restarted one) misbehave on the file named ``poison``.

    ``once``: the first worker to read it dies (``os._exit``); ``always``:
    every worker that reads it dies; ``raise``: reading it raises a
    RuntimeError (a bug, not a bad file). Defined here, so it travels to
    the workers by value.
    """

    class Poison(distributed.WorkerPlugin):
        name = "poison"

        def setup(self, worker):
            # Warm, as a worker that has prepared a file is: _parallel imports scipy and scikit-learn only
            # when a task first cuts or assigns, and a cold worker's first task would lag the other's by
            # that second (the tests here are about what is retried and committed, not about start-up).
            import skillbank.clustering  # noqa: F401
            import skillbank.pipeline._parallel as parallel
            import skillbank.segmentation  # noqa: F401
            import skillbank.selection  # noqa: F401

            original = parallel.read_file

            def read_file(path, **kwargs):
                if Path(path).name == poison:
                    if mode == "raise":
                        raise RuntimeError("planted bug")
                    if mode == "always" or not os.path.exists(marker):
                        if marker is not None:
                            Path(marker).touch()
                        os._exit(1)
                return original(path, **kwargs)

            self.original, parallel.read_file = original, read_file

        def teardown(self, worker):
            import skillbank.pipeline._parallel as parallel

            parallel.read_file = self.original

    client.register_plugin(Poison())
    return "poison"


@pytest.fixture
def planted(client):
    names = []
    yield lambda *args, **kwargs: names.append(plant(client, *args, **kwargs))
    for name in names:
        client.unregister_worker_plugin(name)
    client.wait_for_workers(2, timeout=60)  # the killed ones are back for the next test


def test_a_worker_that_dies_once_is_retried_and_nothing_is_lost(tmp_path, new_library,
        dask_cluster, planted):
    db = new_library()
    files = write_files(tmp_path / "in", 6)
    planted("003.npz", "once", marker=str(tmp_path / "died"))
    with Library(db) as lib:
        report = lib.add_files(files, scheduler=dask_cluster.scheduler_address, keep_going=True, batch_size=2,
                               segmentation={"window": 16})
    assert (tmp_path / "died").exists()  # a worker did die on it
    assert report["failed"] == {} and report["demonstrations"] == [1, 2, 3, 4, 5, 6]
    check_clean(db, 6)


def test_a_file_that_kills_every_worker_is_reported_and_the_rest_committed(tmp_path, dask_cluster, planted):
    db = tmp_path / "lib.db"  # the scheduler's retries, the same on any store
    files = write_files(tmp_path / "in", 6)
    planted("003.npz", "always")
    with Library(db) as lib:
        report = lib.add_files(files, scheduler=dask_cluster.scheduler_address, keep_going=True, batch_size=2,
                               segmentation={"window": 16})
    assert list(report["failed"]) == [str(files[3])]
    assert "worker preparing it died" in report["failed"][str(files[3])]
    assert report["demonstrations"] == [1, 2, 3, 4, 5]  # in the order of the files, none lost
    check_clean(db, 5)
    with Library(db, readonly=True) as lib:
        sources = [lib.demonstration(d).metadata["source"] for d in lib.store.demonstration_ids()]
    assert sources == [str(files[k]) for k in (0, 1, 2, 4, 5)]


def test_a_task_of_several_files_that_kills_workers_is_retried_file_by_file(tmp_path, dask_cluster, planted):
    db = tmp_path / "lib.db"  # the scheduler's retries, the same on any store
    files = write_files(tmp_path / "in", 6)
    planted("004.npz", "always")
    with Library(db) as lib:
        # tasks of files {0, 1, 2} and {3, 4, 5}: the second dies, then 3 and 5 alone succeed
        report = add_in_parallel(lib, files, read={}, options={"segment": False, "segmentation": None,
                                                               "label": None, "assign": "none"},
                                 keep_going=True, progress=False, scheduler=dask_cluster.scheduler_address,
                                 chunk=3)
    assert list(report["failed"]) == [str(files[4])]
    assert report["demonstrations"] == [1, 2, 3, 4, 5]
    check_clean(db, 5)


def test_all_or_nothing_adds_nothing_when_workers_die(tmp_path, dask_cluster, planted):
    db = tmp_path / "lib.db"  # the scheduler's retries, the same on any store
    files = write_files(tmp_path / "in", 4)
    planted("002.npz", "always")
    with Library(db) as lib:
        with pytest.raises(ValueError, match=r"002\.npz: the Dask worker preparing it died.*nothing was add"):
            lib.add_files(files, scheduler=dask_cluster.scheduler_address)
    check_clean(db, 0)


def test_an_add_stopped_midway_keeps_its_committed_batches_whole(tmp_path, new_library,
        dask_cluster, planted):
    db = new_library()
    files = write_files(tmp_path / "in", 8)
    planted("005.npz", "raise")
    with Library(db) as lib:
        with pytest.raises(RuntimeError, match="planted bug"):
            lib.add_files(files, scheduler=dask_cluster.scheduler_address, keep_going=True, batch_size=2)
    # batches {0, 1} and {2, 3} were committed; file 4 waited for its batch, which never came
    check_clean(db, 4)


# -- the command line ------------------------------------------------------------------------------

def test_scheduler_variable_is_honoured(tmp_path, new_library, dask_cluster, client, monkeypatch, capsys):
    db = new_library()
    files = [str(p) for p in write_files(tmp_path / "in", 3)]
    Library(db).close()
    monkeypatch.setenv("SKILLBANK_SCHEDULER", dask_cluster.scheduler_address)
    with distributed.get_task_stream(client=client) as ran:
        assert main(["library", "add", str(db), *files, "--window", "16", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["scheduler"] == dask_cluster.scheduler_address and report["demonstrations"] == [1, 2, 3]
    assert sum(str(task["key"]).startswith("prepare_file") for task in ran.data) == 3  # one per file, there
    # --workers 0 adds in this process, whatever the variable says
    assert main(["library", "add", str(db), *files, "--workers", "0", "--json"]) == 0
    assert "scheduler" not in json.loads(capsys.readouterr().out)


def test_unreachable_scheduler_is_one_line(tmp_path, new_library, monkeypatch, capsys):
    db = new_library()
    files = [str(p) for p in write_files(tmp_path / "in", 1)]
    Library(db).close()
    monkeypatch.setenv("SKILLBANK_SCHEDULER", "tcp://127.0.0.1:9")  # discard port: nothing listens
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        assert main(["library", "add", str(db), *files]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "scheduler: cannot reach the Dask scheduler at 'tcp://127.0.0.1:9'" in err
    check_clean(db, 0)


def test_missing_extra_is_one_line(tmp_path, monkeypatch, capsys):
    files = [str(p) for p in write_files(tmp_path / "in", 1)]
    Library(tmp_path / "lib.db").close()
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if Dask were not installed
    assert main(["library", "add", str(tmp_path / "lib.db"), *files, "--workers", "2"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("skillbank library add: error: parallel adds (workers, scheduler) need Dask: "
                   "pip install 'skillbank[dask]'")
    with Library(tmp_path / "lib.db") as lib, \
            pytest.raises(ImportError, match=r"need Dask: pip install 'skillbank\[dask\]'"):
        lib.add_files(files, scheduler="tcp://127.0.0.1:8786")
    check_clean(tmp_path / "lib.db", 0)


def test_bad_parallel_options(tmp_path, capsys):
    add = ["library", "add", str(tmp_path / "lib.db"), *map(str, write_files(tmp_path / "in", 1))]
    Library(tmp_path / "lib.db").close()
    with pytest.raises(SystemExit, match="2"):
        main([*add, "--workers", "-1"])
    assert "argument --workers: expected an integer >= 0, got '-1'" in capsys.readouterr().err
    assert main([*add, "--workers", "0", "--scheduler", "tcp://h:1"]) == 2
    assert capsys.readouterr().err == ("skillbank library add: error: workers: --workers 0 works in this "
                                       "process, --scheduler on a cluster: give one, got --workers 0 and "
                                       "--scheduler 'tcp://h:1'\n")
    assert main([*add, "--workers", "2", "--scheduler", "tcp://h:1"]) == 2
    assert "workers: give workers (a new local cluster) or scheduler" in capsys.readouterr().err


def test_bad_parallel_arguments(tmp_path):
    files = write_files(tmp_path / "in", 1)
    with Library(tmp_path / "lib.db") as lib:
        with pytest.raises(ValueError, match=r"workers: expected an integer > 0, got 0"):
            lib.add_files(files, workers=0)
        with pytest.raises(ValueError, match=r"batch_size: expected an integer > 0, got 0"):
            lib.add_files(files, workers=1, batch_size=0)
        with pytest.raises(ValueError, match=r"workers: give workers \(a new local cluster\) or scheduler"):
            lib.add_files(files, workers=1, scheduler="tcp://h:1")
