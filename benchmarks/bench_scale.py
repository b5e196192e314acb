"""Benchmark of scaling beyond one process: the store's write rate, SQLite against PostgreSQL.

Run from the repository root (PostgreSQL needs the extra ``postgres``; the
server is started here with ``pgserver``, from the ``test`` extra)::

    .venv/bin/python benchmarks/bench_scale.py store [--demos 2000] [--samples 1000]
        [--batch 50] [--writers 1 2 4] [--json PATH]

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
"""

from __future__ import annotations

import argparse
import json
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


def bench_store(args) -> list:
    import pgserver  # the test extra's embedded PostgreSQL
    import psycopg  # the postgres extra

    from skillbank.store import open_store

    rows = []
    mb = args.demos * args.samples * (1 + 3 + 3 + 3 + 1) * 8 / 1e6  # t and the 4 streams, float64
    with tempfile.TemporaryDirectory(prefix="bench-scale-") as tmp:
        server = pgserver.get_server(Path(tmp) / "pgdata", cleanup_mode="delete")
        try:
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
            version = server.psql("SHOW server_version;").split("\n")[2].strip()
        finally:
            server.cleanup()
    print(f"PostgreSQL {version}, psycopg {psycopg.__version__}, {args.demos} demonstrations of "
          f"{args.samples} samples ({mb:.0f} MB), {platform.processor() or platform.machine()}")
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("part", choices=["store"], help="what to measure")
    parser.add_argument("--demos", type=int, default=2000)
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument("--batch", type=int, default=50, help="demonstrations per transaction")
    parser.add_argument("--writers", type=int, nargs="+", default=[1, 2, 4])
    parser.add_argument("--json", type=Path, default=None, help="write the rows here")
    args = parser.parse_args(argv)
    rows = bench_store(args)
    if args.json is not None:
        options = {k: v for k, v in vars(args).items() if k != "json"}
        args.json.write_text(json.dumps({"args": options, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
