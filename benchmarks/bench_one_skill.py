"""One skill is one cluster (issue 44, item 5): the automatic number of clusters on one letter, two letters
and one RAIL skill, with and without ``ElasticClustering``'s significance test.

Run from the repository root::

    .venv/bin/python benchmarks/bench_one_skill.py [--data ../shared/data]

Cases: each of LASA's 26 single-model letters alone (7 drawings: 1 skill), each of the 325 pairs of
them (14 drawings: 2 skills) and each RAIL skill alone (1 skill). Two pipelines, as the commands run
them: ``skillbank library cluster`` of whole demonstrations (``primitive_features``, 3 PCA components,
``criterion="auto"``) and ``skillbank cluster`` of a folder (``trajectory_features``,
``criterion="hierarchy"``). Each is fitted with ``significance=None`` (the search alone, as before)
and with the default ``significance=0.01``. Scores: cases with the right number of clusters, and
with the right partition (ARI 1). The fits' total time is printed last (machine-dependent).
"""

from __future__ import annotations

import argparse
import itertools
import os
import time
from pathlib import Path

import numpy as np
from sklearn.decomposition import PCA
from sklearn.metrics import adjusted_rand_score

from skillbank.clustering import ElasticClustering, primitive_features, trajectory_features
from skillbank.io import lasa_shapes, load_lasa, load_rail

RAIL = ("reaching", "pushing", "pressing", "writing")


def features(demos):
    """``(folder, library)`` feature matrices: what ``skillbank cluster`` and ``Library.cluster`` fit."""
    F = primitive_features(demos, kind="default", n_points=16)
    library = PCA(n_components=min(3, *F.shape), random_state=0).fit_transform(F)
    return trajectory_features(demos, "default", random_state=0), library


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(os.environ.get("SKILLBANK_DATA", "../shared/data")))
    args = parser.parse_args(argv)
    shapes = {s: load_lasa(s) for s in lasa_shapes() if not s.lower().startswith("multi_models")}
    cases = [("letter", s, d, np.zeros(len(d), int)) for s, d in shapes.items()]
    for a, b in itertools.combinations(shapes, 2):
        truth = np.repeat([0, 1], [len(shapes[a]), len(shapes[b])])
        cases.append(("two letters", f"{a}+{b}", shapes[a] + shapes[b], truth))
    rail = {c: load_rail(args.data / "rail", classes=[c]) for c in RAIL}
    cases += [("RAIL skill", c, d, np.zeros(len(d), int)) for c, d in rail.items()]
    tally, spent, rail_rows = {}, {None: 0.0, 0.01: 0.0}, []
    for kind, name, demos, truth in cases:
        folder, library = features(demos)
        for level in (None, 0.01):
            pipelines = (("library cluster", library, "auto"), ("cluster", folder, "hierarchy"))
            for pipeline, X, criterion in pipelines:
                start = time.perf_counter()
                model = ElasticClustering(criterion=criterion, significance=level, random_state=0).fit(X)
                spent[level] += time.perf_counter() - start
                want = int(truth.max()) + 1
                right = model.n_clusters_ == want
                row = tally.setdefault((kind, pipeline, level), [0, 0, 0])
                row[0] += 1
                row[1] += right
                row[2] += right and (want == 1 or adjusted_rand_score(truth, model.labels_) == 1.0)
                if kind == "RAIL skill":
                    sizes = model.cluster_sizes_.tolist()
                    rail_rows.append((name, pipeline, level, model.n_clusters_, sizes))
    print("| cases | command | significance | n | right number | right partition |")
    print("|---|---|---|--:|--:|--:|")
    for (kind, pipeline, level), (n, right, partition) in tally.items():
        print(f"| {kind} | {pipeline} | {level} | {n} | {right} | {partition} |")
    print()
    for name, pipeline, level, k, sizes in rail_rows:
        print(f"RAIL {name}, {pipeline}, significance {level}: {k} cluster(s) {sizes}")
    print(f"\nfit time, all cases: {spent[None]:.1f} s without the test, {spent[0.01]:.1f} s with it")


if __name__ == "__main__":
    main()
