"""``skillbank edit``: adapt a demonstration to new constraints with LTE or an LfD representation."""

from __future__ import annotations

import json
from pathlib import Path

from ..core import Demonstration
from ._options import add_constraint_options, add_repair_option, constraints_from_args

__all__ = ["add_parser", "run"]


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
    p.add_argument("--method", default="lte",
                   help="a representation of skillbank.representations.REPRESENTATIONS: lte (Laplacian "
                        "trajectory editing, default), ja (jerk-accuracy), promp, elmap (elastic map), dmp")
    add_constraint_options(p)
    p.add_argument("--metrics", action="store_true",
                   help="also compare the result with the demonstration (Fréchet, DTW, swept area, ...); "
                        "Fréchet and DTW take time proportional to the product of the lengths")
    p.add_argument("--out", type=Path, default=None, help="write the result here (.csv or .npz)")
    add_repair_option(p)
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--plot", type=Path, default=None,
                   help="write a figure of the edit to this file (.png, .pdf, .svg; no extension: .png)")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    """Edit ``args.input`` under the constraints given on the command line; returns the exit status."""
    # Imported here, not at the top, so that 'skillbank --help' and the other commands start
    # without scikit-learn and scipy.
    from ..io import load_positions, write_csv, write_npz
    from ..metrics import comparison_metrics
    from ..representations import fit_reproduce, representation

    representation(args.method)  # an unknown name fails first, listing the registry's
    constraints = constraints_from_args(args.start, args.goal, args.via, args.obstacle)
    out_suffix = None if args.out is None else args.out.suffix.lower()
    if out_suffix not in (None, ".csv", ".npz"):
        raise ValueError(f"out: expected a .csv or .npz file name, got {str(args.out)!r}")
    if args.plot is not None:
        from ..plotting import figure_path  # matplotlib only when a figure is asked for

        figure_path(args.plot, name="plot")  # a bad name fails before the work, not after
    demos = load_positions(args.input, repair_time=args.repair_time)
    constraints.check_dims(demos[0]["position"].shape[1])
    out, collision, notes = fit_reproduce(args.method, demos, constraints)
    Y, t = out["position"], out.t
    error = constraints.position_error(Y)
    metrics = comparison_metrics(Y, t, demos[0]["position"], constraints) if args.metrics else None
    if args.out is not None:
        meta = {"method": args.method, "inputs": [str(p) for p in args.input],
                "constraint_error": error, "collision": collision}
        (write_csv if out_suffix == ".csv" else write_npz)(Demonstration(t, {"position": Y}, meta), args.out)
    plot = None
    if args.plot is not None:
        from ..plotting import plot_edit  # matplotlib, as above

        plot = plot_edit(Y, args.plot, demo=demos[0], demos=demos[1:], constraints=constraints,
                         title=f"{args.method}: {Path(args.input[0]).name}")
    if args.json:
        doc = {"trajectory": Y.tolist(), "constraint_error": float(error), "collision": bool(collision)}
        if metrics is not None:
            doc["metrics"] = metrics
        if plot is not None:
            doc["plot"] = str(plot)
        print(json.dumps(doc, allow_nan=False))
        return 0
    print(f"{args.method}: {len(demos)} demonstration(s) -> {Y.shape[0]} samples, {Y.shape[1]} dimensions")
    print(f"  constraint error {error:.3g}, collision {'yes' if collision else 'no'}")
    if metrics is not None:
        print("  " + ", ".join(f"{k} {v:.4g}" for k, v in metrics.items()))
    for note in notes:
        print(f"  warning: {' '.join(note.split())}")
    for path in (args.out, plot):
        if path is not None:
            print(f"  wrote {path}")
    return 0
