"""Work on a Dask cluster, a new local one or an existing one: its client, and tasks gathered in order.

Two kinds of work run here: a parallel add (``skillbank.pipeline._parallel``:
reading and cutting files) and parallel episodes (``skillbank.simulation._episodes``:
robosuite scenes, each from its seed). Both name the cluster the same way:

- ``workers=N``: a new ``distributed.LocalCluster`` of ``N`` single-threaded
  worker processes on this machine (at most :func:`~skillbank.core._cluster_address.max_workers`);
- ``scheduler``: an existing cluster, by its scheduler's address (checked and
  probed first, :func:`~skillbank.core._cluster_address.probe_scheduler`) or a
  ``distributed.Client``.

Dask (the ``dask`` extra) is imported only when a cluster is asked for.
:func:`map_in_order` runs one function over items there and returns the
results in the order of the items, whatever order they finish in; a worker
that dies takes the task back to the scheduler, which gives it to another one
up to ``distributed.scheduler.allowed-failures`` times (default 3), after which
the whole run fails with one line naming the item (nothing partial is returned).
"""

from __future__ import annotations

import contextlib
import logging

from ._cluster_address import check_workers, connect_timeout, probe_scheduler
from ._validation import check_positive

__all__ = ["INSTALL", "distributed", "dask_config", "check_parallel", "dask_client", "map_in_order", "DIED"]

INSTALL = "pip install 'skillbank[dask]'"
#: What a task whose workers all died says (after the item's name).
DIED = ("the Dask worker {doing} died, and again on every retry (a crash, or more memory than a worker "
        "has)")


def distributed(what: str = "parallel work"):
    """The ``distributed`` module; a one-line ImportError saying ``what`` needs it and what to install."""
    try:
        import distributed as module  # optional: the dask extra, only for work on a cluster
    except ImportError:
        raise ImportError(f"{what} (workers, scheduler) need Dask: {INSTALL}") from None
    return module


def dask_config():
    """``dask.config`` (installed with ``distributed``)."""
    import dask.config  # optional: the dask extra, only for work on a cluster

    return dask.config


def check_parallel(workers=None, scheduler=None):
    """``workers`` checked (an integer > 0 within the machine's bound), or None; never both it and scheduler.

    The scheduler's address is checked when its client is made (:func:`dask_client`).

    Examples
    --------
    >>> check_parallel(2), check_parallel(None, "tcp://h:8786")
    (2, None)
    >>> check_parallel(1, "tcp://h:8786")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: workers: give workers (a new local cluster) or scheduler (an existing one), not both; ...
    """
    if workers is not None and scheduler is not None:
        raise ValueError(f"workers: give workers (a new local cluster) or scheduler (an existing one), not "
                         f"both; got workers={workers!r} and scheduler={scheduler!r}")
    if workers is not None:
        workers = check_workers(check_positive(workers, name="workers", integer=True))
    return workers


@contextlib.contextmanager
def dask_client(dist, workers=None, scheduler=None, *, verbose: bool = False):
    """A ``distributed.Client`` on a new local cluster of ``workers`` processes, or on ``scheduler``.

    ``dist`` is the ``distributed`` module (:func:`distributed`). A local
    cluster's logs below ERROR are off unless ``verbose`` (its workers'
    start and stop, a restarted worker's warnings).
    """
    if isinstance(scheduler, dist.Client):
        yield scheduler
        return
    if scheduler is not None:
        probe_scheduler(scheduler)  # fails fast, before Dask's client waits or misreads another protocol
        try:
            client = dist.Client(scheduler, set_as_default=False, timeout=connect_timeout())
        except Exception as exc:  # whatever the peer did: one line, never Dask's traceback
            raise OSError(f"scheduler: cannot reach the Dask scheduler at {scheduler!r}: "
                          f"{' '.join(str(exc).split()) or type(exc).__name__}") from None
        with client:
            yield client
        return
    # One single-threaded process per worker: the work holds the GIL, so threads would not help.
    # A worker holds one task at a time, so one that dies takes no other task down with it.
    # Dask's statistical profiler walks the running task's stack every 10 ms: on robosuite's deep stacks
    # that cost a quarter of the work (8 Lift episodes on one worker: 25.1 CPU seconds with it, 20.3
    # without, 18.8 in one process), for a dashboard nobody looks at here.
    with dask_config().set({"distributed.scheduler.worker-saturation": 1.0,
                            "distributed.worker.profile.enabled": False}):
        cluster = dist.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                    dashboard_address=":0",
                                    silence_logs=logging.INFO if verbose else logging.ERROR)
    with cluster, dist.Client(cluster, set_as_default=False) as client:
        yield client


