"""Benchmark of scaling beyond one process: the store's write rate, adds on Dask, incremental clustering.

Run from the repository root (PostgreSQL needs the extra ``postgres``, Dask
the extra ``dask``; the server is started here with ``pgserver``, from the
``test`` extra)::

    .venv/bin/python benchmarks/bench_scale.py store [--demos 2000] [--samples 1000]
        [--batch 50] [--writers 1 2 4] [--json PATH]
    .venv/bin/python benchmarks/bench_scale.py ingest [--demos 2000] [--samples 1000]
        [--batch 50] [--dask-workers 1 2] [--backends sqlite postgresql] [--json PATH]
    .venv/bin/python benchmarks/bench_scale.py cluster [--points 1000000] [--batch-points 10000]
        [--json PATH]

``store``: ``--demos`` synthetic demonstrations of ``--samples`` samples and
4 streams (position, velocity, force: 3 columns each; gripper: 1), 5
primitives each, written with ``Store.add_demonstrations`` in batches of
``--batch`` (one transaction each) by ``--writers`` processes at once into one
new library: a SQLite file (WAL) and a PostgreSQL database on this machine
(pgserver's PostgreSQL 16, over its Unix socket, default settings: fsync on).
Each writer builds its demonstrations first, waits for a common start, then
writes; the time is from the start to the last writer's end. Throughput is
demonstrations (and megabytes of samples) per second; a single writer with
``--batch 1`` shows the cost of one transaction per demonstration. Segmenting
and featurising are not timed: this is the store alone. No timing is asserted.

``ingest``: ``--demos`` NPZ files of one synthetic demonstration each
(``--samples`` samples, the same 4 streams, five moves with rests, gripper
switches and contact steps, so the segmenter has real work), added with
``Library.add_files(keep_going=True)`` to a new library on each backend: in
the calling process (one transaction at the end), then on a new
``LocalCluster`` of each of ``--dask-workers`` worker processes
(``workers=N``; transactions of ``--batch`` demonstrations), each case in a
fresh child process, timed from the call to its return (so the local
cluster's start and stop are included; they are also timed alone). Peak
memory: the resident set of the child (the client) and of the child with its
worker processes, sampled every 0.1 s. ``write s`` is the time spent in the
store's transactions.

``cluster``: ``--points`` points of 6 Gaussian blobs in 3-D (the library
clusters 3 PCA components; unit standard deviation, centres at least 8
apart), in random order and sorted by blob (skills arriving one after
another): ``ElasticClustering().fit`` on all of them against ``partial_fit``
in batches of ``--batch-points``; time, peak traced memory (tracemalloc,
numpy's allocations included; a separate run from the timed one), the
model's state, clusters found and the adjusted Rand index (ARI) of the
incremental model's ``predict`` against the full refit and against the
blobs, and of the clusters points were given on arrival. Then the LASA
features (26 shapes, 7 demonstrations each, ``trajectory_features``) in
random order, 10 orders, in batches of 26 and 91: clusters found and ARI
against the full refit, the time of a stream (mean over the orders) and its
peak traced memory (the first order), for ``criterion="hierarchy"`` (what
``skillbank cluster`` runs) and ``"auto"`` (what ``Library.cluster`` runs).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

_WRITER = textwrap.dedent("""
    import json, sys, time
    import numpy as np
    from skillbank import Demonstration
    from skillbank.store import open_store

    url, first, count, samples, batch, start = sys.argv[1:7]
    first, count, samples, batch, start = int(first), int(count), int(samples), int(batch), float(start)
    rng = np.random.default_rng(first)
    t = np.linspace(0.0, samples / 100.0, samples)
    cuts = np.linspace(0, samples, 6).astype(int)
    bounds = [(int(a), int(b)) for a, b in zip(cuts[:-1], cuts[1:])]
    items = [{"demo": Demonstration(t, {"position": rng.normal(size=(samples, 3)),
                                        "velocity": rng.normal(size=(samples, 3)),
                                        "force": rng.normal(size=(samples, 3)),
                                        "gripper": rng.uniform(size=samples)}, {"k": first + k}),
              "bounds": bounds, "source": f"demo{first + k}.h5"} for k in range(count)]
    with open_store(url) as store:
        while time.time() < start:
            time.sleep(0.001)
        for i in range(0, count, batch):
            store.add_demonstrations(items[i:i + batch])
    print(json.dumps({"end": time.time()}))
