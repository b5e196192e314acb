"""The ``skillbank`` command line."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from . import _cluster, _edit, _experiment, _library
from ._options import add_segmentation_options

__all__ = ["main", "build_parser"]


def _add_segment(sub):
    p = sub.add_parser("segment", help="cut a demonstration into motion primitives")
    p.add_argument("input", help="demonstration file (.h5, .mat, .csv, .npz)")
    add_segmentation_options(p)
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--plot", type=Path, default=None, help="write a summary figure to this file")
    p.add_argument("--out", type=Path, default=None, help="write each segment to this folder")
    p.add_argument("--format", choices=["npz", "csv"], default="npz", help="segment file format for --out")
    p.set_defaults(func=_run_segment)


def _run_segment(args) -> int:
    from .. import io
    from ..segmentation import segment

    demo = io.load(args.input, index=args.demo, group=args.group)
    result = segment(
        demo, args.stream, window=args.window, min_size=args.min_size, threshold=args.threshold,
        grace=args.grace, stop_ratio=args.stop_ratio, min_turn=args.min_turn, mode=args.mode,
        random_state=args.seed,
    )
    written = []
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        stem = Path(args.input).stem
        for i, seg in enumerate(result.segments):
            path = args.out / f"{stem}_segment{i:02d}.{args.format}"
            (io.write_npz if args.format == "npz" else io.write_csv)(seg, path)
            written.append(str(path))
    if args.plot is not None:
        from ..plotting import plot_segmentation_summary

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


def _add_demo(sub):
    p = sub.add_parser("demo", help="run the main job on embedded data (LASA) and write figures")
    p.add_argument("--out", type=Path, default=Path("demo_output"), help="folder for figures and summary")
    p.add_argument("--data", type=Path, default=None,
                   help="shared data folder: use RAIL and the three-button demo instead of LASA")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=_run_demo)


def _run_demo(args) -> int:
    from ..experiments import run_library_demo

    summary = run_library_demo(args.out, data=args.data)
    if args.json:
        print(json.dumps(summary))
    else:
        for r in summary["reuse"]:
            outcome = r["error"] if "error" in r else (
                f"used {r['used']}, constraint error {r['constraint_error']:.2g}, collision {r['collision']}")
            print(f"reuse {r['skill']} ({r['method']}): {outcome}")
        print(f"figures and summary written to {summary['out']}")
        print(f"open {summary['summary']}")
    return 0


class _OneLineParser(argparse.ArgumentParser):
    """Usage errors as one line on stderr with exit status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser for ``skillbank``."""
    parser = _OneLineParser(prog="skillbank", description="A library of motion primitives.")
    sub = parser.add_subparsers(dest="command", required=True)
    _add_segment(sub)
    _add_demo(sub)
    _cluster.add_parser(sub)
    _experiment.add_parser(sub)
    _library.add_parser(sub)
    _edit.add_parser(sub)
    return parser


def main(argv=None) -> int:
    """Entry point; returns the exit status (2 on bad input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (ValueError, ImportError, OSError) as exc:
        message = " ".join(str(exc).split())
        print(f"skillbank {args.command}: error: {message}", file=sys.stderr)
        return 2
