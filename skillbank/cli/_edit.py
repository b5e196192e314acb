"""``skillbank edit``: adapt a demonstration to new constraints with LTE or an LfD representation."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

from ._options import METHODS, add_constraint_options

__all__ = ["add_parser", "run", "METHODS", "read_demonstrations", "reproduce", "edit_metrics"]

_SINGLE = {"lte": "Laplacian trajectory editing", "ja": "the jerk-accuracy model"}


def add_parser(sub):
    """Register ``edit`` on argparse subparsers ``sub``.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="skillbank")
    >>> add_parser(parser.add_subparsers(dest="command"))  # doctest: +ELLIPSIS
    ArgumentParser(...)
    """
    p = sub.add_parser("edit", help="adapt a demonstration to a new start, goal, via-points and obstacles")
    p.add_argument("input", nargs="+", type=Path,
                   help="trajectory file(s) (.csv, .npz, .h5, .mat); several for the multi-demo methods "
                        "(promp, elmap, dmp). The 'position' stream is used, or the only stream")
    p.add_argument("--method", choices=METHODS, default="lte",
                   help="lte (Laplacian trajectory editing), ja (jerk-accuracy), promp, elmap (elastic map), "
                        "dmp; default lte")
    add_constraint_options(p)
    p.add_argument("--out", type=Path, default=None, help="write the result here (.csv or .npz)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--plot", type=Path, default=None, help="write a figure of the edit here")
    p.set_defaults(func=run)
    return p


def read_demonstrations(paths):
    """Load each file as a Demonstration with one ``"position"`` stream.

    The file's ``position`` stream is taken, or its only stream.

    Raises
    ------
    ValueError
        For a missing or unreadable file, a file with several streams none of
        them ``position``, or files of different dimensions.

    Examples
    --------
    >>> read_demonstrations(["demo.csv"])[0].stream_names  # doctest: +SKIP
    ['position']
    """
    from .._demonstration import Demonstration
    from ..io import load

    demos = []
    for path in paths:
        path = Path(path)
        if not path.is_file():
            raise ValueError(f"input: no such file: {str(path)!r}")
        demo = load(path)
        if "position" in demo.streams:
            name = "position"
        elif len(demo.streams) == 1:
            name = demo.stream_names[0]
        else:
            raise ValueError(f"input: {str(path)!r} has streams {demo.stream_names} and none is 'position'; "
                             "write the one to edit as a single-stream file")
        Y = demo[name]
        if demos and Y.shape[1] != demos[0]["position"].shape[1]:
            raise ValueError(f"input: {str(path)!r} has {Y.shape[1]} dimensions, but "
                             f"{str(paths[0])!r} has {demos[0]['position'].shape[1]}")
        demos.append(Demonstration(demo.t, {"position": Y}, {"source": str(path)}))
    return demos


def _model(method: str):
    if method == "lte":
        from ..editing import LaplacianEditor

        return LaplacianEditor()
    from ..representations import DMP, ElasticMap, JerkAccuracy, ProMP

    return {"ja": JerkAccuracy, "promp": ProMP, "elmap": ElasticMap, "dmp": DMP}[method]()


def reproduce(demos, constraints, method: str = "lte"):
    """Adapt ``demos`` to ``constraints`` with ``method``; returns ``(Demonstration, collision, notes)``.

    ``collision`` is the method's own verdict (samples inside, or segments
    crossing, an obstacle) combined with a check of the samples; ``notes``
    lists warnings raised on the way (e.g. an obstacle edit that failed).

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Demonstration
    >>> from skillbank._constraints import Constraints
    >>> demo = Demonstration.from_array(np.c_[np.linspace(0, 1, 50), np.zeros(50)])
    >>> out, collision, notes = reproduce([demo], Constraints(goal=[1.0, 0.5]))
    >>> out["position"][-1].tolist(), collision
    ([1.0, 0.5], False)
    """
    if method not in METHODS:
        raise ValueError(f"method: expected one of {list(METHODS)}, got {method!r}")
    if method in _SINGLE and len(demos) != 1:
        raise ValueError(f"input: --method {method} ({_SINGLE[method]}) adapts one demonstration, got "
                         f"{len(demos)} files; use promp, elmap or dmp for several")
    constraints.check_dims(demos[0]["position"].shape[1])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        model = _model(method).fit(demos[0] if method in _SINGLE else list(demos))
        out = model.reproduce(constraints)
    notes = [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
    info = out.metadata.get("edit") or out.metadata.get("obstacle_editing") or {}
    Y = out["position"]
    collision = bool(info.get("collision", False))
    collision = collision or (bool(constraints.obstacles) and constraints.collides(Y))
    if method == "lte" and not info.get("success", True) and info.get("message"):
        notes.append(str(info["message"]))
    return out, collision, notes


def edit_metrics(Y, t, reference, constraints) -> dict:
    """Shape and quality of ``Y`` (times ``t``) against the ``reference`` demonstration's positions.

    ``frechet`` and ``dtw`` compare the curves as they are; ``angular_similarity``,
    ``swept_error_area`` and ``curvature_deviation`` compare them sample by
    sample (the reproduction resampled to the reference's length if needed).
    ``clearance`` (smallest signed distance to an obstacle) only with obstacles.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank._constraints import Constraints
    >>> s = np.linspace(0.0, 1.0, 20)
    >>> m = edit_metrics(np.c_[s, s], s, np.c_[s, s], Constraints())
    >>> m["frechet"], round(m["path_length"], 6)
    (0.0, 1.414214)
    """
    from ..metrics import (
        angular_similarity,
        curvature_deviation,
        dtw_distance,
        frechet_distance,
        jerk_cost,
        path_length,
        swept_error_area,
    )
    from ..representations import resample

    same = Y if Y.shape[0] == reference.shape[0] else resample(Y, reference.shape[0])
    metrics = {
        "frechet": frechet_distance(Y, reference),
        "dtw": dtw_distance(Y, reference),
        "swept_error_area": swept_error_area(same, reference),
        "angular_similarity": angular_similarity(same, reference),
        "curvature_deviation": curvature_deviation(same, reference),
        "path_length": path_length(Y),
        "demo_path_length": path_length(reference),
        "jerk_cost": jerk_cost(Y, t) if Y.shape[0] >= 4 else 0.0,
    }
    if constraints.obstacles:
        metrics["clearance"] = float(constraints.signed_distances(Y).min())
    return {k: float(v) for k, v in metrics.items()}


def run(args) -> int:
    """Edit ``args.input`` under the constraints given on the command line; returns the exit status."""
    from .._constraints import Constraints
    from .._demonstration import Demonstration

    constraints = Constraints.from_cli(args.start, args.goal, args.via, args.obstacle)
    out_suffix = None if args.out is None else args.out.suffix.lower()
    if out_suffix not in (None, ".csv", ".npz"):
        raise ValueError(f"out: expected a .csv or .npz file name, got {str(args.out)!r}")
    demos = read_demonstrations(args.input)
    out, collision, notes = reproduce(demos, constraints, args.method)
    Y, t = out["position"], out.t
    error = constraints.position_error(Y)
    metrics = edit_metrics(Y, t, demos[0]["position"], constraints)
    if args.out is not None:
        from ..io import write_csv, write_npz

        meta = {"method": args.method, "inputs": [str(p) for p in args.input],
                "constraint_error": error, "collision": collision}
        (write_csv if out_suffix == ".csv" else write_npz)(Demonstration(t, {"position": Y}, meta), args.out)
    if args.plot is not None:
        from ..plotting._editing import plot_edit

        plot_edit(Y, args.plot, demo=demos[0], demos=demos[1:], constraints=constraints,
                  title=f"{args.method}: {Path(args.input[0]).name}")
    if args.json:
        doc = {"trajectory": Y.tolist(), "constraint_error": float(error), "collision": bool(collision),
               "metrics": metrics}
        print(json.dumps(doc, allow_nan=False))
        return 0
    print(f"{args.method}: {len(demos)} demonstration(s) -> {Y.shape[0]} samples, {Y.shape[1]} dimensions")
    print(f"  constraint error {error:.3g}, collision {'yes' if collision else 'no'}")
    print("  " + ", ".join(f"{k} {v:.4g}" for k, v in metrics.items()))
    for note in notes:
        print(f"  warning: {' '.join(note.split())}")
    for path in (args.out, args.plot):
        if path is not None:
            print(f"  wrote {path}")
    return 0