""")


def _write(url: str, demos: int, samples: int, batch: int, writers: int) -> float:
    """Seconds for ``writers`` processes to write ``demos`` demonstrations into the library at ``url``."""
    share = [demos // writers + (k < demos % writers) for k in range(writers)]
    firsts = [sum(share[:k]) for k in range(writers)]
    start = time.time() + 2.0 + 0.6 * writers  # after every writer has built its demonstrations
    procs = [subprocess.Popen([sys.executable, "-c", _WRITER, url, str(f), str(n), str(samples), str(batch),
                               str(start)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for f, n in zip(firsts, share, strict=True)]
    outs = [p.communicate() for p in procs]
    if any(p.returncode for p in procs):
        raise RuntimeError("a writer failed: " + " | ".join(err[-500:] for _, err in outs if err))
    if time.time() < start:
        raise RuntimeError("writers finished before the start")
    return max(json.loads(out)["end"] for out, _ in outs) - start


@contextlib.contextmanager
def _postgres(tmp: str):
    """pgserver's PostgreSQL 16 in ``tmp``, stopped and deleted at the end."""
    import pgserver  # the test extra's embedded PostgreSQL

    server = pgserver.get_server(Path(tmp) / "pgdata", cleanup_mode="delete")
    try:
        yield server
    finally:
        server.cleanup()


def _pg_version(server) -> str:
    return server.psql("SHOW server_version;").split("\n")[2].strip()


def bench_store(args) -> list:
    import psycopg  # the postgres extra

    from skillbank.store import open_store

    rows = []
    mb = args.demos * args.samples * (1 + 3 + 3 + 3 + 1) * 8 / 1e6  # t and the 4 streams, float64
    with tempfile.TemporaryDirectory(prefix="bench-scale-") as tmp, _postgres(tmp) as server:
        if True:
            cases = [(1, 1)] + [(args.batch, w) for w in args.writers]
            for n, (batch, writers) in enumerate(cases):
                name = f"bench{n}"
                server.psql(f"CREATE DATABASE {name};")
                targets = {"sqlite": str(Path(tmp) / f"{name}.db"), "postgresql": server.get_uri(name)}
                for backend, url in targets.items():
                    open_store(url).close()  # created before the clock starts
                    seconds = _write(url, args.demos, args.samples, batch, writers)
                    with open_store(url, readonly=True) as store:
                        assert len(store.demonstration_ids()) == args.demos  # every row is there
                    row = {"backend": backend, "batch": batch, "writers": writers, "seconds": seconds,
                           "demos_per_s": args.demos / seconds, "mb_per_s": mb / seconds}
                    rows.append(row)
                    print(f"{backend:10s} batch {batch:3d} writers {writers}: {seconds:7.2f} s, "
                          f"{row['demos_per_s']:7.0f} demos/s, {row['mb_per_s']:6.1f} MB/s", flush=True)
                    Path(targets["sqlite"]).unlink(missing_ok=True)
                server.psql(f"DROP DATABASE {name};")
            version = _pg_version(server)
    print(f"PostgreSQL {version}, psycopg {psycopg.__version__}, {args.demos} demonstrations of "
          f"{args.samples} samples ({mb:.0f} MB), {platform.processor() or platform.machine()}")
    return rows


# -- ingest: parallel adds on Dask -------------------------------------------------------------------

def synthetic(k: int, samples: int):
    """Five moves with rests in between; the gripper switches and the force steps at every other rest."""
    import numpy as np

    from skillbank import Demonstration

    rng = np.random.default_rng(k)
    t = np.linspace(0.0, samples / 100.0, samples)
    edges = np.linspace(0, samples, 6).astype(int)
    pos, grip = np.zeros((samples, 3)), np.zeros(samples)
    force = 0.05 * rng.standard_normal((samples, 3))
    p = rng.uniform(-0.5, 0.5, 3)
    for m in range(5):
        a, b = edges[m], edges[m + 1]
        move = int(0.7 * (b - a))
        s = np.linspace(0.0, 1.0, move)
        s = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5
        q = p + rng.uniform(-0.3, 0.3, 3)
        pos[a:a + move], pos[a + move:b], p = p + s[:, None] * (q - p), q, q
        grip[a + move:b] = m % 2
        force[a + move:b, 2] += 5.0 * (m % 2)
    pos += 1e-4 * rng.standard_normal(pos.shape)
    return Demonstration(t, {"position": pos, "velocity": np.gradient(pos, t, axis=0), "force": force,
                             "gripper": grip[:, None]}, {"k": k})


