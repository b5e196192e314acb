"""The store interface: what every storage backend of a skill library implements.

A store only stores. It keeps demonstrations (every stream, losslessly),
primitives (sample ranges in their demonstration), clustering versions (the
parameters, centres and featuriser arrays, and every member's cluster and
features), sparse labels on clusters or primitives, and the segmentation
provenance of each demonstration; and it exports and imports all of it. It
never segments, featurises or clusters: :class:`skillbank.pipeline.Library`
does that and hands the store the results.

Every write method is one transaction: it happens completely or not at all,
and concurrent writers are serialised by the backend. A second backend
(PostgreSQL, say) is one subclass of :class:`Store` and one line in
:data:`skillbank.store.STORES`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from ..core import Demonstration

__all__ = ["Store", "Primitive"]


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
        The primitive's own label, else its cluster's.
    demo : Demonstration or None
        The primitive's samples, every stream of its demonstration.
    features : ndarray or None
        Its features in the current clustering version.
    """

    id: int
    demonstration_id: int
    start: int
    stop: int
    cluster: int | None = None
    label: str | None = None
    demo: Demonstration | None = field(default=None, repr=False)
    features: np.ndarray | None = field(default=None, repr=False)

    @property
    def n_steps(self) -> int:
        """Number of samples."""
        return int(self.stop - self.start)



class Store(ABC):
    """Abstract storage backend of a skill library (see the module docstring).

    Ids are integers assigned by the store. Clustering versions are numbered
    1, 2, ...; the highest is the *current* version.
    """

    #: The URL scheme this backend serves (``"sqlite"`` for ``sqlite:///path`` and plain paths).
    scheme: str = ""

    # -- life cycle ---------------------------------------------------------------------------
    @classmethod
    @abstractmethod
    def from_url(cls, url: str, *, create: bool = True, **options) -> Store:
        """Open the library at ``url`` (``<scheme>://...``), creating it when ``create``."""

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
    @abstractmethod
    def add_demonstration(self, demo: Demonstration, bounds, *, source=None, label=None, provenance=None,
                          members=None) -> tuple[int, list[int]]:
        """Store ``demo`` and one primitive per ``(start, stop)`` of ``bounds``, in one transaction.

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

    # -- transfer ------------------------------------------------------------------------------
    @abstractmethod
    def export(self, folder):
        """Write everything to ``folder`` (NPZ files and ``manifest.json``); returns the manifest path."""

    @abstractmethod
    def import_folder(self, folder) -> dict:
        """Add the contents of an exported folder in one transaction; returns the id maps."""
