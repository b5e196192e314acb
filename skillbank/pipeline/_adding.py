"""Adding to a library: read, validate and segment every demonstration first, then write them in one go.

The adding half of :class:`skillbank.pipeline.Library` (a mixin: it uses the
library's ``store`` and ``cluster``). A batch is all or nothing: nothing is
written until every file is read and every demonstration is cut (and
assigned), and then everything is written in one transaction of the store
(:meth:`skillbank.store.Store.add_demonstrations`). ``keep_going`` instead
sets every failing file aside with its reason and adds the rest, still in one
transaction.
"""

from __future__ import annotations

import warnings
from pathlib import Path

from tqdm import tqdm

from ._parallel import (
    BATCH_SIZE,
    add_in_parallel,
    assignment,
    check_demo,
    file_reason,
    prepare,
    read_file,
    set_aside,
)

__all__ = ["Adding", "ASSIGN", "check_label"]

ASSIGN = ("incremental", "none", "recluster")
#: Parameters of the current clustering that a recluster after an add keeps.
_RECLUSTER_KEEPS = ("stretch", "features", "n_points", "n_components", "random_state")


def check_one_dimension(prims, items=()) -> None:
    """One clustering needs one number of position dimensions: name the primitives that differ.

    Parameters
    ----------
    prims : list of Primitive
        Stored primitives (with their samples), named by id.
    items : list of dict, optional
        Store items about to be added (``{"demo", "bounds", ...}``), counted
        as primitives "being added": an add that reclusters checks them before
        it writes, so a refused add leaves the library as it was.

    Raises
    ------
    ValueError
        One line naming the most common dimension and the primitives of the others.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Demonstration
    >>> t = np.linspace(0.0, 1.0, 5)
    >>> item = {"demo": Demonstration.from_array(np.c_[t, t], t), "bounds": [(0, 5)]}
    >>> check_one_dimension([], [item, item])
    >>> item3 = {"demo": Demonstration.from_array(np.c_[t, t, t], t), "bounds": [(0, 2), (2, 5)]}
    >>> check_one_dimension([], [item, item3])
    Traceback (most recent call last):
    ...
    ValueError: library: cannot cluster positions of different dimensions together: 2 primitive(s) are 3-D \
(being added), 1 are 2-D (1 being added); remove those demonstrations or keep them in another library
    """
    stored: dict = {}
    new: dict = {}
    for p in prims:
        stored.setdefault(p.demo["position"].shape[1], []).append(p.id)
    for item in items:
        d = item["demo"]["position"].shape[1]
        new[d] = new.get(d, 0) + len(item["bounds"])
    dims = set(stored) | set(new)
    if len(dims) <= 1:
        return
    count = {d: len(stored.get(d, [])) + new.get(d, 0) for d in dims}
    order = sorted(dims, key=lambda d: -count[d])

    def where(d):
        ids = stored.get(d, [])
        parts = [f"ids {', '.join(map(str, ids[:5]))}{', ...' if len(ids) > 5 else ''}"] if ids else []
        parts += [f"{new[d]} being added"] if d in new else []
        return "; ".join(parts)

    first = order[0]
    head = f"{count[first]} primitive(s) are {first}-D"
    if first in new:  # the most common dimension is named by ids only when it includes what is added
        head += " (being added)" if not stored.get(first) else f" ({new[first]} of them being added)"
    rest = ", ".join(f"{count[d]} are {d}-D ({where(d)})" for d in order[1:])
    raise ValueError(f"library: cannot cluster positions of different dimensions together: {head}, {rest}; "
                     "remove those demonstrations or keep them in another library")


def check_label(name, what="label"):
    """A stripped non-empty string, else ValueError naming ``what``."""
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"{what}: expected a non-empty string, got {name!r}")
    return name.strip()


def _check_options(assign, label, segmentation):
    if assign not in ASSIGN:
        raise ValueError(f"assign: expected one of {list(ASSIGN)}, got {assign!r}")
    if segmentation is not None and not isinstance(segmentation, dict):
        raise ValueError(f"segmentation: expected a dict of segmenter parameters, got "
                         f"{type(segmentation).__name__}")
    return None if label is None else check_label(label)


