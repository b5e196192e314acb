"""The store interface: what every storage backend of a skill library implements.

A store only stores. It keeps demonstrations (every stream, losslessly),
primitives (sample ranges in their demonstration), clustering versions (the
parameters, centres and featuriser arrays, and every member's cluster and
features), sparse labels on clusters or primitives, and the segmentation
provenance of each demonstration; and it exports and imports all of it. It
never segments, featurises or clusters: :class:`skillbank.pipeline.Library`
does that and hands the store the results.

Every write method is one transaction: it happens completely or not at all,
and concurrent writers are serialised by the backend. A new backend is one
subclass of :class:`Store` and one line in :data:`skillbank.store.STORES`; a
SQL database subclasses :class:`skillbank.store._sql.SQLStore`, which writes
every query once, and gives only its connection and dialect.
"""

from __future__ import annotations

import operator
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from ..core import Demonstration

__all__ = ["Store", "Primitive", "check_item", "check_items", "check_description"]

#: The keys of an item of :meth:`Store.add_demonstrations`: the parameters of :meth:`Store.add_demonstration`.
ITEM_KEYS = ("demo", "bounds", "source", "label", "provenance", "members")


@dataclass
class Primitive:
    """One stored motion primitive.

    Attributes
    ----------
    id : int
    demonstration_id : int
    start, stop : int
        Sample range ``start:stop`` in its demonstration (stop exclusive).
    cluster : int or None
        Cluster in the current clustering version (None: not clustered yet).
    label : str or None
        The primitive's own label, else its cluster's, else the one its cluster's labelled primitives
        agree on (sparse labels).
    demo : Demonstration or None
        The primitive's samples, every stream of its demonstration.
    features : ndarray or None
        Its features in the current clustering version.
    label_source : str or None
        Where ``label`` comes from: ``"given"`` (the primitive's own), ``"cluster"`` (its cluster's) or
        ``"inferred"`` (from the labelled primitives of its cluster).
    """

    id: int
    demonstration_id: int
    start: int
    stop: int
    cluster: int | None = None
    label: str | None = None
    demo: Demonstration | None = field(default=None, repr=False)
    features: np.ndarray | None = field(default=None, repr=False)
    label_source: str | None = None

    @property
    def n_steps(self) -> int:
        """Number of samples."""
        return int(self.stop - self.start)



def _name(where: str, key: str) -> str:
    return f"{where}[{key!r}]" if where else key


def check_item(item, where: str = "") -> dict:
    """Check one item of :meth:`Store.add_demonstrations`; returns it with every key and integer bounds.

    ``where`` prefixes the names in messages (``"items[2]"``); empty, they
    name the parameters of :meth:`Store.add_demonstration`.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 10)
    >>> check_item({"demo": Demonstration.from_array(np.c_[t, t], t), "bounds": [(0, 4), (4, 10)]})["bounds"]
    [(0, 4), (4, 10)]
    >>> check_item({"demo": Demonstration.from_array(np.c_[t, t], t), "bounds": [(4, 2)]}, "items[0]")
    Traceback (most recent call last):
    ...
    ValueError: items[0]['bounds']: expected sample ranges (start, stop), 0 <= start < stop <= 10, got (4, 2)
    """
    what = where or "item"
    if not isinstance(item, dict):
        raise ValueError(f"{what}: expected a dict with 'demo' and 'bounds', got {type(item).__name__}")
    unknown = sorted(set(item) - set(ITEM_KEYS), key=str)
    if unknown:
        raise ValueError(f"{what}: unknown key(s) {unknown}; expected some of {list(ITEM_KEYS)}")
    demo = item.get("demo")
    if not isinstance(demo, Demonstration):
        raise ValueError(f"{_name(where, 'demo')}: expected a Demonstration, got {type(demo).__name__}")
    name = _name(where, "bounds")
    try:
        bounds = [(operator.index(a), operator.index(b)) for a, b in item.get("bounds")]
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a list of integer pairs (start, stop), "
                         f"got {str(item.get('bounds'))[:80]}") from None
    for a, b in bounds:
        if not 0 <= a < b <= demo.n_steps:
            raise ValueError(f"{name}: expected sample ranges (start, stop), 0 <= start < stop <= "
                             f"{demo.n_steps}, got {(a, b)}")
    members = item.get("members")
    if members is not None:
        mname = _name(where, "members")
        if not isinstance(members, dict) or not {"version", "clusters", "features"} <= set(members):
            raise ValueError(f"{mname}: expected a dict with 'version', 'clusters' and 'features'")
        if not len(members["clusters"]) == len(members["features"]) == len(bounds):
            raise ValueError(f"{mname}: expected one cluster and one feature row per bound ({len(bounds)}), "
                             f"got {len(members['clusters'])} and {len(members['features'])}")
    return {**dict.fromkeys(ITEM_KEYS), **item, "bounds": bounds}


