"""Preparing inputs for a library, here or on Dask workers, and writing them in batches.

Preparing a file is everything an add does but the write: read it, check
every demonstration, cut it (:class:`~skillbank.segmentation.MultimodalSegmenter`)
and, with ``assign="incremental"``, featurise its primitives with the current
clustering's stored featuriser and find their nearest centres. It needs no
store: the clustering it assigns to travels as a *snapshot* (the version's
parameters, centres and PCA arrays), so the same function runs in this
process (:meth:`Library.add_files`) and in a Dask worker (:func:`add_in_parallel`).

:func:`add_in_parallel` sends tasks of a few consecutive files (at most 16,
:func:`files_per_task`) to a Dask cluster, a local one (``workers=N``:
``distributed.LocalCluster``, one single-threaded process per worker) or an
existing one (``scheduler``: its address or a ``distributed.Client``), at most
twice as many tasks as the cluster has threads in flight, and writes the
results in this process, through the store, in the order of the inputs (so
the ids are those an add without workers gives):

- ``keep_going=True``: as results arrive, every ``batch_size`` demonstrations
  (whole files) are written in one transaction. Memory stays bounded (the
  files in flight and one batch); a worker that dies loses nothing committed
  and leaves nothing partial, since workers never write; a failed file is
  set aside with its reason, as without workers.
- ``keep_going=False`` (all or nothing, as without workers): every file is
  prepared first and everything is written in one transaction at the end;
  the first bad file cancels the rest and nothing is added. The prepared
  demonstrations are held until then, as without workers.

A task whose worker dies (a crash, or the nanny killing it for memory) is
rescheduled by Dask on another worker, up to the scheduler's
``distributed.scheduler.allowed-failures`` times (default 3). A task of
several files that still fails (``KilledWorker``) is sent again one file per
task, so that only the file that kills workers fails: with ``keep_going`` it
is set aside, else nothing is added. Files are read by the workers: on a
cluster of several machines they must see the same paths (a shared file
system).
"""

from __future__ import annotations

from pathlib import Path

from tqdm import tqdm

# Clustering, segmentation and selection import scikit-learn and scipy: each function that needs them
# imports them, so that a Library opened to list or export does not (tests/cli/test_light_imports.py).
from ..core import Demonstration, __version__
from ..core._dask import DIED, INSTALL, check_parallel, dask_client
from ..core._dask import distributed as dask_distributed
from ..core._validation import check_positive
from ..io import FormatError, load, load_all

__all__ = ["INSTALL", "check_demo", "file_reason", "read_file", "bounds", "assignment", "prepare",
           "prepare_file", "prepare_files", "files_per_task", "distributed", "add_in_parallel", "BATCH_SIZE"]

#: Demonstrations written per transaction by a parallel add with keep_going (whole files).
BATCH_SIZE = 50


def check_demo(demo, name):
    if not isinstance(demo, Demonstration):
        raise ValueError(f"{name}: expected a Demonstration, got {type(demo).__name__}")
    if "position" not in demo.streams:
        hint = ""
        if demo.metadata.get("format") == "lerobot" and demo.stream_names:
            # A LeRobot dataset names its features itself: say how to read one of them as the position.
            feature = next((s for s in demo.stream_names if "state" in s), demo.stream_names[0])
            hint = (f"; read one feature as the position: --feature {feature}=position "
                    f"(reader_options={{'features': ['{feature}=position']}})")
        raise ValueError(f"{name}: expected a 'position' stream, got streams {demo.stream_names}{hint}")


def file_reason(exc, path) -> str:
    """What went wrong with a file, without repeating its name (the caller gives it).

    Examples
    --------
    >>> file_reason(FormatError("a.csv", "no time column"), "a.csv")
    'cannot read it: no time column'
    """
    if isinstance(exc, FormatError) and Path(exc.path) == Path(path):
        return f"cannot read it: {exc.reason}"
    return " ".join(str(exc).split())


def read_file(path, *, source=None, index=None, group="normalized", repair_time=None, reader_options=None):
    """Every demonstration of a file (only ``index`` if given), checked, with ``source`` (default: path)."""
    demos = [load(path, index=index, group=group, repair_time=repair_time, reader_options=reader_options)] \
        if index is not None else load_all(path, group=group, repair_time=repair_time,
                                           reader_options=reader_options)
    for k, demo in enumerate(demos):
        check_demo(demo, "demonstration" if len(demos) == 1 else f"demonstration {k}")
        demo.metadata.setdefault("source", str(path if source is None else source))
    return demos


