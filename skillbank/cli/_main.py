"""The ``skillbank`` command line: one module per command, this one only assembles them."""

from __future__ import annotations

import argparse
import sys

from . import _cluster, _demo, _edit, _experiment, _library, _segment
from ._options import join_negative_values

__all__ = ["main", "build_parser"]

_COMMANDS = (_segment, _demo, _cluster, _experiment, _library, _edit)


class _OneLineParser(argparse.ArgumentParser):
    """Usage errors as one line on stderr with exit status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser for ``skillbank``."""
    parser = _OneLineParser(prog="skillbank", description="A library of motion primitives.")
    sub = parser.add_subparsers(dest="command", required=True)
    for command in _COMMANDS:
        command.add_parser(sub)
    return parser


def main(argv=None) -> int:
    """Entry point; returns the exit status (2 on bad input)."""
    parser = build_parser()
    args = parser.parse_args(join_negative_values(sys.argv[1:] if argv is None else argv))
    try:
        return int(args.func(args) or 0)
    except (ValueError, ImportError, OSError) as exc:
        message = " ".join(str(exc).split())
        print(f"skillbank {args.command}: error: {message}", file=sys.stderr)
        return 2
