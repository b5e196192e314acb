"""``skillbank segment``: cut a demonstration into motion primitives."""

from __future__ import annotations

import json
from pathlib import Path

from ._options import add_segmentation_options, segmentation_params

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``segment`` on argparse subparsers ``sub``."""
    p = sub.add_parser("segment", help="cut a demonstration into motion primitives")
    p.add_argument("input", help="demonstration file (.h5, .mat, .csv, .npz)")
    add_segmentation_options(p)
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--plot", type=Path, default=None, help="write a summary figure to this file")
    p.add_argument("--out", type=Path, default=None, help="write each segment to this folder")
    p.add_argument("--format", choices=["npz", "csv"], default="npz", help="segment file format for --out")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    """Segment one demonstration; returns the exit status."""
    # Imported here so that 'skillbank --help' and the other commands start without scipy.
    from .. import io
    from ..segmentation import MultimodalSegmenter

    demo = io.load(args.input, index=args.demo, group=args.group)
    result = MultimodalSegmenter(**segmentation_params(args)).fit(demo, args.stream).result_
    written = []
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        stem = Path(args.input).stem
        for i, seg in enumerate(result.segments):
            path = args.out / f"{stem}_segment{i:02d}.{args.format}"
            (io.write_npz if args.format == "npz" else io.write_csv)(seg, path)
            written.append(str(path))
    if args.plot is not None:
        from ..plotting import plot_segmentation_summary  # matplotlib only when a figure is asked for

        plot_segmentation_summary(result, args.plot)
    if args.json:
        print(json.dumps(result.to_dict()))
    else:
        print(f"{args.input}: {result.n_segments} segment(s) from streams {list(result.streams)}")
        for name, cps in result.changepoints.items():
            print(f"  changepoints[{name}]: {[int(c) for c in cps]}")
        for i, (a, b) in enumerate(result.bounds):
            print(f"  segment {i}: samples {a}-{b - 1}, t = {demo.t[a]:.3f}-{demo.t[b - 1]:.3f} s")
        for path in written:
            print(f"  wrote {path}")
        if args.plot is not None:
            print(f"  wrote {args.plot}")
    return 0
