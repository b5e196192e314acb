"""The command line: ``skillbank segment | demo | cluster | experiment | library | edit``."""

from ._main import build_parser, main

__all__ = ["main", "build_parser"]
