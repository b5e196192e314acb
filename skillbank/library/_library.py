"""The motion-primitive library: one SQLite file in WAL mode."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._demonstration import Demonstration
from ._arrays import from_npy
from ._clusters import assign_incremental, current_version, fit_version, load_version
from ._records import Primitive, insert_demonstration, load_demonstrations, primitive_demo
from ._schema import SCHEMA_VERSION, connect, database_errors, transaction

__all__ = ["Library"]

_ASSIGN = ("incremental", "none", "recluster")


def _check_label(name, what="label"):
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"{what}: expected a non-empty string, got {name!r}")
    return name.strip()


def _check_id(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}: expected an integer id, got {value!r}")
    return int(value)


class Library:
    """A durable library of demonstrations, motion primitives, skills and labels.

    Everything lives in one SQLite file opened in WAL mode: demonstrations
    (source, time base and every stream, losslessly as ``.npy`` bytes),
    primitives (segment bounds in their demonstration; their samples are the
    demonstration's rows ``start:stop``), clustering versions (parameters,
    centres, the featuriser's PCA arrays, every member's features), sparse
    labels on clusters or primitives, and the segmentation parameters of each
    demonstration. Each write is one transaction; concurrent writers queue on
    SQLite's lock for up to ``timeout`` seconds.

    Parameters
    ----------
    path : str or path-like
        The library file; created when missing (with ``create=True``).
    create : bool, default=True
        False raises ValueError when the file does not exist.
    timeout : float, default=60.0
        Seconds a writer waits for another writer before giving up.

    Raises
    ------
    ValueError
        One line, for a file that is not SQLite, is corrupt, is not a
        skillbank library or was written by a newer schema version.

    Examples
    --------
    >>> import numpy as np, os, tempfile
    >>> from skillbank import Demonstration
    >>> t = np.linspace(0.0, 1.0, 50)
    >>> with Library(os.path.join(tempfile.mkdtemp(), "lib.db")) as lib:
    ...     i = lib.add(Demonstration.from_array(np.column_stack([t, t ** 2]), t), segment=False,
    ...                 label="reach")
    ...     [p.label for p in lib.primitives()]
    ['reach']
    """

    schema_version = SCHEMA_VERSION

    def __init__(self, path, *, create: bool = True, timeout: float = 60.0):
        self.path = Path(path)
        self._conn = connect(self.path, timeout=timeout, create=create)

    # -- life cycle -------------------------------------------------------------------------------
    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self) -> str:
        return f"Library({str(self.path)!r})"

    @property
    def conn(self):
        """The open SQLite connection."""
        if self._conn is None:
            raise ValueError(f"library {str(self.path)!r} is closed")
        return self._conn

    def _errors(self):
        return database_errors(self.path)

    # -- adding -----------------------------------------------------------------------------------
    def _bounds(self, demo, segment, segmentation):
        if not segment:
            return [(0, demo.n_steps)], {"segment": False}
        from .. import __version__
        from ..segmentation import segment as run_segmentation

        params = dict(segmentation or {})
        streams = params.pop("streams", None)
        result = run_segmentation(demo, streams, **params)
        return result.bounds, {"segment": True, "method": "skillbank.segmentation.segment",
                               "streams": streams, "requested": params, "resolved": result.params,
                               "mode": result.mode, "skillbank_version": __version__}

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
            Label every new primitive.
        source : str, optional
            Default: ``demo.metadata["source"]``.
        assign : {"incremental", "none", "recluster"}, default="incremental"
            ``"incremental"`` puts each new primitive in the nearest cluster of
            the current clustering (features from that clustering's
            featuriser); ``"recluster"`` reclusters everything afterwards with
            the last parameters; ``"none"`` leaves them unclustered.

        Examples
        --------
        >>> lib.add(demo, segmentation={"window": 16})  # doctest: +SKIP
        3
        """
        return self.add_many([demo], segment=segment, segmentation=segmentation, label=label,
                             source=source, assign=assign)[0]

    def add_many(self, demos, *, segment: bool = True, segmentation=None, label=None, source=None,
                 assign: str = "incremental", progress: bool = False) -> list:
        """Add several demonstrations, each in its own transaction; returns their ids.

        With ``assign="recluster"`` the library is reclustered once, at the end.
        ``progress`` shows a tqdm bar. Other parameters are :meth:`add`'s.

        Examples
        --------
        >>> lib.add_many(demos, segment=False, progress=True)  # doctest: +SKIP
        [1, 2, 3]
        """
        from tqdm import tqdm

        if assign not in _ASSIGN:
            raise ValueError(f"assign: expected one of {list(_ASSIGN)}, got {assign!r}")
        label = None if label is None else _check_label(label)
        if segmentation is not None and not isinstance(segmentation, dict):
            raise ValueError(f"segmentation: expected a dict of segmenter parameters, got "
                             f"{type(segmentation).__name__}")
        demos = list(demos)
        for k, demo in enumerate(demos):
            if not isinstance(demo, Demonstration):
                raise ValueError(f"demos[{k}]: expected a Demonstration, got {type(demo).__name__}")
            if "position" not in demo.streams:
                raise ValueError(f"demos[{k}]: expected a 'position' stream, got streams {demo.stream_names}")
        ids = []
        for demo in tqdm(demos, desc="adding", unit="demo", disable=not progress):
            bounds, provenance = self._bounds(demo, segment, segmentation)
            src = source if source is not None else demo.metadata.get("source")
            with self._errors(), transaction(self.conn) as conn:
                did, pids = insert_demonstration(conn, demo, bounds, source=None if src is None else str(src),
                                                 label=label, provenance=provenance)
                if assign == "incremental":
                    parts = [primitive_demo(demo, p, did, a, b)
                             for p, (a, b) in zip(pids, bounds, strict=True)]
                    assign_incremental(conn, pids, parts)
            ids.append(did)
        if assign == "recluster" and ids:
            params = self.clustering_params() or {}
            keep = ("stretch", "features", "n_points", "n_components", "random_state")
            self.cluster(**{k: params[k] for k in keep if k in params})
        return ids

    def remove(self, demo_id) -> None:
        """Delete a demonstration with its primitives, their memberships and labels.

        Examples
        --------
        >>> lib.remove(3)  # doctest: +SKIP
        """
        demo_id = _check_id(demo_id, "demo_id")
        with self._errors(), transaction(self.conn) as conn:
            if conn.execute("DELETE FROM demonstrations WHERE id = ?", (demo_id,)).rowcount == 0:
                raise ValueError(f"demo_id: no demonstration with id {demo_id} in the library")

    # -- clustering and labels --------------------------------------------------------------------
    def cluster(self, *, stretch=None, features: str = "default", n_points: int = 16, n_components: int = 3,
                random_state=0) -> int:
        """Cluster every primitive with elastic clustering; records and returns a new version.

        Features: ``features`` (see :func:`~skillbank.library._arrays.flat_features`)
        of ``n_points`` samples, projected on ``n_components`` principal
        components; the PCA arrays are stored so that later primitives are
        featurised identically. Labels of the previous version carry over to
        a new cluster when more than half of its members had that label.

        Parameters
        ----------
        stretch : float, optional
            Stretching constant (default 1.2, the paper's).
        features : {"default", "position"}, default="default"
        n_points, n_components : int
        random_state : int or None, default=0

        Examples
        --------
        >>> lib.cluster(stretch=1.2)  # doctest: +SKIP
        1
        """
        stretch = 1.2 if stretch is None else stretch
        with self._errors(), transaction(self.conn) as conn:
            prims = self._query(conn, load=True)
            return fit_version(conn, [p.id for p in prims], [p.demo for p in prims], stretch=stretch,
                               features=features, n_points=n_points, n_components=n_components,
                               random_state=random_state)

    def clustering_params(self, version=None):
        """Parameters of a clustering version (default: the current one), or None before any."""
        with self._errors():
            version = current_version(self.conn) if version is None else version
            return None if version is None else load_version(self.conn, version)["params"]

    def versions(self) -> list:
        """Every clustering version: ``{"version", "created", "n_clusters", "params"}``, oldest first."""
        from ._arrays import from_json

        with self._errors():
            rows = self.conn.execute("SELECT version, created, n_clusters, params FROM cluster_versions "
                                     "ORDER BY version").fetchall()
        return [{"version": v, "created": c, "n_clusters": n, "params": from_json(p)} for v, c, n, p in rows]

    def label(self, name, *, cluster=None, primitive=None) -> None:
        """Label a cluster of the current version, or one primitive (``name=None`` removes it).

        A primitive's own label overrides its cluster's.

        Examples
        --------
        >>> lib.label("press", cluster=0)  # doctest: +SKIP
        """
        if (cluster is None) == (primitive is None):
            raise ValueError("label: give exactly one of cluster= or primitive=")
        name = None if name is None else _check_label(name, "name")
        with self._errors(), transaction(self.conn) as conn:
            if primitive is not None:
                pid = _check_id(primitive, "primitive")
                if conn.execute("UPDATE primitives SET label = ? WHERE id = ?", (name, pid)).rowcount == 0:
                    raise ValueError(f"primitive: no primitive with id {pid} in the library")
                return
            k = _check_id(cluster, "cluster")
            version = current_version(conn)
            if version is None:
                raise ValueError("cluster: the library has no clusters yet; run cluster() first")
            n = conn.execute("SELECT n_clusters FROM cluster_versions WHERE version = ?",
                             (version,)).fetchone()[0]
            if not 0 <= k < n:
                raise ValueError(f"cluster: expected a cluster id in 0..{n - 1} (version {version}), got {k}")
            conn.execute("DELETE FROM cluster_labels WHERE version = ? AND cluster = ?", (version, k))
            if name is not None:
                conn.execute("INSERT INTO cluster_labels (version, cluster, label) VALUES (?, ?, ?)",
                             (version, k, name))

    # -- queries ----------------------------------------------------------------------------------
    def _query(self, conn, *, label=None, cluster=None, source=None, demonstration=None, load=True):
        version = current_version(conn)
        rows = conn.execute(
            "SELECT p.id, p.demonstration_id, p.start, p.stop, m.cluster, COALESCE(p.label, l.label), "
            "m.features FROM primitives p JOIN demonstrations d ON d.id = p.demonstration_id "
            "LEFT JOIN cluster_members m ON m.primitive_id = p.id AND m.version = ? "
            "LEFT JOIN cluster_labels l ON l.version = m.version AND l.cluster = m.cluster "
            "WHERE (? IS NULL OR d.source = ?) AND (? IS NULL OR p.demonstration_id = ?) "
            "AND (? IS NULL OR m.cluster = ?) AND (? IS NULL OR COALESCE(p.label, l.label) = ?) "
            "ORDER BY p.id",
            (-1 if version is None else version, source, source, demonstration, demonstration,
             cluster, cluster, label, label)).fetchall()
        parents = load_demonstrations(conn, {r[1] for r in rows}) if load and rows else {}
        out = []
        for pid, did, a, b, c, lab, feats in rows:
            demo = primitive_demo(parents[did], pid, did, a, b) if load else None
            out.append(Primitive(pid, did, a, b, c, lab, demo, None if feats is None else from_npy(feats)))
        return out

    def primitives(self, *, label=None, cluster=None, source=None, demonstration=None, load=True) -> list:
        """Primitives matching every filter given, by id (``load=False`` skips their samples).

        Parameters
        ----------
        label : str, optional
            Effective label (the primitive's own, else its cluster's).
        cluster : int, optional
            Cluster in the current version.
        source : str, optional
            Source file of the demonstration.
        demonstration : int, optional

        Returns
        -------
        list of Primitive

        Examples
        --------
        >>> [p.id for p in lib.primitives(label="press")]  # doctest: +SKIP
        [4, 9]
        """
        cluster = None if cluster is None else _check_id(cluster, "cluster")
        demonstration = None if demonstration is None else _check_id(demonstration, "demonstration")
        with self._errors():
            return self._query(self.conn, label=label, cluster=cluster, source=None if source is None
                               else str(source), demonstration=demonstration, load=load)

    def demonstration(self, demo_id) -> Demonstration:
        """The stored demonstration ``demo_id``, exactly as added."""
        with self._errors():
            did = _check_id(demo_id, "demo_id")
            return load_demonstrations(self.conn, [did])[did]

    def demonstration_ids(self) -> list:
        """Ids of every stored demonstration, ascending."""
        with self._errors():
            return [r[0] for r in self.conn.execute("SELECT id FROM demonstrations ORDER BY id")]

    def provenance(self, demo_id) -> dict:
        """The segmentation parameters recorded when ``demo_id`` was added."""
        from ._arrays import from_json

        with self._errors():
            row = self.conn.execute("SELECT p.params FROM demonstrations d LEFT JOIN provenance p "
                                    "ON p.id = d.provenance_id WHERE d.id = ?",
                                    (_check_id(demo_id, "demo_id"),)).fetchone()
        if row is None:
            raise ValueError(f"demo_id: no demonstration with id {demo_id} in the library")
        return from_json(row[0]) or {}

    def summary(self) -> dict:
        """The ``skillbank library list --json`` document.

        Returns
        -------
        dict
            ``{"n_demonstrations": int, "skills": [{"cluster", "label", "count"}],
            "primitives": [{"id", "demonstration", "cluster", "label", "n_steps"}]}``;
            skills are the clusters of the current version.
        """
        with self._errors():
            conn = self.conn
            n_demos = conn.execute("SELECT COUNT(*) FROM demonstrations").fetchone()[0]
            version = current_version(conn)
            skills = []
            if version is not None:
                n = conn.execute("SELECT n_clusters FROM cluster_versions WHERE version = ?",
                                 (version,)).fetchone()[0]
                counts = dict(conn.execute("SELECT cluster, COUNT(*) FROM cluster_members WHERE version = ? "
                                           "GROUP BY cluster", (version,)).fetchall())
                labels = dict(conn.execute("SELECT cluster, label FROM cluster_labels WHERE version = ?",
                                           (version,)).fetchall())
                skills = [{"cluster": k, "label": labels.get(k), "count": int(counts.get(k, 0))}
                          for k in range(n)]
            prims = self._query(conn, load=False)
        return {"n_demonstrations": int(n_demos), "skills": skills,
                "primitives": [{"id": p.id, "demonstration": p.demonstration_id, "cluster": p.cluster,
                                "label": p.label, "n_steps": p.n_steps} for p in prims]}

    def check(self) -> str:
        """SQLite's ``PRAGMA integrity_check`` ("ok" for a sound file)."""
        with self._errors():
            return "; ".join(r[0] for r in self.conn.execute("PRAGMA integrity_check"))

    # -- reuse and transfer -----------------------------------------------------------------------
    def skill(self, skill) -> list:
        """Primitives of a skill: a label (str) or a cluster id of the current version (int)."""
        if isinstance(skill, str):
            prims = self.primitives(label=_check_label(skill, "skill"))
            what = f"label {skill!r}"
        elif isinstance(skill, (int, np.integer)) and not isinstance(skill, bool):
            prims = self.primitives(cluster=int(skill))
            what = f"cluster {int(skill)}"
        else:
            raise ValueError(f"skill: expected a label (str) or a cluster id (int), got {skill!r}")
        if not prims:
            known = sorted({p.label for p in self.primitives(load=False) if p.label is not None})
            raise ValueError(f"skill: no primitive has {what}; labels in the library: {known}")
        return prims

    def reuse(self, skill, constraints, *, method: str = "promp", k=None, rank: str = "shortlist",
              shortlist: int = 3, random_state=None):
        """Reproduce a skill under new constraints with :func:`skillbank.selection.reuse`.

        Every primitive of the skill is a candidate (its id is the primitive id).
        ``rank="shortlist"`` (default) orders the ``shortlist`` candidates
        that the edit deformed least by the paper's curve length;
        ``"length"`` orders all of them by curve length; ``"deformation"``
        and ``"endpoints"`` by how far each candidate is from the task.

        Returns
        -------
        skillbank.selection.ReuseResult

        Examples
        --------
        >>> from skillbank import Constraints
        >>> lib.reuse("press", Constraints(start=[0, 0, 0.2], goal=[0.3, 0.1, 0.0]))  # doctest: +SKIP
        """
        prims = self.skill(skill)  # a clear error for an empty skill before any fitting
        from ..selection import reuse

        return reuse([p.demo for p in prims], constraints, method=method, k=k,
                     ids=[p.id for p in prims], rank=rank, shortlist=shortlist, random_state=random_state)

    def export(self, folder):
        """Write everything to ``folder``: NPZ files plus ``manifest.json``; returns the manifest path.

        See :func:`skillbank.library._transfer.export_library` for the layout.
        """
        from ._transfer import export_library

        with self._errors():
            return export_library(self.conn, folder)

    def import_folder(self, folder) -> dict:
        """Add everything from a folder written by :meth:`export`, in one transaction.

        Into an empty library the ids are kept; otherwise they are renumbered.
        Returns ``{"demonstrations": {old: new}, "primitives": {...}, "versions": {...}}``.
        """
        from ._transfer import import_library

        with self._errors():
            return import_library(self.conn, folder)
