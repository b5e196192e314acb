"""Episodes of robosuite scenes, in this process or on Dask workers, reported in seed order.

``sim evaluate``, ``plan --scene robosuite:TASK --simulate`` and the
composition experiments run many episodes that share nothing: each one builds
its own environment from its seed (robosuite's sampler places the objects
from it), runs, and closes the environment. An episode is a function of its
seed alone, so the episodes can run anywhere, in any order, and the report
is the same as long as the rows are put back in seed order:
:func:`run_episodes` runs them here, one after the other, or on a Dask
cluster (``workers``: a new local one; ``scheduler``: an existing one, whose
workers have ``skillbank[sim]``) through :func:`skillbank.core._dask.map_in_order`,
the one place that makes a cluster and gathers its tasks in order for a
parallel add as well.

On a worker the episode runs as it does here: robosuite's log and its lines on
stdout are off (on stderr with ``verbose``), and the worker's own stdout is
pointed at stderr, so that what a worker prints never mixes with the
command's report. A worker that dies is replaced by Dask and its episode run
again; an episode whose workers all died fails the whole run with one line
naming its seed: no report is made of the others.
"""

from __future__ import annotations

import contextlib
import copy
import io
import logging
import os
import sys
from functools import partial

from ..core._cluster_address import check_scheduler
from ..core._dask import check_parallel, map_in_order
from ._human_file import quiet_robosuite

__all__ = ["run_episodes", "check_episode_cluster", "fresh"]


def check_episode_cluster(workers=None, scheduler=None):
    """``workers`` checked against ``scheduler``, before any episode or recording (:func:`run_episodes`)."""
    if scheduler is not None and isinstance(scheduler, str):
        check_scheduler(scheduler)  # its syntax now; it is reached when the episodes start
    return check_parallel(workers, scheduler)


@contextlib.contextmanager
def _verbose_robosuite():
    """robosuite's log through (the root logger at INFO, as its importer asks) and its lines on stderr."""
    root = logging.getLogger()
    level = root.level
    root.setLevel(min(level or logging.INFO, logging.INFO))
    logging.getLogger("robosuite_logs").disabled = False
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        root.setLevel(level)


def _quietly(episode, verbose, job, seed):
    """``episode(job, seed)`` with robosuite's log off (on, to stderr, with ``verbose``), and the linear
    algebra libraries on one thread, as Dask's workers run them.

    A Dask worker's process starts with one BLAS and OpenMP thread (its nanny sets ``OMP_NUM_THREADS``,
    ``OPENBLAS_NUM_THREADS`` and ``MKL_NUM_THREADS`` to 1); a product split over threads adds in another
    order, the last bits differ, and a contact-rich episode amplifies them into another outcome (a
    human-like PickPlace on the Panda, seed 920: the tool 3 cm short at its seventh segment on a worker,
    a link on the bin's wall at its fifth here). On one thread here too, an episode is the same function
    of its seed in this process and on any worker.
    """
    from threadpoolctl import threadpool_limits  # scikit-learn's own dependency

    with threadpool_limits(limits=1), (_verbose_robosuite() if verbose else quiet_robosuite()):
        return episode(job, seed)


def _on_worker(episode, verbose, home, job, seed):
    """A Dask task: one episode; a worker's stdout (shared with the command that started the cluster,
    whose report it is) goes to stderr, whatever writes to it, Python or C. A worker thread in the
    process ``home`` that asked for the episodes (a cluster of threads) leaves its stdout alone."""
    if os.getpid() != home:
        with contextlib.suppress(OSError, ValueError, io.UnsupportedOperation):
            sys.stdout.flush()
            os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    return _quietly(episode, verbose, job, seed)


def run_episodes(episode, job, seeds, *, workers=None, scheduler=None, progress=None, verbose: bool = False):
    """``([episode(job, seed) for seed in seeds], scheduler address or None)``: here, or on Dask.

    Parameters
    ----------
    episode : callable
        ``episode(job, seed) -> (row, ...)``, ``row`` a dict with ``"success"``: a function of a module
        (the workers import it by its name). It must build everything it uses from ``job`` and its
        seed; nothing it changes may outlive the call.
    job : object
        What every episode needs (the library's demonstrations, the options): sent with each task, so
        that an episode whose worker died can run on another.
    seeds : sequence of int
    workers : int, optional
        Run on a new local Dask cluster of this many worker processes.
    scheduler : str or distributed.Client, optional
        Run on an existing Dask cluster (``tcp://HOST:PORT``). Neither: here, one episode after the other.
    progress : callable, optional
        ``progress(done, successes)`` after each episode (as they finish).
    verbose : bool, default=False
        robosuite's and a local cluster's log lines through (to stderr).

    Returns
    -------
    tuple
        The episodes' results in the order of ``seeds``, and the scheduler's address (None here).

    Examples
    --------
    >>> def episode(job, seed):
    ...     return {"seed": seed, "success": seed % job == 0}, None
    >>> rows, where = run_episodes(episode, 2, [4, 5])
    >>> [(r["seed"], r["success"]) for r, _ in rows], where
    ([(4, True), (5, False)], None)
    """
    seeds = [int(s) for s in seeds]
    done = {"n": 0, "successes": 0}

    def tick(_index, result):
        done["n"] += 1
        done["successes"] += bool(result[0]["success"])
        if progress is not None:
            progress(done["n"], done["successes"])

    if check_episode_cluster(workers, scheduler) is None and scheduler is None:
        results = []
        for seed in seeds:
            results.append(_quietly(episode, verbose, job, seed))
            tick(len(results) - 1, results[-1])
        return results, None
    return map_in_order(partial(_on_worker, episode, verbose, os.getpid(), job), seeds, workers=workers,
                        scheduler=scheduler, what="parallel episodes",
                        name=lambda seed: f"episode of seed {seed}", progress=tick, verbose=verbose)


def fresh(value):
    """An episode's own copy of ``value`` (a random generator: the same state for every episode, here as on
    a worker, where it arrives by pickle)."""
    return copy.deepcopy(value)
