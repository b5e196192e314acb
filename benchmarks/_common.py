"""Helpers shared by the benchmark scripts: where the data is, best-of-n timing, timed subprocesses."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import NamedTuple

__all__ = ["data_dir", "best_of", "ChildRun", "run_child"]


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


class ChildRun(NamedTuple):
    """One finished subprocess: wall-clock seconds, peak resident memory (MB), exit status, stderr."""

    seconds: float
    max_rss_mb: float
    returncode: int
    stderr: str
    rss_from: str  # "GNU time" or "wait4"


_GNU_TIME = Path("/usr/bin/time")


def run_child(cmd, *, stdout=None, env=None, cwd=None) -> ChildRun:
    """Run ``cmd`` to the end: its wall-clock time, its peak RSS and its exit status.

    ``stdout`` is a path the child's output is written to (default: discarded); stderr is
    returned. The time runs from just before the process is created to just after it is
    reaped, so it includes the interpreter's start-up.

    The peak RSS comes from GNU ``/usr/bin/time -f %M`` when it exists (adds the start of one
    small process, about a millisecond, to the time). Without it, it is ``ru_maxrss`` from
    ``os.wait4``, which on Linux also counts the pages the child shared with this process
    between fork and exec: a floor of this process's own RSS. ``resource.getrusage
    (RUSAGE_CHILDREN)`` is no better: it is the largest over all children so far. POSIX only.
    """
    cmd = [str(c) for c in cmd]
    with contextlib.ExitStack() as stack:
        out = stack.enter_context(open(stdout, "wb")) if stdout is not None else subprocess.DEVNULL
        err = stack.enter_context(tempfile.TemporaryFile())
        rss_file = None
        if _GNU_TIME.is_file():
            rss_file = Path(stack.enter_context(tempfile.TemporaryDirectory())) / "rss"
            cmd = [str(_GNU_TIME), "-f", "MAXRSS_KB %M", "-o", str(rss_file), *cmd]
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=out, stderr=err, env=env, cwd=cwd)
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.perf_counter() - start
        proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here; Popen must not wait again
        err.seek(0)
        stderr = err.read().decode("utf-8", errors="replace")
        rss_kb = None
        if rss_file is not None and rss_file.is_file():
            found = [line.split()[1] for line in rss_file.read_text().splitlines()
                     if line.startswith("MAXRSS_KB ")]
            rss_kb = int(found[-1]) if found else None
    if rss_kb is not None:
        return ChildRun(seconds, rss_kb / 1024, proc.returncode, stderr, "GNU time")
    rss_bytes = usage.ru_maxrss * (1 if sys.platform == "darwin" else 1024)  # macOS: bytes; Linux: KiB
    return ChildRun(seconds, rss_bytes / 2**20, proc.returncode, stderr, "wait4")


def skillbank(*args) -> str:
    """Run ``skillbank ARGS`` as a user does (a child process); its stdout, or exit naming the command."""
    done = subprocess.run([sys.executable, "-m", "skillbank.cli", *map(str, args)], capture_output=True,
                          text=True)
    if done.returncode != 0:
        raise SystemExit(f"skillbank {' '.join(map(str, args))}: {done.stderr.strip()}")
    return done.stdout


def robosuite_library(folder: Path, task: str, seed: int, demos: int) -> Path:
    """A library of ``demos`` scripted robosuite demonstrations of ``task`` from ``seed``, clustered."""
    data, db = folder / f"{task}.hdf5", folder / f"{task}.db"
    skillbank("sim", "record", f"robosuite:{task}", "--episodes", demos, "--seed", seed, "--out", data)
    skillbank("library", "init", db)
    skillbank("library", "add", db, data, "--assign", "recluster")
    return db