def bounds(demo, segment, segmentation):
    """``(bounds, provenance)``: the segmenter's cut of ``demo``, or the whole of it.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 1.0, 30)
    >>> bounds(Demonstration.from_array(np.column_stack([t, t]), t), False, None)
    ([(0, 30)], {'segment': False})
    """
    if not segment:
        return [(0, demo.n_steps)], {"segment": False}
    from ..segmentation import MultimodalSegmenter  # scipy, only when a demonstration is cut

    params = dict(segmentation or {})
    streams = params.pop("streams", None)
    result = MultimodalSegmenter(**params).fit(demo, streams).result_
    # the streams without information that took no part in the cut, and why (none: no key)
    aside = {"set_aside": dict(result.set_aside)} if result.set_aside else {}
    # each cut with the streams that supported it and their evidence there (the library's web view shows it)
    support = [{"at": int(k), "streams": s} for k, s in zip(result.keypoints, result.keypoint_support,
                                                             strict=True)]
    return result.bounds, {"segment": True, "method": "skillbank.segmentation.MultimodalSegmenter",
                           "streams": streams, "requested": params, "resolved": result.params,
                           "mode": result.mode, "skillbank_version": __version__, "cut_support": support,
                           **aside}


def assignment(parts, snapshot):
    """``(members, None)`` in the clustering ``snapshot`` for primitive samples ``parts``, or ``(None, why)``.

    ``snapshot`` is a clustering version as the store gives it
    (:meth:`~skillbank.store.Store.version`), or None before any (then ``why``
    is None too).

    Examples
    --------
    >>> assignment([], None)
    (None, None)
    """
    if snapshot is None:
        return None, None
    version, p = snapshot["version"], snapshot["params"]
    dims = sorted({part["position"].shape[1] for part in parts})
    fitted = p.get("n_dims")  # recorded by cluster() from this release on; older: the width check below
    if fitted is not None and dims != [fitted]:
        return None, (f"its positions have {', '.join(map(str, dims))} dimension(s), clustering version "
                      f"{version} was fitted on {fitted}-D positions")
    from ..clustering import nearest_centre, primitive_features  # scikit-learn, only to assign

    try:
        F = primitive_features(parts, kind=p["features"], n_points=p["n_points"])
    except ValueError as exc:
        return None, f"clustering version {version} cannot featurise it: {exc}"
    width = snapshot["pca_mean"].shape[0]
    if F.shape[1] != width:
        return None, (f"its {F.shape[1]} features do not match the {width} of clustering version "
                      f"{version} (fitted on positions of another number of dimensions)")
    X = (F - snapshot["pca_mean"]) @ snapshot["pca_components"].T
    clusters = nearest_centre(X, snapshot["centers"]).tolist()
    return {"version": version, "clusters": clusters, "features": X}, None


def set_aside(written, prepared) -> dict:
    """``{demonstration id: {stream: reason}}`` of the streams the segmenter set aside as constant."""
    pairs = zip(written, prepared, strict=True)
    return {did: item["provenance"]["set_aside"] for (did, _), (item, _) in pairs
            if "set_aside" in item["provenance"]}


def relations(demo, cuts) -> list:
    """What each primitive acts on (:func:`~skillbank.selection.acted_on`), as JSON, one per cut.

    Kept in the demonstration's provenance, so the library, its exports and its imports carry it with the
    primitives; values are rounded to the nanometre (and 1e-9 of a quaternion) so that the same samples
    give the same record on any worker.
    """
    from ..selection import acted_on  # scipy, only for object poses

    out = []
    for a, b in cuts:
        r = acted_on(demo.slice(a, b))
        out.append(None if r is None else _rounded(r.to_dict()))
    return out


def _rounded(doc):
    if isinstance(doc, dict):
        return {k: _rounded(v) for k, v in doc.items()}
    if isinstance(doc, list):
        return [_rounded(v) for v in doc]
    return round(doc, 9) if isinstance(doc, float) else doc


