"""The pipeline: add -> segment -> featurise -> assign or cluster -> reuse, over any store."""

from __future__ import annotations

import numpy as np
from tqdm import tqdm

# Clustering, reuse and planning import scikit-learn and scipy (about 0.9 s); each method that needs them
# imports them, so opening a library to list, export or copy it does not (tests/cli/test_light_imports.py).
from ..core import POSE_OF, Demonstration
from ..core._defaults import FEATURE_KINDS, SHORTLIST, TIME_LIMIT
from ..core._validation import check_id, check_positive
from ..io._arms import arm_of
from ..store import SCHEMA_VERSION, Store, open_store
from ..store._rows import MAX_N_POINTS
from ._adding import Adding, check_one_dimension
from ._adding import check_label as _check_label

__all__ = ["Library", "carry_labels"]

#: The paper's stretching constant for elastic clustering (RAIL experiment).
DEFAULT_STRETCH = 1.2


def carry_labels(old_members: dict, old_labels: dict, new_members: dict) -> dict:
    """Labels for a new clustering: a new cluster takes the old label more than half of its members had.

    Parameters
    ----------
    old_members, new_members : dict
        ``{primitive id: cluster}`` of the previous and the new version.
    old_labels : dict
        ``{cluster: label}`` of the previous version.

    Returns
    -------
    dict
        ``{new cluster: label}``.

    Examples
    --------
    >>> carry_labels({1: 0, 2: 0, 3: 1}, {0: "reach"}, {1: 5, 2: 5, 3: 5})
    {5: 'reach'}
    """
    old_label = {pid: old_labels[c] for pid, c in old_members.items() if c in old_labels}
    by_cluster: dict = {}
    for pid, c in new_members.items():
        by_cluster.setdefault(c, []).append(pid)
    out = {}
    for c in sorted(by_cluster):
        members = by_cluster[c]
        names = [old_label[pid] for pid in members if pid in old_label]
        if not names:
            continue
        values, counts = np.unique(names, return_counts=True)
        best = int(np.argmax(counts))
        if counts[best] * 2 > len(members):
            out[c] = str(values[best])
    return out


def _ticker(bar):
    """A ``progress(done, total)`` callback that moves a tqdm bar."""

    def tick(done, total):
        bar.total = total
        bar.update(done - bar.n)

    return tick