_ADD = textwrap.dedent("""
    import json, sys, time
    from skillbank.pipeline import Library

    url, listing, workers, batch = sys.argv[1:5]
    paths = open(listing).read().split()
    workers = int(workers)
    with Library(url) as lib:
        spent = []
        write = lib.store.add_demonstrations

        def timed(items):
            start = time.perf_counter()
            out = write(items)
            spent.append(time.perf_counter() - start)
            return out

        lib.store.add_demonstrations = timed
        start = time.perf_counter()
        options = {} if workers == 0 else {"workers": workers, "batch_size": int(batch)}
        report = lib.add_files(paths, keep_going=True, **options)
        seconds = time.perf_counter() - start
        n = len(lib.store.demonstration_ids())
        n_prims = len(lib.store.primitives(load=False))
    print(json.dumps({"seconds": seconds, "write_s": sum(spent), "transactions": len(spent), "demos": n,
                      "primitives": n_prims, "failed": len(report["failed"])}))
""")

_START = textwrap.dedent("""
    import json, sys, time, logging
    import dask.config, distributed
    start = time.perf_counter()
    with dask.config.set({"distributed.scheduler.worker-saturation": 1.0}):
        cluster = distributed.LocalCluster(n_workers=int(sys.argv[1]), threads_per_worker=1, processes=True,
                                           dashboard_address=":0", silence_logs=logging.ERROR)
    with cluster, distributed.Client(cluster, set_as_default=False) as client:
        client.submit(sum, [1]).result()
        up = time.perf_counter() - start
    print(json.dumps({"start_s": up, "total_s": time.perf_counter() - start}))
""")


def _watch(cmd) -> dict:
    """Run ``cmd``: its JSON output, with the peak resident memory of it and of it with its descendants."""
    import threading

    import psutil  # installed with distributed

    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    peak = {"client": 0, "all": 0}
    stop = threading.Event()

    def sample():
        me = psutil.Process(proc.pid)
        while not stop.is_set():
            try:
                own = me.memory_info().rss
                rest = 0
                for child in me.children(recursive=True):
                    with contextlib.suppress(psutil.Error):
                        rest += child.memory_info().rss
            except psutil.Error:
                break
            peak["client"], peak["all"] = max(peak["client"], own), max(peak["all"], own + rest)
            stop.wait(0.1)

    watcher = threading.Thread(target=sample, daemon=True)
    watcher.start()
    out, err = proc.communicate()
    stop.set()
    watcher.join()
    if proc.returncode:
        raise RuntimeError(f"{cmd[3:]} failed: {err[-2000:]}")
    return {**json.loads(out.strip().splitlines()[-1]), "peak_client_mb": peak["client"] / 1e6,
            "peak_all_mb": peak["all"] / 1e6}


def bench_ingest(args) -> list:
    from skillbank.io import write_npz

    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-ingest-") as tmp:
        folder = Path(tmp) / "demos"
        folder.mkdir()
        start = time.perf_counter()
        paths = [str(write_npz(synthetic(k, args.samples), folder / f"{k:06d}.npz"))
                 for k in range(args.demos)]
        listing = Path(tmp) / "files.txt"
        listing.write_text("\n".join(paths))
        print(f"wrote {args.demos} files in {time.perf_counter() - start:.1f} s", flush=True)
        for n in args.dask_workers:
            up = _watch([sys.executable, "-c", _START, str(n)])
            print(f"LocalCluster of {n} worker(s): {up['start_s']:.2f} s to start, {up['total_s']:.2f} s "
                  f"with its close", flush=True)
        contexts = contextlib.ExitStack()
        with contexts:
            server = contexts.enter_context(_postgres(tmp)) if "postgresql" in args.backends else None
            for backend in args.backends:
                base = None
                for workers in [0, *args.dask_workers]:
                    name = f"ingest_{backend}_{workers}"
                    if backend == "postgresql":
                        server.psql(f"CREATE DATABASE {name};")
                        url = server.get_uri(name)
                    else:
                        url = str(Path(tmp) / f"{name}.db")
                    row = _watch([sys.executable, "-c", _ADD, url, str(listing), str(workers),
                                  str(args.batch)])
                    assert row["demos"] == args.demos and row["failed"] == 0  # every demonstration is there
                    base = row["seconds"] if workers == 0 else base
                    one = next((r["seconds"] for r in rows if r["backend"] == backend and r["workers"] == 1),
                               None)
                    row.update(backend=backend, workers=workers, demos_per_s=args.demos / row["seconds"],
                               ms_per_demo=1e3 * row["seconds"] / args.demos, speedup=base / row["seconds"],
                               speedup_vs_1=None if one is None else one / row["seconds"])
                    rows.append(row)
                    print(f"{backend:10s} workers {workers} ({'in process' if workers == 0 else 'Dask'}): "
                          f"{row['seconds']:7.1f} s, {row['demos_per_s']:6.1f} demos/s, "
                          f"x{row['speedup']:.2f} of in-process, write {row['write_s']:5.1f} s in "
                          f"{row['transactions']} transaction(s), peak {row['peak_client_mb']:6.0f} MB "
                          f"client, {row['peak_all_mb']:6.0f} MB all", flush=True)
                    if backend == "postgresql":
                        server.psql(f"DROP DATABASE {name};")
                    else:
                        Path(url).unlink(missing_ok=True)
            version = _pg_version(server) if server is not None else None
    import distributed  # the dask extra

    server_text = "" if version is None else f", PostgreSQL {version}"
    cores = len(os.sched_getaffinity(0))
    print(f"{args.demos} demonstrations of {args.samples} samples, 4 streams; dask {distributed.__version__}"
          f"{server_text}; {platform.processor() or platform.machine()}, {cores} cores")
    return rows