class Adding:
    """``add``, ``add_many`` and ``add_files`` of :class:`~skillbank.pipeline.Library`."""

    def _check_writable(self, what: str) -> None:
        if getattr(self.store, "readonly", False):
            raise ValueError(f"library {self.store.location!r} is open read-only: cannot {what}")

    # -- one demonstration ---------------------------------------------------------------------
    def _snapshot(self, cache: dict | None = None):
        """The current clustering version as the store gives it (what an add assigns to), or None.

        ``cache`` (a dict) keeps the last version read, so a batch reads it
        once; it is read again when another process has reclustered since.
        """
        cache = {} if cache is None else cache
        version = self.store.current_version()
        if version is None:
            return None
        if cache.get("version") != version:
            cache.clear()
            cache.update(self.store.version(version))
        return cache

    def _assignment(self, parts, cache: dict):
        """``(members, None)`` in the current version for primitive samples ``parts``, or ``(None, why)``.

        ``why`` is None when there is no clustering to join yet.
        """
        return assignment(parts, self._snapshot(cache))

    def _assign(self, parts, cache: dict):
        """Clusters of the current version for primitive samples ``parts`` (None when they cannot join)."""
        return self._assignment(parts, cache)[0]

    def _prepare(self, demo, *, segment, segmentation, label, source, assign, cache) -> tuple:
        """``(store item, why it stays unclustered or None)``: everything but the write."""
        snapshot = self._snapshot(cache) if assign == "incremental" else None
        return prepare(demo, segment=segment, segmentation=segmentation, label=label, source=source,
                       assign=assign, snapshot=snapshot)

    def _check_recluster(self, items) -> None:
        """An add that reclusters refuses, before it writes, what the clustering would refuse after."""
        prims = self.store.primitives(load=True)
        n = len(prims) + sum(len(item["bounds"]) for item in items)
        if n < 2:  # Library.cluster's own check
            raise ValueError(f"library: expected at least 2 primitives to cluster, got {n}")
        check_one_dimension(prims, items)

    def _keep_one_dimension(self, by_file, fail) -> list:
        """``keep_going`` with a recluster: set aside each file whose positions have another dimension
        than the library's (the stored primitives', else most of those being added); the others' items."""
        stored = {p.demo["position"].shape[1] for p in self.store.primitives(load=True)}
        if len(stored) > 1:  # already mixed: the check after this one says which
            return [item for _, items in by_file for item in items]
        count: dict = {}
        for _, items in by_file:
            for item, _ in items:
                d = item["demo"]["position"].shape[1]
                count[d] = count.get(d, 0) + len(item["bounds"])
        want = next(iter(stored)) if stored else max(sorted(count), key=count.get)
        kept = []
        for path, items in by_file:
            other = sorted({item["demo"]["position"].shape[1] for item, _ in items} - {want})
            if other:
                whose = "the library's" if stored else "most of those added"
                fail(path, "", ValueError(f"its positions are {other[0]}-D, {whose} are {want}-D: one "
                                          "clustering cannot mix them"))
            else:
                kept.extend(items)
        return kept

    def _recluster(self, progress: bool = False) -> int:
        params = self.clustering_params() or {}
        return self.cluster(**{k: params[k] for k in _RECLUSTER_KEEPS if k in params}, progress=progress)

    # -- batches --------------------------------------------------------------------------------
    def add(self, demo, *, segment: bool = True, segmentation=None, label=None, source=None,
            assign: str = "incremental") -> int:
        """Store a demonstration and its primitives in one transaction; returns its id.

        Parameters
        ----------
        demo : Demonstration
            Needs a ``"position"`` stream (clustering and reuse work on it).
        segment : bool, default=True
            Cut it with :func:`skillbank.segmentation.segment`; False stores it
            as one primitive.
        segmentation : dict, optional
            Keyword arguments of the segmenter, plus ``"streams"``.
        label : str, optional
            Label every new primitive. Default: the demonstration's task,
            ``demo.metadata["task"]`` (a LeRobot episode's task string),
            recorded in the provenance as ``"label_from"``; else none.
        source : str, optional
            Default: ``demo.metadata["source"]``.
        assign : {"incremental", "none", "recluster"}, default="incremental"
            ``"incremental"`` puts each new primitive in the nearest cluster of
            the current clustering (features from that clustering's
            featuriser); a demonstration that cannot join it (positions of
            another number of dimensions, say) is left unclustered with a
            ``UserWarning`` saying why, recorded in its provenance
            (``provenance(id)["assignment"]``). ``"recluster"`` reclusters
            everything afterwards with the last parameters; ``"none"`` leaves
            them unclustered.

        Examples
        --------
        >>> lib.add(demo, segmentation={"window": 16})  # doctest: +SKIP
        3
        """
        return self.add_many([demo], segment=segment, segmentation=segmentation, label=label,
                             source=source, assign=assign)[0]

    def add_many(self, demos, *, segment: bool = True, segmentation=None, label=None, source=None,
                 assign: str = "incremental", progress: bool = False) -> list:
        """Add several demonstrations, all or nothing; returns their ids.

        Every demonstration is checked and cut first; then all are written in
        one transaction. A demonstration that cannot be cut raises ValueError
        naming it (``demos[k]`` and its source), and nothing is added. With
        ``assign="recluster"`` the library is reclustered once, at the end
        (a second transaction: if it is interrupted the new primitives stay
        unclustered, and :meth:`summary` lists them under ``"unassigned"``).
        ``progress`` shows a tqdm bar. Other parameters are :meth:`add`'s.

        Examples
        --------
        >>> lib.add_many(demos, segment=False, progress=True)  # doctest: +SKIP
        [1, 2, 3]
        """
        label = _check_options(assign, label, segmentation)
        self._check_writable("add demonstrations")
        demos = list(demos)
        for k, demo in enumerate(demos):
            check_demo(demo, f"demos[{k}]")
        cache, prepared = {}, []
        for k, demo in enumerate(tqdm(demos, desc="segmenting", unit="demo", disable=not progress)):
            try:
                prepared.append(self._prepare(demo, segment=segment, segmentation=segmentation, label=label,
                                              source=source, assign=assign, cache=cache))
            except ValueError as exc:
                src = demo.metadata.get("source")
                name = f"demos[{k}]" + ("" if src is None else f" (source {str(src)!r})")
                raise ValueError(f"{name}: {exc}; nothing was added") from None
        if assign == "recluster":
            try:
                self._check_recluster([item for item, _ in prepared])
            except ValueError as exc:
                raise ValueError(f"{exc}; nothing was added") from None
        written = self.store.add_demonstrations([item for item, _ in prepared])
        for (did, pids), (_, why) in zip(written, prepared, strict=True):
            if why is not None:
                warnings.warn(f"demonstration {did}: {len(pids)} primitive(s) left unclustered: {why}",
                              UserWarning, stacklevel=2)
        if assign == "recluster" and written:
            self._recluster(progress)
        return [did for did, _ in written]

    def add_files(self, paths, *, index=None, group: str = "normalized", segment: bool = True,
                  segmentation=None, label=None, assign: str = "incremental", keep_going: bool = False,
                  progress: bool = False, repair_time=None, reader_options=None, workers=None,
                  scheduler=None, batch_size: int = BATCH_SIZE) -> dict:
        """Read demonstration files and add every demonstration in them as one batch.

        By default all or nothing: every file is read and every
        demonstration cut before anything is written, then all are written
        in one transaction; the first bad file raises ValueError naming it,
        and nothing is added. With ``keep_going=True`` each bad file is set
        aside with its reason (a file counts as bad when it cannot be read or
        any of its demonstrations cannot be cut) and the others are added, in
        one transaction.

        With ``workers`` or ``scheduler`` (the ``dask`` extra), files are read
        and cut in parallel on a Dask cluster and written here, in the order
        of ``paths`` (the same ids as without): all or nothing still writes
        everything in one transaction at the end; ``keep_going`` writes every
        ``batch_size`` demonstrations (whole files) in one transaction as
        they come, so memory stays bounded and a stopped add keeps the
        batches written (see ``skillbank.pipeline._parallel`` and
        ``docs/scaling.md``).

        Parameters
        ----------
        paths : list of str or path-like
            Files in any format :func:`skillbank.io.load_all` reads; each
            demonstration's ``source`` is its file (unless its metadata has one).
        index : int, optional
            Add only this demonstration of each file (:func:`skillbank.io.load`).
        group : str, default="normalized"
            For handwriting HDF5 files.
        repair_time : {None, "drop"}, default=None
            Repeated time stamps are an error; ``"drop"`` drops them
            (:func:`skillbank.io.load_all`).
        reader_options : mapping, optional
            Options of the recording readers (ROS bags, MCAP, LeRobot,
            robomimic), e.g. ``{"topics": ["/ft=wrench"], "episodes": "0:100"}``
            (:func:`skillbank.io.load_all`); other formats ignore them.
        keep_going : bool, default=False
            Set failing files aside (``report["failed"]``) and add the rest.
            With ``assign="recluster"``, a file whose positions have another
            dimension than the library's is one of them; without
            ``keep_going`` such a file stops the add before it writes
            anything, as a recluster could not mix them.
        progress : bool, default=False
            tqdm bars while reading and cutting.
        segment, segmentation, label, assign
            As in :meth:`add`.
        workers : int, optional
            Prepare the files on a new local Dask cluster of this many
            single-threaded worker processes, closed at the end.
        scheduler : str or distributed.Client, optional
            Or on an existing Dask cluster: its scheduler's address
            (``"tcp://host:8786"``) or a client of it. The workers read the
            files, so they must see the same paths.
        batch_size : int, default=50
            Demonstrations per transaction of a parallel add with ``keep_going``.

        Returns
        -------
        dict
            ``{"demonstrations": [ids], "primitives": [[ids] per demonstration],
            "failed": {file: reason}, "unclustered": {demonstration id: reason},
            "set_aside": {demonstration id: {stream: reason}} (streams without
            information the segmenter set aside),
            "version": the new clustering version (assign="recluster") or None}``;
            a parallel add adds ``"scheduler"``, the address of the cluster used.

        Examples
        --------
        >>> lib.add_files(["a.csv", "b.csv"], keep_going=True)["failed"]  # doctest: +SKIP
        {'b.csv': 'cannot read it: ...'}
        """
        label = _check_options(assign, label, segmentation)
        if isinstance(paths, (str, Path)) or not isinstance(paths, (list, tuple)):
            raise ValueError(f"paths: expected a list of files, got {type(paths).__name__}")
        self._check_writable("add demonstrations")
        if workers is not None or scheduler is not None:
            report = add_in_parallel(
                self, paths, read={"index": index, "group": group, "repair_time": repair_time,
                                   "reader_options": reader_options},
                options={"segment": segment, "segmentation": segmentation, "label": label, "assign": assign},
                keep_going=keep_going, progress=progress, workers=workers, scheduler=scheduler,
                batch_size=batch_size)
            if assign == "recluster" and report["demonstrations"]:
                report["version"] = self._recluster(progress)
            return report
        failed, read = {}, []

        def fail(path, what, exc):
            reason = what + file_reason(exc, path)
            if not keep_going:
                raise ValueError(f"{path}: {reason}; nothing was added") from None
            failed[str(path)] = reason

        for path in tqdm(paths, desc="reading", unit="file", disable=not progress):
            try:
                demos = read_file(path, index=index, group=group, repair_time=repair_time,
                                  reader_options=reader_options)
            except (ValueError, OSError) as exc:
                fail(path, "", exc)
                continue
            read.append((path, demos))
        cache, prepared, by_file = {}, [], []
        for path, demos in tqdm(read, desc="segmenting", unit="file", disable=not progress):
            items = []
            try:
                for demo in demos:
                    items.append(self._prepare(demo, segment=segment, segmentation=segmentation, label=label,
                                               source=None, assign=assign, cache=cache))
            except ValueError as exc:  # raised by the demonstration after the last one prepared
                fail(path, "" if len(demos) == 1 else f"demonstration {len(items)}: ", exc)
                continue
            prepared.extend(items)
            by_file.append((path, items))
        if assign == "recluster" and prepared and keep_going:
            prepared = self._keep_one_dimension(by_file, fail)
        if assign == "recluster" and prepared:
            try:
                self._check_recluster([item for item, _ in prepared])
            except ValueError as exc:
                raise ValueError(f"{exc}; nothing was added") from None
        written = self.store.add_demonstrations([item for item, _ in prepared]) if prepared else []
        order = {str(p): n for n, p in enumerate(paths)}
        report = {"demonstrations": [did for did, _ in written], "primitives": [pids for _, pids in written],
                  "failed": dict(sorted(failed.items(), key=lambda kv: order[kv[0]])),
                  "unclustered": {did: why for (did, _), (_, why) in zip(written, prepared, strict=True)
                                  if why is not None},
                  "set_aside": set_aside(written, prepared), "version": None}
        if assign == "recluster" and written:
            report["version"] = self._recluster(progress)
        return report
