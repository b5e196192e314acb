"""``skillbank cluster``: elastic clustering of a feature matrix or a folder of trajectories."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .._validation import check_array

__all__ = ["add_parser", "run", "read_feature_matrix", "read_trajectory_folder"]

_TRAJECTORY_SUFFIXES = (".csv", ".txt", ".npz")
_PROGRESS_FROM = 20  # files; fewer load too fast for a progress bar to help


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
    p.add_argument("--features", choices=["default", "angular", "dtw", "none"], default="default",
                   help="featuriser for a folder of trajectories: default (direction over time in each "
                        "trajectory's heading frame), angular (similarity to --representatives), dtw, "
                        "none (flattened positions); a feature matrix is used as it is")
    p.add_argument("--representatives", default=None,
                   help="comma-separated file indices (sorted order) of the representatives for "
                        "--features angular")
    p.add_argument("--seed", type=int, default=None, help="random seed")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--plot", type=Path, default=None, help="write a figure of the clusters here")
    p.set_defaults(func=run)
    return p


def read_feature_matrix(path) -> np.ndarray:
    """A feature matrix from ``.npy`` (no pickles) or ``.csv`` (header row optional).

    Raises
    ------
    ValueError
        If the file cannot be parsed as a 2-D finite numeric matrix.

    Examples
    --------
    >>> read_feature_matrix("features.csv").shape  # doctest: +SKIP
    (150, 3)
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npy":
        try:
            data = np.load(path, allow_pickle=False)
        except ValueError as exc:  # object arrays, or not an .npy file at all
            raise ValueError(f"input: cannot read {str(path)!r} as a numeric .npy array: {exc}") from None
    elif suffix in (".csv", ".txt"):
        text = path.read_text(encoding="utf-8-sig")
        lines = [line for line in text.splitlines() if line.strip()]
        if not lines:
            raise ValueError(f"input: expected a numeric feature matrix in {str(path)!r}, "
                             "found an empty file")
        try:
            [float(cell) for cell in lines[0].split(",")]
        except ValueError:
            lines = lines[1:]  # a header row
        if not lines:
            raise ValueError(f"input: expected data rows after the header of {str(path)!r}, found none")
        width = len(lines[0].split(","))
        for number, line in enumerate(lines, start=1):
            cells = line.split(",")
            if len(cells) != width:
                raise ValueError(f"input: {str(path)!r}: data row {number} has {len(cells)} columns, "
                                 f"expected {width} like the first")
            try:
                [float(cell) for cell in cells]
            except ValueError:
                raise ValueError(f"input: {str(path)!r}: data row {number} holds a non-numeric cell: "
                                 f"{line[:60]!r}") from None
        data = np.loadtxt(lines, delimiter=",", dtype=float, ndmin=2)
    else:
        raise ValueError(f"input: expected a feature matrix (.csv, .npy) or a folder of trajectories, "
                         f"got {str(path)!r}")
    return check_array(data, name="input", ndim=2, min_samples=1)


def read_trajectory_folder(folder, *, progress: bool = True):
    """Load every trajectory file of ``folder`` in sorted name order.

    Returns
    -------
    names : list of str
    demos : list of Demonstration
    """
    from tqdm import tqdm

    from ..io import load

    folder = Path(folder)
    files = sorted(f for f in folder.iterdir()
                   if f.is_file() and not f.name.startswith(".") and f.suffix.lower() in _TRAJECTORY_SUFFIXES)
    if not files:
        raise ValueError(f"input: expected trajectory files ({', '.join(_TRAJECTORY_SUFFIXES)}) in folder "
                         f"{str(folder)!r}, found none")
    bar = tqdm(files, desc="loading", unit="file", leave=False,
               disable=not progress or len(files) < _PROGRESS_FROM)
    demos = [load(f) for f in bar]
    return [f.name for f in files], demos


def _parse_indices(text, n: int) -> list[int]:
    if text is None:
        raise ValueError("representatives: --features angular needs --representatives, e.g. 0,5,9 "
                         "(indices of the files in sorted order)")
    try:
        indices = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise ValueError(f"representatives: expected comma-separated integers, got {text!r}") from None
    bad = [i for i in indices if not 0 <= i < n]
    if not indices or bad:
        raise ValueError(f"representatives: expected indices in 0..{n - 1}, got {text!r}")
    return indices


def _featurise(demos, kind: str, representatives, seed):
    if kind == "default":
        from ..clustering import HeadingFeatures

        return HeadingFeatures(random_state=seed).fit_transform(demos)
    if kind == "dtw":
        from ..clustering import DTWFeatures

        return DTWFeatures().fit_transform(demos)
    if kind == "angular":
        from ..clustering import AngularSimilarityFeatures

        reps = [demos[i] for i in _parse_indices(representatives, len(demos))]
        raw = AngularSimilarityFeatures(representatives=reps).fit_transform(demos)
        span = raw.max(axis=0) - raw.min(axis=0)  # min-max per column, as in the paper
        return (raw - raw.min(axis=0)) / np.where(span > 0, span, 1.0)
    lengths = sorted({d.n_steps for d in demos})
    if len(lengths) > 1:
        raise ValueError(f"features: 'none' flattens the positions and needs trajectories of equal length, "
                         f"got lengths {lengths}; use --features default or dtw")
    return np.stack([d["position"].ravel() for d in demos])


def run(args) -> int:
    """Cluster ``args.input``; returns the exit status."""
    from ..clustering import ElasticClustering

    path = Path(args.input)
    if not path.exists():
        raise ValueError(f"input: no such file or folder: {str(path)!r}")
    names, demos = None, None
    if path.is_dir():
        names, demos = read_trajectory_folder(path)
        missing = [n for n, d in zip(names, demos, strict=True) if "position" not in d.streams]
        if missing:
            raise ValueError(f"input: expected a 'position' stream in every file, missing in {missing[:3]}")
        X = _featurise(demos, args.features, args.representatives, args.seed)
    else:
        if args.features not in ("default", "none"):
            raise ValueError(f"features: {args.features!r} needs a folder of trajectories, "
                             f"got the feature matrix {str(path)!r}")
        X = read_feature_matrix(path)
    model = ElasticClustering(stretch=args.stretch, random_state=args.seed).fit(X)
    labels = model.labels_.tolist()
    if args.plot is not None:
        from ..plotting._clustering import plot_cluster_comparison

        plot_cluster_comparison(
            X, {"elastic": model.labels_}, args.plot,
            trajectories=None if demos is None else [d["position"] for d in demos],
            title=f"{path.name}: {model.n_clusters_} cluster(s)",
        )
    if args.json:
        doc = {"labels": labels, "n_clusters": int(model.n_clusters_), "energy": float(model.energy_)}
        if names is not None:
            doc = {"files": names, **doc}
        print(json.dumps(doc))
        return 0
    print(f"{path}: {X.shape[0]} sample(s), {X.shape[1]} feature(s) -> {model.n_clusters_} cluster(s), "
          f"energy {model.energy_:.6g}")
    for k in range(model.n_clusters_):
        members = np.flatnonzero(model.labels_ == k)
        shown = [names[i] for i in members[:8]] if names is not None else members[:12].tolist()
        more = " ..." if members.size > len(shown) else ""
        print(f"  cluster {k + 1}: {members.size} member(s): {', '.join(map(str, shown))}{more}")
    if args.plot is not None:
        print(f"  wrote {args.plot}")
    return 0
