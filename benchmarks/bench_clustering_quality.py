"""Quality of ``skillbank cluster`` with its defaults on folders of raw trajectory files, against baselines.

Run from the repository root::

    .venv/bin/python benchmarks/bench_clustering_quality.py [--seeds 10] [--json PATH]

Cases
-----
lasa8-s
    8 of the 26 single-model LASA shapes (all but ``Multi_Models_1``-``4``),
    drawn with seed s, 7 demonstrations each, written as CSV files to a
    temporary folder and read back as ``skillbank cluster`` reads a folder.
lasa26
    All 26 single-model shapes, 182 files.
rail4
    The RAIL reaching, pushing, pressing and writing demonstrations (209), as
    CSV files.
paper
    The paper's RAIL experiment (``run_rail_experiment(mode="paper")``):
    elastic 20 and agglomerative 22 misclustered must not change.

Methods, all in the same run: skillbank's defaults (``trajectory_features``
default + ``ElasticClustering(criterion="hierarchy")``, what ``skillbank
cluster`` runs), the previous defaults (heading features, ``criterion="auto"``),
k-means with k chosen by the silhouette (k = 2..40) and Ward given the true k,
both on plain resampled start-subtracted coordinates (32 samples in time), and
Ward given the true k on skillbank's features. Scores: number of clusters and
the adjusted Rand index (ARI). Targets (issue 13): LASA 8 the right k and
ARI >= 0.95 on every seed; LASA 26 k within 2 of 26 and ARI >= 0.95; RAIL four
skills ARI >= 0.85. No timing is reported.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
from sklearn.cluster import AgglomerativeClustering, KMeans
from sklearn.metrics import adjusted_rand_score, silhouette_score

from skillbank.clustering import ElasticClustering, trajectory_features
from skillbank.core import resample_many
from skillbank.io import lasa_shapes, load_folder, load_lasa, load_rail, write_csv

RAIL_CLASSES = ("reaching", "pushing", "pressing", "writing")


def single_model_shapes() -> list[str]:
    return [s for s in lasa_shapes() if not s.lower().startswith("multi_models")]


def as_folder(demos, classes, folder: Path):
    """Write one CSV per demonstration (named so that sorted order is the given order); read it back."""
    for i, d in enumerate(demos):
        write_csv(d, folder / f"{i:04d}.csv")
    names, loaded = load_folder(folder, progress=False)
    return loaded, np.asarray(classes)


def plain(demos) -> np.ndarray:
    R = resample_many([d["position"] for d in demos], [d.t for d in demos], 32, "time")
    R -= R[:, :1, :]
    return R.reshape(R.shape[0], -1)


def kmeans_silhouette(X, k_max=40):
    best = (-2.0, None)
    for k in range(2, min(k_max, X.shape[0] - 1) + 1):
        labels = KMeans(n_clusters=k, n_init=4, random_state=0).fit_predict(X)
        score = silhouette_score(X, labels)
        if score > best[0]:
            best = (score, labels)
    return best[1]


def score(demos, truth) -> dict:
    k_true = int(np.unique(truth).size)
    X = trajectory_features(demos, "default", random_state=0)
    model = ElasticClustering(criterion="hierarchy", random_state=0).fit(X)
    old = ElasticClustering(random_state=0).fit(trajectory_features(demos, "heading", random_state=0))
    P = plain(demos)
    km = kmeans_silhouette(P)
    ward_plain = AgglomerativeClustering(n_clusters=k_true, linkage="ward").fit_predict(P)
    ward_ours = AgglomerativeClustering(n_clusters=k_true, linkage="ward").fit_predict(X)
    return {
        "n": len(demos), "k_true": k_true,
        "k": int(model.n_clusters_), "ari": adjusted_rand_score(truth, model.labels_),
        "k_old": int(old.n_clusters_), "ari_old": adjusted_rand_score(truth, old.labels_),
        "k_kmeans": int(np.unique(km).size), "ari_kmeans": adjusted_rand_score(truth, km),
        "ari_ward_plain": adjusted_rand_score(truth, ward_plain),
        "ari_ward_features": adjusted_rand_score(truth, ward_ours),
    }


def run(seeds: int, data_dir: Path) -> dict:
    shapes = single_model_shapes()
    by_shape = {s: load_lasa(s) for s in shapes}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        cases = [(f"lasa8-{s}", list(np.random.default_rng(s).choice(shapes, 8, replace=False)))
                 for s in range(seeds)] + [("lasa26", shapes)]
        for name, chosen in cases:
            demos = [d for s in chosen for d in by_shape[s]]
            classes = [k for k, s in enumerate(chosen) for _ in by_shape[s]]
            folder = Path(tmp) / name
            folder.mkdir()
            rows.append({"case": name, **score(*as_folder(demos, classes, folder))})
        rail = data_dir / "rail"
        if rail.is_dir():
            demos, classes = [], []
            for k, c in enumerate(RAIL_CLASSES):
                part = load_rail(rail, classes=[c])
                demos += part
                classes += [k] * len(part)
            folder = Path(tmp) / "rail4"
            folder.mkdir()
            rows.append({"case": "rail4", **score(*as_folder(demos, classes, folder))})
    paper = None
    if (data_dir / "rail").is_dir():
        from skillbank.experiments import run_rail_experiment

        out = run_rail_experiment(data_dir / "rail", mode="paper")
        paper = {"elastic": out["elastic"]["misclustered"],
                 "agglomerative": out["agglomerative"]["misclustered"]}
    return {"rows": rows, "paper": paper, "seeds": seeds}


def report(results: dict) -> str:
    lines = ["| case | files | k true | k skillbank | ARI skillbank | k old default | ARI old default "
             "| k k-means+silhouette | ARI k-means+silhouette | ARI Ward true k (plain) "
             "| ARI Ward true k (skillbank features) |",
             "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|"]
    for r in results["rows"]:
        lines.append(f"| {r['case']} | {r['n']} | {r['k_true']} | {r['k']} | {r['ari']:.3f} | {r['k_old']} "
                     f"| {r['ari_old']:.3f} | {r['k_kmeans']} | {r['ari_kmeans']:.3f} "
                     f"| {r['ari_ward_plain']:.3f} | {r['ari_ward_features']:.3f} |")
    lasa8 = [r for r in results["rows"] if r["case"].startswith("lasa8")]
    right = sum(r["k"] == r["k_true"] for r in lasa8)
    aris = np.array([r["ari"] for r in lasa8])
    lines += ["", f"LASA 8 shapes over {len(lasa8)} seeds: right k on {right}, ARI min {aris.min():.3f}, "
              f"mean {aris.mean():.3f}, ARI >= 0.95 on {int((aris >= 0.95).sum())}"]
    if results["paper"] is not None:
        p = results["paper"]
        lines.append(f"paper mode: elastic {p['elastic']} misclustered, agglomerative {p['agglomerative']} "
                     f"({'unchanged' if (p['elastic'], p['agglomerative']) == (20, 22) else 'CHANGED'})")
    return "\n".join(lines)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=10, help="LASA 8-shape subsets (default 10)")
    parser.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[2] / "shared" / "data",
                        help="data folder holding rail/ (default ../shared/data)")
    parser.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    args = parser.parse_args(argv)
    results = run(args.seeds, args.data)
    print(report(results))
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    sys.exit(main())