def check_items(items) -> list:
    """Check the items of :meth:`Store.add_demonstrations` with :func:`check_item`, naming ``items[k]``.

    Examples
    --------
    >>> check_items([{"bounds": [(0, 1)]}])
    Traceback (most recent call last):
    ...
    ValueError: items[0]['demo']: expected a Demonstration, got NoneType
    """
    if isinstance(items, (dict, str, bytes)) or not isinstance(items, (list, tuple)):
        raise ValueError(f"items: expected a list of dicts with 'demo' and 'bounds', "
                         f"got {type(items).__name__}")
    return [check_item(item, f"items[{k}]") for k, item in enumerate(items)]


def check_description(label, action, binding) -> tuple:
    """Check the arguments of :meth:`Store.set_description`; returns them (``binding`` a plain dict).

    Examples
    --------
    >>> check_description("press", "(:action press :parameters (?b))", {})[0]
    'press'
    >>> check_description("press", 3, {})
    Traceback (most recent call last):
    ...
    ValueError: action: expected PDDL text (a string) or None, got int
    """
    if not isinstance(label, str) or not label.strip():
        raise ValueError(f"label: expected a non-empty string, got {label!r}")
    if action is not None and (not isinstance(action, str) or not action.strip()):
        raise ValueError(f"action: expected PDDL text (a string) or None, got {type(action).__name__}")
    if not isinstance(binding, dict) or not all(isinstance(k, str) for k in binding):
        raise ValueError(f"binding: expected a dict with string keys, got {type(binding).__name__}")
    return label, action, dict(binding)