class Library(Adding):
    """A skill library: the pipeline from demonstrations to reusable skills, over a store.

    ``Library`` adds demonstrations (cut into primitives by
    :class:`~skillbank.segmentation.MultimodalSegmenter`), clusters the
    primitives into skills (:class:`~skillbank.clustering.ElasticClustering`
    on :func:`~skillbank.clustering.primitive_features`), assigns new
    primitives to the current skills, keeps sparse labels, and reuses a skill
    for a new task (:func:`~skillbank.selection.reuse`). What it computes is
    kept by a :class:`~skillbank.store.Store`: by default one SQLite file in
    WAL mode (:class:`~skillbank.store.SQLiteStore`), each write one
    transaction, concurrent writers queueing on its lock.

    Parameters
    ----------
    location : str, path-like or Store
        A library file (created when missing, with ``create=True``), a URL of
        a registered backend (``sqlite:///lib.db``), or an open store.
    create : bool, default=True
        False raises ValueError when the library does not exist.
    timeout : float, default=60.0
        Seconds a SQLite writer waits for another writer before giving up.
    readonly : bool, default=False
        Open the store read-only: it writes nothing (a library in a folder the
        user may not write can be read: listed, reused, exported), and every
        method that would change the library raises ValueError. Never creates.

    Raises
    ------
    ValueError
        One line, for a file that is not SQLite, is corrupt, is not a
        skillbank library or was written by a newer schema version; and for
        one opened for writing where its file or folder is read-only.

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

    def __init__(self, location, *, create: bool = True, timeout: float = 60.0, readonly: bool = False):
        if isinstance(location, Store):
            self.store = location
        elif readonly:
            self.store = open_store(location, create=False, timeout=timeout, readonly=True)
        else:
            self.store = open_store(location, create=create, timeout=timeout)

    @property
    def path(self):
        """The store's location (a path for SQLite)."""
        return getattr(self.store, "path", self.store.location)

    # -- life cycle -------------------------------------------------------------------------------
    def close(self) -> None:
        """Close the store (idempotent)."""
        self.store.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self) -> str:
        return f"Library({self.store.location!r})"

    # -- removing -------------------------------------------------------------------------------
    def remove(self, demo_id) -> None:
        """Delete a demonstration with its primitives, their memberships and labels.

        Examples
        --------
        >>> lib.remove(3)  # doctest: +SKIP
        """
        self.store.remove_demonstration(check_id(demo_id, name="demo_id"))

    # -- clustering and labels --------------------------------------------------------------------
    def cluster(self, *, stretch=None, features: str = "default", n_points: int = 16, n_components: int = 3,
                random_state=0, progress: bool = False) -> int:
        """Cluster every primitive with elastic clustering; records and returns a new version.

        Features: ``features`` (see :func:`~skillbank.clustering.primitive_features`)
        of ``n_points`` samples, projected on ``n_components`` principal
        components; the PCA arrays are stored so that later primitives are
        featurised identically. Labels of the previous version carry over to
        a new cluster when more than half of its members had that label
        (:func:`carry_labels`). The version is written in one transaction;
        the fit itself runs outside it, so other processes keep adding
        meanwhile; primitives added while the fit ran are then assigned to the
        new version's nearest clusters, as later adds are. Every primitive is
        a member of the new version, including those an add left unclustered
        (``summary()["unassigned"]``).

        Parameters
        ----------
        stretch : float, optional
            Stretching constant (default 1.2, the paper's).
        features : {"default", "position"}, default="default"
        n_points, n_components : int
        random_state : int or None, default=0
        progress : bool, default=False
            A tqdm bar on stderr over the steps (loading, features, fit, writing).

        Examples
        --------
        >>> lib.cluster(stretch=1.2)  # doctest: +SKIP
        1
        """
        stretch = DEFAULT_STRETCH if stretch is None else stretch
        if features not in FEATURE_KINDS:
            raise ValueError(f"features: expected one of {list(FEATURE_KINDS)}, got {features!r}")
        n_points = check_positive(n_points, name="n_points", integer=True)
        n_components = check_positive(n_components, name="n_components", integer=True)
        if not 2 <= n_points <= MAX_N_POINTS:  # what a copy, export and import of the library accept
            raise ValueError(f"n_points: expected an integer in 2..{MAX_N_POINTS}, got {n_points}")
        self._check_writable("record a clustering")
        # scikit-learn, only when a clustering is fitted
        from sklearn.decomposition import PCA

        from ..clustering import ElasticClustering, primitive_features

        with tqdm(total=4, desc="clustering", unit="step", disable=not progress) as bar:
            bar.set_postfix_str("loading primitives")
            old = self.store.current_version()
            prims = self.store.primitives(load=True)
            if len(prims) < 2:
                raise ValueError(f"library: expected at least 2 primitives to cluster, got {len(prims)}")
            check_one_dimension(prims)
            bar.update()
            bar.set_postfix_str("features")
            F = primitive_features([p.demo for p in prims], kind=features, n_points=n_points)
            pca = PCA(n_components=min(n_components, *F.shape), random_state=random_state).fit(F)
            X = (F - pca.mean_) @ pca.components_.T
            bar.update()
            bar.set_postfix_str("fitting")
            model = ElasticClustering(stretch=stretch, random_state=random_state).fit(X)
            bar.update()
            bar.set_postfix_str("writing")
            # n_dims lets an add say why a primitive of another dimension cannot join
            params = {"stretch": float(stretch), "features": features, "n_points": int(n_points),
                      "n_components": int(pca.components_.shape[0]), "random_state": random_state,
                      "method": "ElasticClustering", "criterion": model.criterion,
                      "min_separation": model.min_separation, "significance": model.significance,
                      "n_primitives": len(prims),
                      "energy": float(model.energy_), "n_dims": int(prims[0].demo["position"].shape[1])}
            new_members = {p.id: int(c) for p, c in zip(prims, model.labels_, strict=True)}
            labels = {} if old is None else carry_labels(self.store.members(old),
                                                         self.store.cluster_labels(old), new_members)
            version = self.store.add_version(
                params=params, centers=model.cluster_centers_, pca_mean=pca.mean_,
                pca_components=pca.components_, labels=labels,
                members=[(p.id, int(c), x) for p, c, x in zip(prims, model.labels_, X, strict=True)])
            self._assign_late(version, set(new_members))
            bar.update()
        return version

    def _assign_late(self, version: int, fitted: set) -> None:
        """Primitives other processes added while the fit ran join the new version as adds would."""
        late = [q for q in self.store.primitives(load=False) if q.id not in fitted]
        if not late:
            return
        ids = {q.id for q in late}
        late = [q for did in sorted({q.demonstration_id for q in late})
                for q in self.store.primitives(demonstration=did) if q.id in ids]
        found = self._assign([q.demo for q in late], {}) if late else None
        if found is not None and found["version"] == version:
            self.store.add_members(version, [(q.id, c, x) for q, c, x in
                                             zip(late, found["clusters"], found["features"], strict=True)])

    def clustering_params(self, version=None):
        """Parameters of a clustering version (default: the current one), or None before any."""
        version = self.store.current_version() if version is None else version
        return None if version is None else self.store.version(version)["params"]

    def versions(self) -> list:
        """Every clustering version: ``{"version", "created", "n_clusters", "params"}``, oldest first."""
        return self.store.versions()

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
        self.store.set_label(name, cluster=cluster, primitive=primitive)

    # -- queries ----------------------------------------------------------------------------------
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
        return self.store.primitives(label=label, cluster=cluster, source=source, demonstration=demonstration,
                                     load=load)

    def demonstration(self, demo_id) -> Demonstration:
        """The stored demonstration ``demo_id``, exactly as added."""
        did = check_id(demo_id, name="demo_id")
        return self.store.demonstrations([did])[did]

    def demonstration_ids(self) -> list:
        """Ids of every stored demonstration, ascending."""
        return self.store.demonstration_ids()

    def provenance(self, demo_id) -> dict:
        """The segmentation parameters recorded when ``demo_id`` was added."""
        return self.store.provenance(demo_id)

    def summary(self) -> dict:
        """The ``skillbank library list --json`` document.

        Returns
        -------
        dict
            ``{"n_demonstrations": int, "version": int or None,
            "skills": [{"cluster", "label", "label_source", "count"}],
            "unassigned": {"count": int, "ids": [primitive ids]},
            "demonstrations": [{"id", "pose_of", "arm_index"}],
            "primitives": [{"id", "demonstration", "cluster", "label", "label_source", "n_steps",
            "acts_on", "pose_of", "arm_index"}]}``; ``arm_index``: which arm of a recording of several
            (robosuite's ``robotK_``) a demonstration is of, None for one arm's;
            skills are the clusters (0..k-1) of the current clustering
            ``version``; ``unassigned`` the primitives in none of them (an
            add with ``assign="none"``, a primitive that could not join, or
            a recluster that was interrupted): :meth:`cluster` assigns them.
            ``label_source`` says whether a label was given (``"given"``: to the cluster, or to the
            primitive itself), taken from the cluster (``"cluster"``, a primitive's) or inferred from
            the labelled primitives of the cluster (``"inferred"``), or None without a label.
            ``acts_on`` is what the primitive acts on, found when it was added
            (:class:`~skillbank.selection.Relation` as a dict: the object, whether it was carried,
            its target, the tool's end pose in their frames), or None (no object poses recorded, or
            a move in free space). ``pose_of`` is the point of the robot the poses are of
            (``metadata["pose_of"]``, :func:`skillbank.core.check_pose_of`), or None when unknown.
        """
        version = self.store.current_version()
        skills = []
        if version is not None:
            n = self.store.version(version)["n_clusters"]
            counts = np.bincount(list(self.store.members(version).values()), minlength=n)
            labels, inferred = self.store.cluster_labels(version), self.store.inferred_labels(version)
            skills = [{"cluster": k, "label": labels.get(k, inferred.get(k)), "count": int(counts[k]),
                       "label_source": "given" if k in labels else "inferred" if k in inferred else None}
                      for k in range(n)]
        prims = self.store.primitives(load=False)
        unassigned = [p.id for p in prims if p.cluster is None]
        ids = self.store.demonstration_ids()
        # what each primitive acts on, recorded at add time (demonstrations with object poses only)
        acts = {d: self.store.provenance(d).get("relations") for d in ids}
        rank, relation = {}, {}
        for p in sorted(prims, key=lambda p: (p.demonstration_id, p.start)):
            k = rank[p.demonstration_id] = rank.get(p.demonstration_id, -1) + 1
            known = acts.get(p.demonstration_id)
            relation[p.id] = known[k] if isinstance(known, list) and k < len(known) else None
        meta = self.store.demonstration_metadata()
        pose_of = {d: meta.get(d, {}).get(POSE_OF) for d in ids}
        arm = {d: arm_of(meta.get(d, {})) for d in ids}  # which arm of a recording of several; None: one
        return {"n_demonstrations": len(ids), "version": version, "skills": skills,
                "unassigned": {"count": len(unassigned), "ids": unassigned},
                "demonstrations": [{"id": d, "pose_of": pose_of[d], "arm_index": arm[d]} for d in ids],
                "primitives": [{"id": p.id, "demonstration": p.demonstration_id, "cluster": p.cluster,
                                "label": p.label, "label_source": p.label_source, "n_steps": p.n_steps,
                                "acts_on": relation[p.id], "pose_of": pose_of.get(p.demonstration_id),
                                "arm_index": arm.get(p.demonstration_id)}
                               for p in prims]}

    def check(self) -> str:
        """The store's integrity check ("ok" for a sound library)."""
        return self.store.check()

    # -- reuse and transfer -----------------------------------------------------------------------
    def skill(self, skill) -> list:
        """Primitives of a skill: a label (str) or a cluster id of the current version (int)."""
        if isinstance(skill, str):
            prims = self.primitives(label=_check_label(skill, "skill"))
            what = f"label {skill!r}"
        elif isinstance(skill, (int, np.integer)) and not isinstance(skill, bool):
            prims = self.primitives(cluster=check_id(skill, name="skill"))  # a 64-bit id, else one line
            what = f"cluster {int(skill)}"
        else:
            raise ValueError(f"skill: expected a label (str) or a cluster id (int), got {skill!r}")
        if not prims:
            known = sorted({p.label for p in self.primitives(load=False) if p.label is not None})
            raise ValueError(f"skill: no primitive has {what}; labels in the library: {known}")
        return prims

    def reuse(self, skill, constraints, *, method: str = "promp", k=None, rank: str = "shortlist",
              shortlist: int = SHORTLIST, random_state=None, progress: bool = False, duration=None,
              robot=None, limits=None, branch=None, clearance_margin=None, time_law: str = "toppra"):
        """Reproduce a skill under new constraints with :func:`skillbank.selection.reuse`.

        Every primitive of the skill is a candidate (its id is the primitive id).
        ``rank="shortlist"`` (default) orders the ``shortlist`` candidates
        that the edit deformed least by the paper's curve length;
        ``"length"`` orders all of them by curve length; ``"deformation"``
        and ``"endpoints"`` by how far each candidate is from the task.
        ``progress`` shows a tqdm bar on stderr over the candidates adapted
        (the result is the same). ``duration``, ``robot``, ``limits``, ``branch`` and
        ``time_law`` make the reproduction executable (time from 0, gripper and other streams
        of the best primitive, joints by inverse kinematics, velocity and
        acceleration limits): see :func:`skillbank.selection.reuse`. With a
        robot, ``clearance_margin`` (m, default 5 mm) is what every moving body
        keeps from the obstacles; a reproduction that comes closer is repaired
        with via points or its candidates are rejected.

        Returns
        -------
        skillbank.selection.ReuseResult

        Examples
        --------
        >>> from skillbank import Constraints
        >>> lib.reuse("press", Constraints(start=[0, 0, 0.2], goal=[0.3, 0.1, 0.0]))  # doctest: +SKIP
        >>> lib.reuse("reach", Constraints(goal=[0.1, -0.5, 0.2], goal_orientation=[1.0, 0, 0, 0]),
        ...           robot="ur5e", limits={"joint_velocity": 1.0})  # doctest: +SKIP
        """
        from ..selection import reuse  # scipy, only when a skill is reused

        prims = self.skill(skill)  # a clear error for an empty skill before any fitting
        with tqdm(total=len(prims), desc="adapting", unit="candidate", disable=not progress) as bar:
            return reuse([p.demo for p in prims], constraints, method=method, k=k,
                         ids=[p.id for p in prims], rank=rank, shortlist=shortlist, random_state=random_state,
                         progress=_ticker(bar) if progress else None, duration=duration, robot=robot,
                         limits=limits, branch=branch, clearance_margin=clearance_margin,
                         time_law=time_law)

    # -- planning ---------------------------------------------------------------------------------
    def describe(self, label, action, binding=None) -> int:
        """Attach a PDDL action schema and its binding to skill ``label``; returns the revision number.

        The action is named like the label; ``binding`` says how its
        parameters bind to geometry (see :mod:`skillbank.planning`).
        ``action=None`` removes the description. Each call adds a revision
        (kept, exported and imported with the library).

        Examples
        --------
        >>> lib.describe("press", "(:action press :parameters (?b - button) :effect (pressed ?b))",
        ...              {"offset": [0, 0, 0.002]})  # doctest: +SKIP
        1
        """
        from ..planning import describe_skill  # the planner, only when a description is written

        return describe_skill(self.store, label, action, binding)

    def descriptions(self, *, history: bool = False) -> list:
        """Skill descriptions ``{"label", "revision", "created", "action", "binding"}`` (current ones)."""
        return self.store.descriptions(history=history)

    def plan(self, scene, *, domain=None, robot=None, limits=None, random_state=None, progress: bool = False,
             max_groundings: int | None = None, time_limit: float = TIME_LIMIT,
             search: str = "satisficing", planner: str = "ompl"):
        """Plan a task over the labelled skills in ``scene`` and reproduce it as one trajectory.

        See :func:`skillbank.planning.plan_task`: ``scene`` is a scene file, a dict of the same content
        or a :class:`~skillbank.planning.Scene`; ``progress`` shows a tqdm bar over the steps;
        ``max_groundings`` bounds the ground actions the planner may build, ``time_limit`` its search;
        ``search`` is ``"satisficing"`` (skillbank's greedy best-first search) or ``"optimal"``
        (A* with LM-cut, the fewest steps); ``planner`` (``"ompl"``, default, or ``"none"``) whether a
        step the skill cannot keep clear has its move planned in joint space (docs/planning.md).

        Returns
        -------
        skillbank.planning.PlanResult

        Examples
        --------
        >>> res = lib.plan("scene.json", robot="ur5e")  # doctest: +SKIP
        >>> [(s.action, s.args) for s in res.steps]  # doctest: +SKIP
        [('press', ('b3',)), ('press', ('b1',))]
        """
        from ..planning import plan_task  # the planner, only when a task is planned

        with tqdm(desc="plan steps", unit="step", disable=not progress) as bar:
            return plan_task(self.store, scene, domain=domain, robot=robot, limits=limits,
                             random_state=random_state, progress=_ticker(bar) if progress else None,
                             max_groundings=max_groundings, time_limit=time_limit, search=search,
                             planner=planner)

    def export(self, folder, *, progress: bool = False):
        """Write everything to ``folder``: NPZ files plus ``manifest.json``; returns the manifest path.

        ``progress`` shows a tqdm bar on stderr over the demonstrations written.
        """
        if not progress:
            return self.store.export(folder)
        with tqdm(desc="exporting", unit="demo") as bar:
            return self.store.export(folder, progress=_ticker(bar))

    def import_folder(self, folder, *, max_bytes=None) -> dict:
        """Import a folder written by :meth:`export`; importing it again changes nothing.

        The whole folder is checked first (paths confined to it, no links,
        the manifest validated, the files checked against it), so a bad
        folder changes nothing; the import itself is one transaction. Its
        arrays may take at most ``max_bytes`` once decompressed (default
        1 GiB, or ``$SKILLBANK_MAX_IMPORT_BYTES``; ``docs/scaling.md``).

        - Into an **empty** library: an exact copy (ids, clustering versions,
          memberships and labels kept).
        - Into a **non-empty** library: a merge. Demonstrations the library
          already holds (same samples, streams and metadata) are skipped; the
          others are added, renumbered, with their primitives and the
          primitives' own labels. The imported clustering versions are not
          added (they describe another population): the current version
          stays current with its labels, and the new primitives join its
          nearest clusters, as :meth:`add` would put them.

        Returns
        -------
        dict
            ``{"mode": "copy" or "merge", "demonstrations": {old: new},
            "primitives": {old: new}, "versions": {old: new},
            "skipped": {old demonstration id: id already stored},
            "assigned": {new primitive id: cluster}}``.

        Examples
        --------
        >>> lib.import_folder("backup")["skipped"]  # doctest: +SKIP
        {1: 1, 2: 2}
        """
        # a backend written before the bound existed takes no max_bytes: it is passed only when given
        result = self.store.import_folder(folder, **({} if max_bytes is None else {"max_bytes": max_bytes}))
        result["assigned"] = {}
        if result["mode"] != "merge":
            return result
        # A second transaction: a crash in between leaves the new primitives unclustered (as assign="none").
        cache, by_version = {}, {}
        for did in sorted(result["demonstrations"].values()):
            prims = self.store.primitives(demonstration=did, load=True)
            found = self._assign([p.demo for p in prims], cache) if prims else None
            if found is not None:
                by_version.setdefault(found["version"], []).extend(
                    zip([p.id for p in prims], found["clusters"], found["features"], strict=True))
        for version, members in by_version.items():
            self.store.add_members(version, members)
            result["assigned"].update({int(p): int(c) for p, c, _ in members})
        return result
