"""Helpers shared by the benchmark scripts: where the data is, and best-of-n timing."""

from __future__ import annotations

import os
import time
from pathlib import Path

__all__ = ["data_dir", "best_of"]


def data_dir(arg=None) -> Path:
    """``arg`` if given, else ``$SKILLBANK_DATA``, else ``../shared/data`` beside the repository."""
    if arg is not None:
        return Path(arg)
    env = os.environ.get("SKILLBANK_DATA")
    return Path(env) if env else (Path(__file__).resolve().parents[1] / ".." / "shared" / "data").resolve()


def best_of(fn, repeats: int) -> tuple[float, object]:
    """The shortest of ``repeats`` wall-clock times of ``fn()`` (``time.perf_counter``), and its result."""
    best, out = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out
