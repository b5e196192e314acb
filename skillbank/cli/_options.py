"""Options shared by several commands: segmentation parameters and task constraints."""

from __future__ import annotations

import argparse
import re

__all__ = ["METHODS", "RANKINGS", "SHORTLIST", "size", "add_segmentation_options", "add_constraint_options"]

# the CLI starts without importing skillbank.selection; a test checks these match it
METHODS = ("lte", "ja", "promp", "elmap", "dmp")
RANKINGS = ("shortlist", "length", "endpoints", "deformation")
SHORTLIST = 3
_NEGATIVE_COORDINATES = re.compile(r"^-(\d|\.\d)[\d.eE+\-,]*$")


def size(value: str):
    """Samples (``64``) or seconds (``0.1s``), checked later against the data."""
    value = value.strip()
    if value == "auto" or value.endswith("s"):
        return value
    try:
        return int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected an integer number of samples or seconds like '0.1s', got {value!r}") from None


def ratio_or_none(value: str):
    """A number, or ``none`` to switch the stop-or-turn gate off."""
    if value.strip().lower() == "none":
        return None
    try:
        return float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 1] or 'none', got {value!r}") from None


def add_segmentation_options(p) -> None:
    """Input selection and :class:`~skillbank.segmentation.MultimodalSegmenter` parameters."""
    p.add_argument("--demo", type=int, default=None, help="demonstration index inside multi-demo files")
    p.add_argument("--group", default="normalized", help="group inside handwriting HDF5 files")
    p.add_argument("--stream", action="append", default=None, help="stream to use (repeatable; default all)")
    p.add_argument("--window", type=size, default="auto", help="window in samples or seconds (0.1s)")
    p.add_argument("--min-size", type=size, default="auto", help="minimum segment size, samples or seconds")
    p.add_argument("--threshold", type=float, default=0.4, help="minimum jerk-event prominence in (0, 1]")
    p.add_argument("--grace", type=size, default="auto", help="samples ignored at each end")
    p.add_argument("--stop-ratio", type=ratio_or_none, default=0.5,
                   help="keep a changepoint where the speed drops below this fraction of the movements' "
                        "peak speed ('none': keep every jerk event, as in the paper)")
    p.add_argument("--min-turn", type=float, default=45.0,
                   help="or where the direction turns by at least this many degrees")
    p.add_argument("--mode", choices=["deterministic", "sampling"], default="deterministic")
    p.add_argument("--seed", type=int, default=None, help="random seed for --mode sampling")


def add_constraint_options(p) -> None:
    """``--start``, ``--goal``, ``--via`` and ``--obstacle``, parsed by ``Constraints.from_cli``."""
    p.add_argument("--start", default=None, metavar="X,Y[,Z]", help="new initial point")
    p.add_argument("--goal", default=None, metavar="X,Y[,Z]", help="new final point")
    p.add_argument("--via", action="append", default=[], metavar="PHASE:X,Y[,Z]",
                   help="via-point at a phase in [0, 1] (repeatable)")
    p.add_argument("--obstacle", action="append", default=[], metavar="sphere:X,Y,Z,R|box:...",
                   help="region to avoid: sphere:X,Y[,Z],R or box:XMIN,YMIN[,ZMIN],XMAX,YMAX[,ZMAX] "
                        "(repeatable)")
    # Let coordinates such as "-25,3" through as values (argparse only knows "-25" as a number);
    # "--start=-25,3" works either way.
    p._negative_number_matcher = _NEGATIVE_COORDINATES
