"""``skillbank segment``: cut a demonstration into motion primitives."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

from ..core._text import printable
from ._options import add_reader_options, add_segmentation_options, reader_options, segmentation_params
from ._output import add_force_option

__all__ = ["add_parser", "run", "segment_file_names", "set_aside_note"]


def add_parser(sub):
    """Register ``segment`` on argparse subparsers ``sub``."""
    p = sub.add_parser("segment", help="cut a demonstration into motion primitives")
    p.add_argument("input", help="demonstration file (.h5, .mat, .csv, .npz, a ROS 1 .bag, a ROS 2 bag "
                                 "folder, .mcap, a LeRobot dataset folder, a robomimic .hdf5)")
    add_segmentation_options(p)
    add_reader_options(p)
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--plot", type=Path, default=None, help="write a summary figure to this file")
    p.add_argument("--out", type=Path, default=None,
                   help="write the segments to this folder: <input>_segmentNN.npz with every stream, or "
                        "with --format csv one <input>_segmentNN_<stream>.csv per stream; files of that "
                        "format left there by an earlier run on the same input are replaced, with --force")
    add_force_option(p, existing=_earlier_outputs)
    p.add_argument("--format", choices=["npz", "csv"], default="npz", help="segment file format for --out")
    p.set_defaults(func=run)
    return p


def segment_file_names(stem: str, n_segments: int, streams, fmt: str) -> list[str]:
    """The files ``--out`` writes for ``n_segments`` segments of a demonstration with ``streams``.

    NPZ keeps every stream in one file per segment; a CSV file holds one stream
    (:func:`skillbank.io.write_csv`), so there is one per stream and segment.

    Examples
    --------
    >>> segment_file_names("demo", 2, ["position", "force"], "csv")[:3]
    ['demo_segment00_position.csv', 'demo_segment00_force.csv', 'demo_segment01_position.csv']
    >>> segment_file_names("demo", 2, ["position", "force"], "npz")
    ['demo_segment00.npz', 'demo_segment01.npz']
    """
    if fmt == "npz":
        return [f"{stem}_segment{i:02d}.npz" for i in range(n_segments)]
    return [f"{stem}_segment{i:02d}_{name}.csv" for i in range(n_segments) for name in streams]


def _earlier_files(folder: Path, stem: str, fmt: str) -> list[Path]:
    """Files of ``fmt`` that a run on an input named ``stem`` wrote to ``folder``."""
    # Not "<stem>_segment00_segment00.npz": the segments of a segment file, another input's.
    stream = r"_(?!segment\d)\w+" if fmt == "csv" else ""
    pattern = re.compile(rf"{re.escape(stem)}_segment\d+{stream}\.{fmt}")
    return sorted(p for p in folder.iterdir() if p.is_file() and pattern.fullmatch(p.name))


def _earlier_outputs(args) -> list[Path]:
    """What ``--out`` would replace: the segments an earlier run on the same input left there."""
    folder = Path(args.out)
    return _earlier_files(folder, Path(args.input).stem, args.format) if folder.is_dir() else []


def _write_segments(io, result, folder: Path, stem: str, fmt: str) -> tuple[list[str], list[str]]:
    """Write every segment with every stream; remove what an earlier run left. Returns (written, removed)."""
    folder.mkdir(parents=True, exist_ok=True)
    earlier = _earlier_files(folder, stem, fmt)
    segments = result.segments
    streams = segments[0].stream_names
    names = iter(segment_file_names(stem, len(segments), streams, fmt))
    written = []
    for seg in segments:
        if fmt == "npz":
            written.append(io.write_npz(seg, folder / next(names)))
        else:
            written += [io.write_csv(seg, folder / next(names), stream=name) for name in streams]
    # Removed after writing: a run that fails half-way leaves the earlier files, not none.
    kept = set(written)
    removed = [p for p in earlier if p not in kept]
    for p in removed:
        p.unlink()
    return [str(p) for p in written], [str(p) for p in removed]


def set_aside_note(result) -> str:
    """One line on the streams a segmentation set aside as constant; empty if none.

    Constant columns of an informative stream (a simulated force along z only)
    are reported by ``--json`` (``constant_columns``), not noted.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Demonstration
    >>> from skillbank.segmentation import segment
    >>> t = np.linspace(0.0, 4.0, 400)
    >>> demo = Demonstration(t, {"position": np.c_[np.minimum(t, 1.0), np.clip(t - 2.0, 0.0, 1.0)],
    ...                          "torque": np.zeros((400, 3))})
    >>> set_aside_note(segment(demo))[:69]
    "set aside stream 'torque' (constant: every value is 0), which carries"
    """
    parts = [f"stream {name!r} ({why})" for name, why in result.set_aside.items()]
    if not parts:
        return ""
    if len(parts) == len(result.streams):
        return (f"every stream is constant: {', '.join(parts)}; nothing to segment, the demonstration is "
                "one segment")
    verb = "carry" if len(parts) > 1 else "carries"
    return (f"set aside {', '.join(parts)}, which {verb} no information; the other streams were segmented "
            "as usual")


def _pick(demos: list, index, path: str) -> int:
    """The index of the demonstration to segment, counted from 0."""
    n = len(demos)
    if index is None:
        if n > 1:
            print(printable(f"skillbank segment: {path} holds {n} demonstrations; segmenting demonstration 0 "
                            f"(--demo 0..{n - 1} picks another)"), file=sys.stderr)  # a name may hold ESC
        return 0
    if not -n <= index < n:
        raise ValueError(f"demo: expected an index in 0..{n - 1} ({path} holds {n} demonstration"
                         f"{'s' if n != 1 else ''}), got {index}")
    return index % n


def run(args) -> int:
    """Segment one demonstration; returns the exit status."""
    # Imported here so that 'skillbank --help' and the other commands start without scipy.
    from .. import io
    from ..segmentation import MultimodalSegmenter

    if args.plot is not None:
        from ..plotting import figure_path  # matplotlib only when a figure is asked for

        figure_path(args.plot, name="plot")  # a bad name fails before the work, not after
    demos = io.load_all(args.input, group=args.group, repair_time=args.repair_time,
                        reader_options=reader_options(args))
    index = _pick(demos, args.demo, args.input)
    demo = demos[index]
    result = MultimodalSegmenter(**segmentation_params(args)).fit(demo, args.stream).result_
    note = set_aside_note(result)
    if note:
        print(printable(f"skillbank segment: {note}"), file=sys.stderr)
    written, removed = [], []
    if args.out is not None:
        written, removed = _write_segments(io, result, args.out, Path(args.input).stem, args.format)
    plot = None
    if args.plot is not None:
        from ..plotting import plot_segmentation_summary  # matplotlib, as above

        plot = plot_segmentation_summary(result, args.plot)
    if args.json:
        doc = {**result.to_dict(), "demo": index, "n_demos": len(demos)}
        if args.out is not None:
            doc.update(files=written, removed=removed)
        if plot is not None:
            doc["plot"] = str(plot)
        print(json.dumps(doc))
        return 0
    which = f" (demonstration {index} of {len(demos)})" if len(demos) > 1 else ""
    print(f"{args.input}{which}: {result.n_segments} segment(s) from streams {list(result.streams)}")
    for name, cps in result.changepoints.items():
        print(f"  changepoints[{name}]: {[int(c) for c in cps]}")
    for i, (a, b) in enumerate(result.bounds):
        print(f"  segment {i}: samples {a}-{b - 1}, t = {demo.t[a]:.3f}-{demo.t[b - 1]:.3f} s")
    for path in written:
        print(f"  wrote {path}")
    for path in removed:
        print(f"  removed {path} (from an earlier run)")
    if plot is not None:
        print(f"  wrote {plot}")
    return 0
