"""The ``skillbank`` command line: one module per command, this one only assembles them."""

from __future__ import annotations

import argparse
import os
import sys

from ..core import __version__
from ..io import check_output_path
from . import _cluster, _demo, _edit, _experiment, _library, _plan, _segment, _sim, _simulate
from ._library_location import check_libraries
from ._options import join_negative_values
from ._output import check_overwrite, error_line, escaped_stdout

__all__ = ["main", "build_parser", "leaf_parsers"]

_COMMANDS = (_segment, _demo, _cluster, _experiment, _library, _edit, _plan, _simulate, _sim)


class _OneLineParser(argparse.ArgumentParser):
    """Usage errors as one line on stderr with exit status 2."""

    def error(self, message):
        # argparse quotes arguments as given: a password, a terminal escape
        self.exit(2, f"{self.prog}: error: {error_line(message)}\n")


def leaf_parsers(parser) -> dict:
    """Every command that runs something, by its full name (``"skillbank library add"``).

    Examples
    --------
    >>> sorted(leaf_parsers(build_parser()))[:2]
    ['skillbank cluster', 'skillbank demo']
    """
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        return {parser.prog: parser}
    return {name: leaf for sub in subs for child in dict.fromkeys(sub.choices.values())
            for name, leaf in leaf_parsers(child).items()}


def build_parser() -> argparse.ArgumentParser:
    """The argument parser for ``skillbank``."""
    parser = _OneLineParser(prog="skillbank", description="A library of motion primitives.")
    parser.add_argument("--version", action="version", version=f"skillbank {__version__}",
                        help="print 'skillbank <version>' and exit")
    sub = parser.add_subparsers(dest="command", required=True)
    for command in _COMMANDS:
        command.add_parser(sub)
    # Errors name the command that ran, sub-command included ("skillbank library add: error: ...").
    for name, leaf in leaf_parsers(parser).items():
        leaf.set_defaults(command_name=name)
    return parser


def _quiet_stdout() -> None:
    """Point stdout at the null device once its reader has gone (``skillbank ... | head``).

    Python flushes stdout again at exit, which would raise a second BrokenPipeError
    there; this is the recipe of the Python documentation (``signal``, "Note on SIGPIPE").
    """
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout without a file descriptor: nothing left to flush
        pass


#: The options that name a file or folder a command writes.
_OUTPUTS = ("out", "plot", "video", "view")


def _written(option: str, value) -> str:
    """The file an output option writes: its folder resolved (``./a``, ``d/../a``, a linked folder), its
    own name kept (a link there is replaced, not followed: ``io.atomic_output``); ``--plot`` without an
    extension writes ``.png`` (``plotting.figure_path``)."""
    path = os.path.abspath(os.fspath(value))
    folder, name = os.path.split(path)
    if option == "plot" and not os.path.splitext(name)[1]:
        name = name.rstrip(".") + ".png"
    return os.path.join(os.path.realpath(folder), name)


def _check_outputs(args) -> None:
    """Refuse an output that exists and is neither a regular file nor a folder, and one path given to two
    output options, before any work.

    Writing to a FIFO blocks and writing to a device clobbers it; each writer
    also checks (``io.atomic_output``), but only once the work is done. Two
    options on one path would write one file over the other.
    """
    seen: dict = {}
    for option in _OUTPUTS:
        value = getattr(args, option, None)
        if isinstance(value, (str, os.PathLike)):
            check_output_path(value, name=option)
            wheres = [_written(option, value)]
            if option == "plot" and getattr(args, "command_name", "") == "skillbank plan":
                stem = os.path.splitext(wheres[0])[0]  # its PDDL beside the figure (planning.write_pddl)
                wheres += [stem + ".domain.pddl", stem + ".problem.pddl"]
            for where in wheres:
                if where in seen:
                    raise ValueError(f"{option}: {os.fspath(value)!r} writes {where!r}, which "
                                     f"--{seen[where]} writes too; give each output its own file")
                seen[where] = option


def main(argv=None) -> int:
    """Entry point; returns the exit status (2 on bad input, 0 when the reader closes the pipe)."""
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(join_negative_values(sys.argv[1:] if argv is None else argv))
        except SystemExit:
            sys.stdout.flush()  # --help and --version: a closed pipe is handled below, not at exit
            raise
        try:
            _check_outputs(args)
            check_overwrite(args)
            check_libraries(args)
            with escaped_stdout():  # user-given text (labels, file names) without raw terminal escapes
                status = int(args.func(args) or 0)
        except (ValueError, ImportError, OSError) as exc:
            if isinstance(exc, BrokenPipeError):
                raise
            print(f"{args.command_name}: error: {error_line(exc, args)}", file=sys.stderr)
            return 2
        sys.stdout.flush()  # here, where a closed pipe can still be handled, not at exit
        return status
    except BrokenPipeError:
        # The reader wanted no more output (``| head``): not an error.
        _quiet_stdout()
        return 0
