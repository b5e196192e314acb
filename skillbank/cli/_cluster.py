"""``skillbank cluster``: elastic clustering of a feature matrix or a folder of trajectories."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ._options import add_repair_option

__all__ = ["add_parser", "run", "CLUSTER_FEATURES", "LIBRARY_FEATURES", "library_features", "FEATURE_KIND"]

#: ``cluster --features``: the featurisers of a folder of trajectories (``clustering.trajectory_features``).
CLUSTER_FEATURES = ("default", "heading", "angular", "dtw", "none")
#: ``library cluster --features``: the two the library stores (``clustering.primitive_features``), by the
#: names ``cluster`` gives them; FEATURE_KIND maps them to the library's own kinds.
LIBRARY_FEATURES = ("heading", "position")
FEATURE_KIND = {"heading": "default", "position": "position"}


def library_features(text: str) -> str:
    """``library cluster --features``: its old name ``default`` is read as ``heading``.

    Examples
    --------
    >>> library_features("default"), library_features("position")
    ('heading', 'position')
    """
    return "heading" if text == "default" else text



def add_parser(sub):
    """Register ``cluster`` on argparse subparsers ``sub``.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="skillbank")
    >>> add_parser(parser.add_subparsers(dest="command"))  # doctest: +ELLIPSIS
    ArgumentParser(...)
    """
    p = sub.add_parser("cluster", help="group motion primitives with elastic clustering")
    p.add_argument("input", type=Path,
                   help="feature matrix (.csv with or without header, .npy) or a folder of trajectory "
                        "files (.csv/.npz, one trajectory each, taken in sorted name order)")
    p.add_argument("--stretch", type=float, default=1.2, help="stretching constant lambda >= 0")
    p.add_argument("--criterion", default="hierarchy", choices=("hierarchy", "auto", "paper"),
                   help="how the number of clusters is chosen: hierarchy (the most detailed cut of a Ward "
                        "tree whose clusters are all well separated; default), auto (split one cluster at a "
                        "time while the split is well separated), paper (the authors' energy)")
    p.add_argument("--features", default="default", choices=CLUSTER_FEATURES,
                   help="featuriser for a folder of trajectories: default (shape and direction: unit step "
                        "directions over time and along the path), heading (direction over time in each "
                        "trajectory's heading frame), angular (similarity to --representatives), dtw, "
                        "none (flattened positions); a feature matrix is used as it is")
    p.add_argument("--representatives", default=None,
                   help="comma-separated file indices (sorted order) of the representatives for "
                        "--features angular")
    p.add_argument("--seed", type=int, default=0,
                   help="random seed (first elastic node, PCA; default 0, as 'library cluster' and "
                        "'experiment rail')")
    add_repair_option(p)
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--plot", type=Path, default=None,
                   help="write a figure of the clusters to this file (.png, .pdf, .svg; no extension: .png)")
    p.set_defaults(func=run)
    return p


def _indices(text) -> list[int] | None:
    if text is None:
        return None
    try:
        return [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise ValueError(f"representatives: expected comma-separated integers, got {text!r}") from None


def run(args) -> int:
    """Cluster ``args.input``; returns the exit status."""
    # Imported here so that 'skillbank --help' and the other commands start without scikit-learn.
    from ..clustering import ElasticClustering, trajectory_features
    from ..io import load_folder, read_feature_matrix

    path = Path(args.input)
    if not path.exists():
        raise ValueError(f"input: no such file or folder: {str(path)!r}")
    if args.plot is not None:
        from ..plotting import figure_path  # matplotlib only when a figure is asked for

        figure_path(args.plot, name="plot")  # a bad name fails before the work, not after
    names, demos = None, None
    if path.is_dir():
        names, demos = load_folder(path, repair_time=args.repair_time)
        missing = [n for n, d in zip(names, demos, strict=True) if "position" not in d.streams]
        if missing:
            raise ValueError(f"input: expected a 'position' stream in every file, missing in {missing[:3]}")
        if args.features == "angular" and args.representatives is None:
            raise ValueError("representatives: --features angular needs --representatives, e.g. 0,5,9 "
                             "(indices of the files in sorted order)")
        X = trajectory_features(demos, args.features, representatives=_indices(args.representatives),
                                random_state=args.seed)
    else:
        if args.features not in ("default", "none"):
            raise ValueError(f"features: {args.features!r} needs a folder of trajectories, "
                             f"got the feature matrix {str(path)!r}")
        X = read_feature_matrix(path)
    model = ElasticClustering(stretch=args.stretch, criterion=args.criterion, random_state=args.seed).fit(X)
    sizes = model.cluster_sizes_.tolist()
    # each cluster's separation from its nearest other cluster: why it is a cluster of its own
    separation = [None if not np.isfinite(v) else round(float(v), 3) for v in model.separation_]
    # and the p-value of the test that kept it apart from its nearest cluster (None where none ran)
    p_values = [None if not np.isfinite(v) else round(float(v), 4) for v in model.p_values_]
    labels = model.labels_.tolist()
    plot = None
    if args.plot is not None:
        from ..plotting import plot_cluster_comparison  # matplotlib, as above

        plot = plot_cluster_comparison(
            X, {"elastic": model.labels_}, args.plot,
            trajectories=None if demos is None else [d["position"] for d in demos],
            title=f"{path.name}: {model.n_clusters_} cluster(s), separation >= "
                  f"{model.min_separation:g} ({model.criterion})",
            separation=model.separation_,
        )
    if args.json:
        doc = {"labels": labels, "n_clusters": int(model.n_clusters_), "energy": float(model.energy_),
               "criterion": model.criterion, "min_separation": float(model.min_separation),
               "significance": model.significance, "sizes": sizes, "separation": separation,
               "p_values": p_values}
        if names is not None:
            doc = {"files": names, **doc}
        if plot is not None:
            doc["plot"] = str(plot)
        print(json.dumps(doc))
        return 0
    print(f"{path}: {X.shape[0]} sample(s), {X.shape[1]} feature(s) -> {model.n_clusters_} cluster(s), "
          f"energy {model.energy_:.6g}")
    for k in range(model.n_clusters_):
        members = np.flatnonzero(model.labels_ == k)
        shown = [names[i] for i in members[:8]] if names is not None else members[:12].tolist()
        more = " ..." if members.size > len(shown) else ""
        # ids as in --json, the figure and 'skillbank library': 0..k-1
        why = "" if separation[k] is None else f", separation {separation[k]:.2f}"
        why += "" if p_values[k] is None else f", p {p_values[k]:.3f}"
        print(f"  cluster {k}: {members.size} member(s){why}: {', '.join(map(str, shown))}{more}")
    if plot is not None:
        print(f"  wrote {plot}")
    return 0