def map_in_order(function, items, *, workers=None, scheduler=None, what: str = "parallel work",
                 name=repr, doing: str = "running it", progress=None, verbose: bool = False,
                 window=None) -> tuple:
    """``([function(item) for item in items], scheduler address)``, each call a task on a Dask cluster.

    Parameters
    ----------
    function : callable
        Called once per item on a worker; it and the items travel to the workers by pickle with each
        task (a function of a module is sent by its name: the workers must be able to import it). A
        task carries all it needs, so a worker that dies loses nothing another cannot redo.
    items : sequence
    workers, scheduler
        The cluster (see the module docstring); exactly one is given.
    what : str
        The work, for the one-line error when Dask is missing ("parallel episodes").
    name : callable
        ``name(item)``: how an error names the item whose workers all died ("episode of seed 503").
    doing : str
        What the dead worker was doing with it ("running it").
    progress : callable, optional
        ``progress(index, result)`` as each task finishes (in the order they finish).
    verbose : bool, default=False
        Let a local cluster's log lines below ERROR through.
    window : int, optional
        Tasks in flight at once (default: the cluster's threads, so that a worker holds only the task
        it runs, and a worker that dies takes only that one down). More are sent as tasks finish; what
        waits here costs the scheduler nothing.

    Returns
    -------
    tuple
        The results in the order of ``items``, and the scheduler's address.

    Raises
    ------
    ValueError
        A task whose workers all died: ``"{name(item)}: the Dask worker running it died, ..."``. The
        other tasks are cancelled and no result is returned.
    Exception
        What ``function`` raised on a worker, as it raised it; the other tasks are cancelled.

    Examples
    --------
    >>> map_in_order(abs, [-2, 3], workers=0)
    Traceback (most recent call last):
    ...
    ValueError: workers: expected an integer > 0, got 0
    """
    workers = check_parallel(workers, scheduler)
    if workers is None and scheduler is None:
        raise ValueError("workers: give workers (a new local cluster) or scheduler (an existing one)")
    if window is not None:
        window = check_positive(window, name="window", integer=True)
    dist = distributed(what)
    items = list(items)
    results = [None] * len(items)
    with dask_client(dist, workers, scheduler, verbose=verbose) as client:
        window = window or max(1, sum(client.nthreads().values()))
        queue = dist.as_completed(loop=client.loop)
        inflight = {}

        def top_up(sent):
            while sent < len(items) and len(inflight) < window:
                future = client.submit(function, items[sent], pure=False)
                inflight[future.key] = (sent, future)
                queue.add(future)
                sent += 1
            return sent

        try:
            sent = top_up(0)
            for future in queue:
                k, _ = inflight.pop(future.key)
                try:
                    results[k] = future.result()
                except dist.KilledWorker:
                    raise ValueError(f"{name(items[k])}: " + DIED.format(doing=doing)) from None
                finally:
                    future.release()
                if progress is not None:
                    progress(k, results[k])
                sent = top_up(sent)
        finally:
            queue.clear()
            if inflight:  # stopped early (an error, an interrupt): the tasks still running are not wanted
                client.cancel([future for _, future in inflight.values()])
        return results, client.scheduler.address