def prepare(demo, *, segment, segmentation, label, source, assign, snapshot) -> tuple:
    """``(store item, why it stays unclustered or None)``: everything but the write."""
    cuts, provenance = bounds(demo, segment, segmentation)
    src = source if source is not None else demo.metadata.get("source")
    task = demo.metadata.get("task")
    if label is None and isinstance(task, str) and task.strip():
        # The recording says what it shows (a LeRobot episode's task): its primitives' own label, as if given.
        label, provenance["label_from"] = task.strip(), "metadata['task']"
    from ..selection import object_streams  # scipy, only when a demonstration is prepared

    if object_streams(demo):
        provenance["relations"] = relations(demo, cuts)
    members, why = None, None
    if assign == "incremental":
        members, why = assignment([demo.slice(a, b) for a, b in cuts], snapshot)
    if why is not None:
        provenance["assignment"] = {"version": snapshot["version"], "clustered": False, "reason": why}
    item = {"demo": demo, "bounds": cuts, "source": None if src is None else str(src), "label": label,
            "provenance": provenance, "members": members}
    return item, why


def prepare_file(path, source, read: dict, options: dict, snapshot):
    """A Dask task: ``([(item, why) per demonstration], None)``, or ``(None, reason)`` for a bad file.

    A file is bad when it cannot be read or one of its demonstrations cannot
    be cut: the reason is what :meth:`Library.add_files` reports for it.
    """
    try:
        demos = read_file(path, source=source, **read)
    except (ValueError, OSError) as exc:
        return None, file_reason(exc, path)
    items = []
    try:
        for demo in demos:
            items.append(prepare(demo, source=None, snapshot=snapshot, **options))
    except ValueError as exc:  # raised by the demonstration after the last one prepared
        return None, ("" if len(demos) == 1 else f"demonstration {len(items)}: ") + file_reason(exc, path)
    return items, None


def prepare_files(files, read: dict, options: dict, snapshot) -> list:
    """A Dask task: :func:`prepare_file` of each ``(path, source)`` of ``files``, in order.

    Several files per task: each task costs a few round trips between the
    client, the scheduler and a worker, much more than cutting one short
    demonstration when a worker's event loop waits for the lock its
    computation holds.
    """
    return [prepare_file(path, source, read, options, snapshot) for path, source in files]