class Store(ABC):
    """Abstract storage backend of a skill library (see the module docstring).

    Ids are integers assigned by the store. Clustering versions are numbered
    1, 2, ...; the highest is the *current* version.
    """

    #: The URL scheme this backend serves (``"sqlite"`` for ``sqlite:///path`` and plain paths).
    scheme: str = ""

    #: True for a store opened read-only (``readonly=True``): it writes nothing, and every write
    #: method raises ValueError in one line.
    readonly: bool = False

    # -- life cycle ---------------------------------------------------------------------------
    @classmethod
    @abstractmethod
    def from_url(cls, url: str, *, create: bool = True, **options) -> Store:
        """Open the library at ``url`` (``<scheme>://...``), creating it when ``create``.

        A backend that can open read-only takes ``readonly=True`` among the ``options``.
        """

    @property
    @abstractmethod
    def location(self) -> str:
        """Where the library lives (a path or a URL without password), for messages."""

    @abstractmethod
    def close(self) -> None:
        """Release the connection (idempotent)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.location!r})"

    @abstractmethod
    def check(self) -> str:
        """The backend's integrity check: ``"ok"`` for a sound library."""

    # -- demonstrations and primitives ------------------------------------------------------
    def add_demonstration(self, demo: Demonstration, bounds, *, source=None, label=None, provenance=None,
                          members=None) -> tuple[int, list[int]]:
        """Store ``demo`` and one primitive per ``(start, stop)`` of ``bounds``, in one transaction.

        The one-item case of :meth:`add_demonstrations`.

        Parameters
        ----------
        demo : Demonstration
        bounds : list of (int, int)
            Sample range of each primitive (stop exclusive).
        source : str, optional
        label : str, optional
            Given to every new primitive.
        provenance : dict, optional
            How ``bounds`` were found (the segmentation parameters), JSON-able.
        members : dict, optional
            ``{"version": v, "clusters": [...], "features": [...]}``: the
            clusters of version ``v`` the new primitives join (one per bound),
            with their features.

        Returns
        -------
        (demonstration id, list of primitive ids)
        """
        item = check_item({"demo": demo, "bounds": bounds, "source": source, "label": label,
                           "provenance": provenance, "members": members})
        return self.add_demonstrations([item])[0]

    @abstractmethod
    def add_demonstrations(self, items) -> list[tuple[int, list[int]]]:
        """Store several demonstrations with their primitives in **one** transaction: all or none.

        Parameters
        ----------
        items : list of dict
            One per demonstration, with the parameters of
            :meth:`add_demonstration` as keys: ``"demo"`` and ``"bounds"``,
            optionally ``"source"``, ``"label"``, ``"provenance"``,
            ``"members"``. Checked with :func:`check_items` before the
            transaction begins (messages name ``items[k]``).

        Returns
        -------
        list of (demonstration id, list of primitive ids)
            In the order of ``items``.
        """

    @abstractmethod
    def remove_demonstration(self, demo_id: int) -> None:
        """Delete a demonstration with its primitives, memberships and labels; ValueError if unknown."""

    @abstractmethod
    def demonstrations(self, ids) -> dict:
        """``{id: Demonstration}`` exactly as added; ValueError naming an unknown id."""

    @abstractmethod
    def demonstration_ids(self) -> list[int]:
        """Ids of every stored demonstration, ascending."""

    @abstractmethod
    def demonstration_metadata(self) -> dict:
        """``{id: metadata}`` of every stored demonstration (without its samples)."""

    @abstractmethod
    def provenance(self, demo_id: int) -> dict:
        """The provenance recorded when ``demo_id`` was added (``{}`` when none)."""

    @abstractmethod
    def primitives(self, *, label=None, cluster=None, source=None, demonstration=None,
                   load: bool = True) -> list[Primitive]:
        """Primitives matching every filter given, by id; ``load=False`` skips their samples.

        ``label`` is the effective label (the primitive's own, else its
        cluster's in the current version); ``cluster`` a cluster of the
        current version.
        """

    # -- clustering versions and labels ------------------------------------------------------
    @abstractmethod
    def current_version(self) -> int | None:
        """The latest clustering version, or None before the first."""

    @abstractmethod
    def version(self, version: int) -> dict:
        """``{"version", "created", "params", "n_clusters", "centers", "pca_mean", "pca_components"}``."""

    @abstractmethod
    def versions(self) -> list[dict]:
        """Every version as ``{"version", "created", "n_clusters", "params"}``, oldest first."""

    @abstractmethod
    def members(self, version: int) -> dict:
        """``{primitive id: cluster}`` of a version."""

    @abstractmethod
    def cluster_labels(self, version: int) -> dict:
        """``{cluster: label}`` of a version."""

    def inferred_labels(self, version: int) -> dict:
        """``{cluster: label}`` inferred in a version: the one label its labelled primitives carry."""
        return {}

    @abstractmethod
    def add_version(self, *, params: dict, centers, pca_mean, pca_components, members, labels=None) -> int:
        """Record a clustering version in one transaction; returns its number.

        ``members`` is a list of ``(primitive id, cluster, features)``;
        ``labels`` an optional ``{cluster: label}`` (e.g. carried over from
        the previous version).
        """

    @abstractmethod
    def add_members(self, version: int, members) -> None:
        """Add ``(primitive id, cluster, features)`` to a version incrementally, in one transaction.

        A primitive already a member of that version is left as it is.
        """

    @abstractmethod
    def set_label(self, name, *, cluster=None, primitive=None) -> None:
        """Label a cluster of the current version or one primitive; ``name=None`` removes the label."""

    # -- skill descriptions --------------------------------------------------------------------
    def set_description(self, label: str, action, binding: dict) -> int:
        """Record a new revision of the description of skill ``label``; returns its revision number.

        ``action`` is PDDL text (an action schema; None removes the
        description), ``binding`` a JSON-able dict (how its parameters bind to
        geometry). Revisions of a label are numbered 1, 2, ...; the highest is
        current. The store keeps them as given: the pipeline checks them.
        One transaction. A backend without descriptions raises ValueError.
        """
        raise ValueError(f"library {self.location!r}: its backend {type(self).__name__} does not store "
                         "skill descriptions")

    def descriptions(self, *, history: bool = False) -> list[dict]:
        """Skill descriptions as ``{"label", "revision", "created", "action", "binding"}``, by label.

        Only the current revision of each label, removed ones left out; with
        ``history``, every revision (removals included, ``action`` None), by
        label then revision. A backend without descriptions has none.
        """
        return []

    # -- transfer ------------------------------------------------------------------------------
    @abstractmethod
    def export(self, folder, *, progress=None):
        """Write everything to ``folder`` (NPZ files and ``manifest.json``); returns the manifest path.

        ``progress``, when given, is called as ``progress(done, total)`` with
        the number of demonstrations written so far and their total.
        """

    @abstractmethod
    def import_folder(self, folder, *, max_bytes=None) -> dict:
        """Import an exported folder in one transaction, after checking all of it; a bad one changes nothing.

        Every path the manifest names must be a regular file of its own
        inside ``folder`` (no symbolic or hard links); the arrays of all its
        NPZ files may take at most ``max_bytes`` once decompressed (default
        1 GiB, or ``$SKILLBANK_MAX_IMPORT_BYTES``), measured before any is
        read; the manifest is validated against its schema and the files
        against the manifest before the transaction begins
        (:func:`skillbank.store._manifest.read_export`). Messages name the
        manifest entry and never quote a file's contents.

        Into an empty library (no demonstrations, no versions): an exact copy,
        ids kept. Into a non-empty one: a merge that skips demonstrations
        already stored (same content hash), adds the others renumbered with
        their primitives and the primitives' own labels, and adds no
        clustering version (the current one stays current; the new primitives
        are left unclustered for the pipeline to assign).

        Returns
        -------
        dict
            ``{"mode": "copy" or "merge", "demonstrations": {old: new},
            "primitives": {old: new}, "versions": {old: new},
            "skipped": {old demonstration id: id already stored}}``.
        """
