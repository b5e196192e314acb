"""Command-line interface: ``skillbank segment``, ``skillbank demo``."""

from ._main import build_parser, main

__all__ = ["main", "build_parser"]