def files_per_task(n_files: int, n_threads: int) -> int:
    """Files in one task: at most 16, and at least 8 tasks per worker thread for an even load.

    Examples
    --------
    >>> files_per_task(10_000, 8), files_per_task(100, 2), files_per_task(5, 2)
    (16, 6, 1)
    """
    return int(min(16, max(1, n_files // (8 * max(1, n_threads)))))


def distributed():
    """The ``distributed`` module; a one-line ImportError saying what to install when it is missing."""
    return dask_distributed("parallel adds")


def add_in_parallel(lib, paths, *, read: dict, options: dict, keep_going: bool, progress: bool,
                    workers=None, scheduler=None, batch_size: int = BATCH_SIZE, chunk=None) -> dict:
    """Prepare ``paths`` on Dask and write them into ``lib``'s store (see the module docstring).

    ``read`` and ``options`` are :func:`read_file`'s and :func:`prepare`'s
    keyword arguments; ``chunk`` is the number of files per task (default
    :func:`files_per_task`). At most twice as many tasks as the cluster has
    threads (at least 4) are in flight. Returns the report of
    :meth:`Library.add_files`, with ``"scheduler"``: the cluster's address.
    """
    workers = check_parallel(workers, scheduler)
    batch_size = check_positive(batch_size, name="batch_size", integer=True)
    if chunk is not None:
        chunk = check_positive(chunk, name="chunk", integer=True)
    dist = distributed()
    snapshot = lib._snapshot() if options["assign"] == "incremental" else None
    # the absolute path for a worker in another folder; the source recorded is the path as given
    files = [(str(Path(p).absolute()), str(p)) for p in paths]
    with dask_client(dist, workers, scheduler) as client:
        threads = sum(client.nthreads().values())
        job = _Job(lib, client, dist, files, (read, options, snapshot), keep_going=keep_going,
                   batch_size=batch_size, chunk=chunk or files_per_task(len(files), threads),
                   window=max(4, 2 * threads))
        return job.run(progress)


class _Job:
    """One parallel add: tasks of consecutive files in flight, results written in the order of the files."""

    def __init__(self, lib, client, dist, files, args, *, keep_going, batch_size, chunk, window):
        self.lib, self.client, self.dist, self.files, self.args = lib, client, dist, files, args
        self.keep_going, self.batch_size, self.chunk, self.window = keep_going, batch_size, chunk, window
        self.report = {"demonstrations": [], "primitives": [], "failed": {}, "unclustered": {},
                       "set_aside": {}, "version": None, "scheduler": client.scheduler.address}
        self.pending, self.done, self.inflight = [], {}, {}
        # keep_going with a recluster: batches are written as they come, so a file of another dimension
        # than the library's (the stored primitives', else the first file's) is set aside, not written
        self.one_dimension = keep_going and args[1]["assign"] == "recluster"
        stored = {p.demo["position"].shape[1] for p in lib.store.primitives(load=True)} \
            if self.one_dimension else set()
        self.dimension = next(iter(stored)) if len(stored) == 1 else None
        self.queue = dist.as_completed(loop=client.loop)
        self.submitted = self.consumed = 0

    def submit(self, first: int, count: int) -> None:
        future = self.client.submit(prepare_files, self.files[first:first + count], *self.args, pure=False)
        self.inflight[future.key] = (first, count, future)
        self.queue.add(future)

    def top_up(self) -> None:
        while self.submitted < len(self.files) and len(self.inflight) < self.window:
            count = min(self.chunk, len(self.files) - self.submitted)
            self.submit(self.submitted, count)
            self.submitted += count

    def flush(self) -> None:
        if self.pending and not self.keep_going and self.args[1]["assign"] == "recluster":
            try:  # all or nothing: what the recluster after this write would refuse, before it
                self.lib._check_recluster([item for item, _ in self.pending])
            except ValueError as exc:
                raise ValueError(f"{exc}; nothing was added") from None
        if self.pending:
            written = self.lib.store.add_demonstrations([item for item, _ in self.pending])
            self.report["demonstrations"] += [did for did, _ in written]
            self.report["primitives"] += [pids for _, pids in written]
            self.report["unclustered"].update({did: why for (did, _), (_, why)
                                               in zip(written, self.pending, strict=True) if why is not None})
            self.report["set_aside"].update(set_aside(written, self.pending))
            self.pending.clear()

    def collect(self, future, bar) -> None:
        """Take a finished task's results; a task whose workers all died is retried one file per task."""
        first, count, _ = self.inflight.pop(future.key)
        try:
            results = future.result()
        except self.dist.KilledWorker:
            if count > 1:  # find the file that kills workers: the others in its task are innocent
                for k in range(first, first + count):
                    self.submit(k, 1)
                return
            results = [(None, DIED.format(doing="preparing it"))]
        finally:
            future.release()
        self.done.update(zip(range(first, first + count), results, strict=True))
        bar.update(count)

    def write_ready(self, bar) -> None:
        """Results of the next files, in order: set aside the failed ones, write a batch when it is full."""
        while self.consumed in self.done:
            items, reason = self.done.pop(self.consumed)
            path = self.files[self.consumed][1]
            self.consumed += 1
            if reason is not None:
                if not self.keep_going:
                    raise ValueError(f"{path}: {reason}; nothing was added")
                self.report["failed"][path] = reason
                continue
            if self.one_dimension and items:
                dims = sorted({item["demo"]["position"].shape[1] for item, _ in items})
                self.dimension = dims[0] if self.dimension is None else self.dimension
                other = [d for d in dims if d != self.dimension]
                if other:
                    self.report["failed"][path] = (f"its positions are {other[0]}-D, the library's are "
                                                   f"{self.dimension}-D: one clustering cannot mix them")
                    continue
            self.pending.extend(items)
            if self.keep_going and len(self.pending) >= self.batch_size:
                self.flush()
                bar.set_postfix_str(f"{len(self.report['demonstrations'])} demonstration(s) written")

    def run(self, progress: bool) -> dict:
        try:
            self.top_up()
            with tqdm(total=len(self.files), desc="adding", unit="file", disable=not progress) as bar:
                for future in self.queue:
                    self.collect(future, bar)
                    self.write_ready(bar)
                    self.top_up()
                self.flush()  # keep_going: the last batch; all or nothing: everything, in one transaction
        finally:
            self.queue.clear()
            if self.inflight:  # stopped early: the files still being prepared are not wanted
                self.client.cancel([future for _, _, future in self.inflight.values()])
        return self.report
