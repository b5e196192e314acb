"""Benchmark of the library's web view on a large library: the first pages served, and the whole site written.

Run from the repository root (the extra ``view``)::

    .venv/bin/python benchmarks/bench_view.py [--demos 100] [--per-demo 100] [--samples 1000]
        [--repeats 5] [--json PATH]

A new SQLite library of ``--demos`` random-walk demonstrations of ``--samples`` samples (3-D
positions), each cut into ``--per-demo`` primitives, in one clustering of 4 skills (written through
the store, as ``tests/plotting/test_view.py`` does): 10^4 primitives by default. A
:class:`~skillbank.plotting._view_server.ViewServer` on it answers ``/`` (the index), the first and
the last page of skill 0 and one demonstration's page; each is timed ``--repeats`` times from the
request path to the bytes (rendering included, the socket not), and the median reported. Then the
whole static site is written once (``write_view``). No timing is asserted.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from skillbank import Demonstration
from skillbank.plotting._view import write_view
from skillbank.plotting._view_server import ViewServer
from skillbank.store import open_store


def build(path: Path, demos: int, per_demo: int, samples: int) -> int:
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 10.0, samples)
    width = samples // per_demo
    with open_store(path) as store:
        store.add_demonstrations([
            {"demo": Demonstration(t, {"position": np.cumsum(rng.normal(size=(samples, 3)), axis=0) * 0.01}),
             "bounds": [(width * k, width * (k + 1)) for k in range(per_demo)]} for _ in range(demos)])
        prims = store.primitives(load=False)
        clusters = np.arange(len(prims)) % 4
        X = rng.normal(size=(len(prims), 3)) + 10.0 * clusters[:, None]
        params = {"method": "ElasticClustering", "min_separation": 4.0, "features": "default"}
        centers = 10.0 * np.repeat(np.arange(4.0)[:, None], 3, axis=1)
        store.add_version(params=params, centers=centers, pca_mean=np.zeros(3), pca_components=np.eye(3),
                          labels={0: "zero"},
                          members=[(p.id, int(c), x) for p, c, x in zip(prims, clusters, X, strict=True)])
    return len(prims)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--demos", type=int, default=100)
    parser.add_argument("--per-demo", type=int, default=100)
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="bench_view."))
    path = folder / "large.db"
    n = build(path, args.demos, args.per_demo, args.samples)
    last = -(-(n // 4) // 100)
    rows = {}
    with ViewServer(lambda: open_store(path, readonly=True), log=None) as server:
        for name in ("/", "/skill-0.html", f"/skill-0-{last}.html", "/demonstration-1.html"):
            times = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                status, body, _ = server.respond(name)
                times.append(time.perf_counter() - start)
                assert status == 200, (name, status)  # noqa: S101 - a benchmark's own sanity check
            rows[name] = {"median_s": statistics.median(times), "max_s": max(times), "bytes": len(body)}
    start = time.perf_counter()
    with open_store(path, readonly=True) as store:
        done = write_view(store, folder / "view")
    rows["write_view"] = {"seconds": time.perf_counter() - start, "pages": done["pages"]}
    print(f"{n} primitives in {args.demos} demonstrations of {args.samples} samples, 4 skills")
    for name, r in rows.items():
        if "median_s" in r:
            print(f"  {name:28s} median {r['median_s']:.3f} s, max {r['max_s']:.3f} s, {r['bytes']} bytes")
    site = rows["write_view"]
    print(f"  whole site written: {site['pages']} pages in {site['seconds']:.2f} s")
    if args.json is not None:
        args.json.write_text(json.dumps({"primitives": n, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