# -- cluster: incremental clustering against a full refit --------------------------------------------

def _blobs(n: int, seed: int = 0):
    import numpy as np

    rng = np.random.default_rng(seed)
    while True:  # 6 centres in [-15, 15]^3, at least 8 apart
        centres = rng.uniform(-15.0, 15.0, size=(6, 3))
        gaps = np.linalg.norm(centres[:, None] - centres[None, :], axis=2)[np.triu_indices(6, 1)]
        if gaps.min() >= 8.0:
            break
    truth = rng.integers(0, 6, n)
    return centres[truth] + rng.normal(size=(n, 3)), truth


def _traced(fn):
    """``(result, seconds, peak traced MB)``: timed alone, then run again under tracemalloc."""
    import tracemalloc

    start = time.perf_counter()
    out = fn()
    seconds = time.perf_counter() - start
    tracemalloc.start()
    fn()
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    return out, seconds, peak


def _state_mb(model) -> float:
    total = 0
    for name, value in vars(model).items():
        parts = value if isinstance(value, list) else [value]
        for part in parts:
            for array in (part if isinstance(part, tuple) else [part]):
                total += 0 if name == "labels_" else getattr(array, "nbytes", 0)
    return total / 1e6


def _stream(X, batch: int, seen):
    """``partial_fit`` on ``X`` in batches; the cluster each point was given on arrival goes to ``seen``."""
    from skillbank.clustering import ElasticClustering

    model = ElasticClustering(random_state=0)
    for i in range(0, X.shape[0], batch):
        seen[i:i + batch] = model.partial_fit(X[i:i + batch]).labels_
    return model


def bench_cluster(args) -> dict:
    import numpy as np
    from sklearn.metrics import adjusted_rand_score

    from skillbank.clustering import ElasticClustering

    X, truth = _blobs(args.points)
    out = {"blobs": [], "lasa": []}
    for order in ("random", "sorted"):
        if order == "sorted":
            idx = np.argsort(truth, kind="stable")
            X, truth = X[idx], truth[idx]
        full, t_full, m_full = _traced(lambda data=X: ElasticClustering(random_state=0).fit(data))
        seen = np.empty(X.shape[0], dtype=np.intp)  # allocated before the traced runs
        inc, t_inc, m_inc = _traced(lambda data=X, out=seen: _stream(data, args.batch_points, out))
        predicted = inc.predict(X)
        row = {"order": order, "points": int(X.shape[0]), "batch": args.batch_points,
               "full_s": t_full, "full_peak_mb": m_full, "full_k": int(full.n_clusters_),
               "inc_s": t_inc, "inc_peak_mb": m_inc, "inc_k": int(inc.n_clusters_),
               "inc_state_mb": _state_mb(inc),
               "data_mb": X.nbytes / 1e6,
               "ari_inc_full": adjusted_rand_score(full.labels_, predicted),
               "ari_full_truth": adjusted_rand_score(truth, full.labels_),
               "ari_inc_truth": adjusted_rand_score(truth, predicted),
               "ari_arrival_truth": adjusted_rand_score(truth, seen)}
        out["blobs"].append(row)
        print(f"{order:6s} {row['points']} points: full {t_full:6.2f} s {m_full:7.1f} MB k={row['full_k']}; "
              f"incremental (batches of {args.batch_points}) {t_inc:6.2f} s {m_inc:6.1f} MB (state "
              f"{row['inc_state_mb']:.2f} MB) k={row['inc_k']}; ARI inc/full {row['ari_inc_full']:.4f}, "
              f"inc/truth {row['ari_inc_truth']:.4f}, full/truth {row['ari_full_truth']:.4f}, "
              f"on arrival/truth {row['ari_arrival_truth']:.4f}", flush=True)
    out["lasa"] = _lasa(args)
    return out


