"""Writer processes for the durability tests: forked, killed at any moment, never able to hang the parent."""

from __future__ import annotations

import multiprocessing

from tqdm import tqdm
from tqdm.std import TqdmDefaultWriteLock

_CTX = multiprocessing.get_context("fork")  # the targets are test functions, not importable by name


def _run(target, args):
    # A forked child shares the parent's tqdm write lock (a multiprocessing semaphore); killed while
    # it holds it (any progress bar, even a disabled one, takes it when made), the parent would wait
    # for it forever. A separate writer process, as in a lab, has its own lock: so does this one.
    TqdmDefaultWriteLock.mp_lock = _CTX.RLock()  # the class keeps one; a new instance would reuse it
    tqdm.set_lock(TqdmDefaultWriteLock())
    target(*args)


def writer_process(target, args=()) -> multiprocessing.Process:
    """A forked process that runs ``target(*args)`` with its own tqdm lock (not started)."""
    return _CTX.Process(target=_run, args=(target, args))
