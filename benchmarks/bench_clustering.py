"""Benchmark of skillbank's elastic clustering against scikit-learn's KMeans given the true k.

Run from the repository root::

    .venv/bin/python benchmarks/bench_clustering.py [--quick] [--json PATH]

Cases
-----
blobs-N
    N = 150, 1,500, 15,000, 150,000 points of K = 4 Gaussian blobs in 3-D
    (unit standard deviation, centres drawn once in [-10, 10]^3 at least 8
    apart, equal weights). ``ElasticClustering()`` with its defaults
    (``criterion="auto"``) must find K by itself; ``KMeans(n_clusters=K,
    n_init=1)`` is told K. The table gives both times, their ratio and the
    adjusted Rand index of both against the generating labels.
paper-N
    The authors' algorithm (``criterion="paper"``, stretch 0.4) on the same
    blobs at 150 and 1,500 points, to show how its number of clusters drifts
    with N (the authors' own code takes 0.13 s and 5.1 s there).

Every figure is the best of several repeats (``time.perf_counter``), all in
the same run. BLAS and OpenMP are limited to ``--threads`` threads (default 1)
for both sides: on a small shared machine, idle worker threads spinning make
multi-threaded timings swing by 5x. No timing is asserted anywhere.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from pathlib import Path

import numpy as np
import sklearn
from sklearn.cluster import KMeans
from sklearn.metrics import adjusted_rand_score
from threadpoolctl import threadpool_limits

from skillbank.clustering import ElasticClustering

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of  # noqa: E402

K = 4
SIZES = (150, 1_500, 15_000, 150_000)
PAPER_SIZES = (150, 1_500)
TARGET_S = 5.0  # the target at 150,000 points


def centres(seed: int = 0) -> np.ndarray:
    """K centres in [-10, 10]^3, redrawn until every pair is at least 8 apart."""
    rng = np.random.default_rng(seed)
    while True:
        c = rng.uniform(-10.0, 10.0, size=(K, 3))
        gaps = np.linalg.norm(c[:, None] - c[None, :], axis=2)[np.triu_indices(K, 1)]
        if gaps.min() >= 8.0:
            return c


def blobs(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed + 1)
    labels = rng.integers(0, K, n)
    return centres(seed)[labels] + rng.normal(size=(n, 3)), labels




def run(quick: bool, threads: int = 1) -> dict:
    rows = []
    ElasticClustering(random_state=0).fit(blobs(300)[0])  # warm-up (imports, BLAS)
    for n in SIZES:
        X, truth = blobs(n)
        repeats = (2 if quick else 5) if n < 100_000 else (1 if quick else 3)
        el_s, el = best_of(lambda X=X: ElasticClustering(random_state=0).fit(X), repeats)
        km_s, km = best_of(lambda X=X: KMeans(n_clusters=K, n_init=1, random_state=0).fit(X), repeats)
        rows.append({
            "case": "blobs", "n_samples": n, "k_true": K, "k_found": el.n_clusters_,
            "skillbank_s": el_s, "kmeans_s": km_s, "ratio": el_s / km_s,
            "ari_skillbank": adjusted_rand_score(truth, el.labels_),
            "ari_kmeans": adjusted_rand_score(truth, km.labels_),
            "tried": el.n_clusters_tried_.tolist(),
        })
    for n in PAPER_SIZES:
        X, truth = blobs(n)
        model = ElasticClustering(criterion="paper", stretch=0.4, random_state=0)
        s, fitted = best_of(lambda X=X, m=model: m.fit(X), 1 if quick else 3)
        rows.append({"case": "paper", "n_samples": n, "k_true": K, "k_found": fitted.n_clusters_,
                     "skillbank_s": s, "kmeans_s": None, "ratio": None,
                     "ari_skillbank": adjusted_rand_score(truth, fitted.labels_), "ari_kmeans": None,
                     "tried": fitted.n_clusters_tried_.tolist()})
    machine = {"python": platform.python_version(), "numpy": np.__version__, "sklearn": sklearn.__version__,
               "cpus": os.cpu_count(), "platform": platform.platform()}
    return {"rows": rows, "machine": machine, "quick": quick, "threads": threads}


def report(results: dict) -> str:
    m = results["machine"]
    lines = [f"Python {m['python']}, numpy {m['numpy']}, scikit-learn {m['sklearn']}, {m['cpus']} CPUs, "
             f"{m['platform']}, {results['threads']} BLAS/OpenMP thread(s)", "",
             "| case | n_samples | k true | k found | skillbank (s) | KMeans, true k (s) | ratio "
             "| ARI skillbank | ARI KMeans |",
             "|---|--:|--:|--:|--:|--:|--:|--:|--:|"]
    for r in results["rows"]:
        km = "" if r["kmeans_s"] is None else f"{r['kmeans_s']:.4f}"
        ratio = "" if r["ratio"] is None else f"{r['ratio']:.1f}x"
        ari_km = "" if r["ari_kmeans"] is None else f"{r['ari_kmeans']:.3f}"
        case = "auto (default)" if r["case"] == "blobs" else "paper, stretch 0.4"
        lines.append(f"| {case} | {r['n_samples']:,} | {r['k_true']} | {r['k_found']} "
                     f"| {r['skillbank_s']:.4f} | {km} | {ratio} | {r['ari_skillbank']:.3f} | {ari_km} |")
    auto = [r for r in results["rows"] if r["case"] == "blobs"]
    right = all(r["k_found"] == r["k_true"] for r in auto)
    lines += ["", "automatic number of clusters right at every size: " + ("yes" if right else "NO")]
    big = max(auto, key=lambda r: r["n_samples"])
    met = "met" if big["skillbank_s"] < TARGET_S else "MISSED"
    lines.append(f"target < {TARGET_S:.0f} s at {big['n_samples']:,} points: {met} "
                 f"({big['skillbank_s']:.2f} s)")
    return "\n".join(lines)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    parser.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    parser.add_argument("--threads", type=int, default=1, help="BLAS/OpenMP threads (default 1)")
    args = parser.parse_args(argv)
    with threadpool_limits(limits=args.threads):
        results = run(args.quick, args.threads)
    print(report(results))
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