def _lasa(args) -> list:
    import numpy as np
    from sklearn.metrics import adjusted_rand_score

    from skillbank.clustering import ElasticClustering, trajectory_features
    from skillbank.io import lasa_shapes, load_lasa

    shapes = [s for s in lasa_shapes() if not s.lower().startswith("multi_models")]
    demos, truth = [], []
    for k, shape in enumerate(shapes):
        some = load_lasa(shape)
        demos += some
        truth += [k] * len(some)
    F, truth = trajectory_features(demos), np.asarray(truth)
    rows = []
    for criterion in ("hierarchy", "auto"):
        start = time.perf_counter()
        full = ElasticClustering(criterion=criterion, random_state=0).fit(F)
        t_full = time.perf_counter() - start
        for batch in (26, 91):
            ks, aris, truths, seconds = [], [], [], []
            for seed in range(10):
                order = np.random.default_rng(seed).permutation(F.shape[0])

                def stream(order=order, criterion=criterion, batch=batch):
                    model = ElasticClustering(criterion=criterion, random_state=0)
                    for i in range(0, F.shape[0], batch):
                        model.partial_fit(F[order[i:i + batch]])
                    return model

                if seed == 0:  # the first order also under tracemalloc, for the peak
                    model, t_inc, peak = _traced(stream)
                else:
                    start = time.perf_counter()
                    model = stream()
                    t_inc = time.perf_counter() - start
                seconds.append(t_inc)
                ks.append(model.n_clusters_)
                aris.append(adjusted_rand_score(full.labels_, model.predict(F)))
                truths.append(adjusted_rand_score(truth, model.predict(F)))
            row = {"criterion": criterion, "batch": batch, "full_k": int(full.n_clusters_),
                   "full_ari_truth": adjusted_rand_score(truth, full.labels_), "inc_k": ks,
                   "ari_inc_full_mean": float(np.mean(aris)), "ari_inc_full_min": float(np.min(aris)),
                   "ari_inc_truth_mean": float(np.mean(truths)), "full_s": t_full,
                   "inc_s_mean": float(np.mean(seconds)), "inc_peak_mb": peak}
            rows.append(row)
            print(f"LASA {F.shape[0]} x {F.shape[1]} {criterion:9s} batch {batch:3d}: full k={row['full_k']} "
                  f"(ARI/truth {row['full_ari_truth']:.3f}); incremental k {min(ks)}-{max(ks)}, ARI inc/full "
                  f"mean {row['ari_inc_full_mean']:.3f} min {row['ari_inc_full_min']:.3f}, inc/truth mean "
                  f"{row['ari_inc_truth_mean']:.3f}; full {t_full:.2f} s, stream {row['inc_s_mean']:.2f} s "
                  f"(mean), {peak:.1f} MB", flush=True)
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("part", choices=["store", "ingest", "cluster"], help="what to measure")
    parser.add_argument("--demos", type=int, default=2000)
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument("--batch", type=int, default=50, help="demonstrations per transaction")
    parser.add_argument("--writers", type=int, nargs="+", default=[1, 2, 4])
    parser.add_argument("--dask-workers", type=int, nargs="+", default=[1, 2],
                        help="ingest: sizes of the local Dask clusters")
    parser.add_argument("--backends", nargs="+", choices=["sqlite", "postgresql"],
                        default=["sqlite", "postgresql"])
    parser.add_argument("--points", type=int, default=1_000_000, help="cluster: points")
    parser.add_argument("--batch-points", type=int, default=10_000, help="cluster: points per partial_fit")
    parser.add_argument("--json", type=Path, default=None, help="write the rows here")
    args = parser.parse_args(argv)
    rows = {"store": bench_store, "ingest": bench_ingest, "cluster": bench_cluster}[args.part](args)
    if args.json is not None:
        options = {k: v for k, v in vars(args).items() if k != "json"}
        args.json.write_text(json.dumps({"args": options, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
