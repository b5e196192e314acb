"""Candidate adaptation and ranking: the first three steps of reuse.

Every stored primitive is a candidate. Each is warped to the task's
constraints with Laplacian trajectory editing; those that still collide or
miss a constraint are dropped with the editor's reason; the rest are ranked.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import Constraints, Demonstration, resample
from ..core._defaults import SHORTLIST  # defined where Library takes it as a default, importing no scipy
from ..core._validation import check_array, check_positive, check_time, numerical_errors
from ..editing import lte

__all__ = ["Candidate", "Selection", "select_candidates", "RANKINGS", "SHORTLIST"]

RANKINGS = ("shortlist", "length", "endpoints", "deformation")


@dataclass
class Candidate:
    """One adapted candidate.

    Attributes
    ----------
    id : hashable
        The caller's id of the primitive.
    t : ndarray of shape (n_steps,)
    original, adapted : ndarray of shape (n_steps, n_dims)
        The primitive before and after Laplacian trajectory editing.
    length : float
        Curve length of the adapted path.
    endpoint_distance : float
        Distance of the original start to the requested start plus that of
        the original end to the requested goal (0 for a missing one).
    deformation : float
        Root-mean-square displacement of the samples by the edit.
    message : str
        The editor's message.
    source : Demonstration or None
        The primitive as given, with every recorded stream (None for an
        array): reuse carries its orientation, gripper and other streams.
    """

    id: object
    t: np.ndarray
    original: np.ndarray
    adapted: np.ndarray
    length: float
    endpoint_distance: float
    deformation: float
    message: str
    source: Demonstration | None = None

    def recorded(self) -> Demonstration:
        """The primitive with every recorded stream (an array's positions on its time base)."""
        return self.source if self.source is not None else Demonstration(self.t, {"position": self.original})

    def demo(self) -> Demonstration:
        """The adapted candidate as a Demonstration (metadata ``{"id": ...}``)."""
        return Demonstration(self.t, {"position": self.adapted}, {"id": self.id})


@dataclass
class Selection:
    """Usable candidates, best first, and the rejected ones with their reasons.

    Attributes
    ----------
    candidates : list of Candidate
        Adapted, collision-free candidates meeting the constraints, best first.
    rejected : dict
        Candidate id -> reason (str), in input order.
    rank : str
        The ranking criterion used.
    """

    candidates: list
    rejected: dict = field(default_factory=dict)
    rank: str = "shortlist"

    @property
    def ranking(self) -> list:
        """``[(id, curve length), ...]`` of the usable candidates, best first."""
        return [(c.id, c.length) for c in self.candidates]


def _check_ids(ids, n: int) -> list:
    if ids is None:
        return list(range(n))
    if isinstance(ids, (str, bytes)) or not hasattr(ids, "__len__"):
        raise ValueError(f"ids: expected a list of {n} ids, got {type(ids).__name__}")
    ids = [i.item() if isinstance(i, np.generic) else i for i in ids]
    if len(ids) != n:
        raise ValueError(f"ids: expected one id per primitive ({n}), got {len(ids)}")
    try:
        unique = len(set(ids)) == n
    except TypeError:
        raise ValueError("ids: expected hashable ids (int or str)") from None
    if not unique:
        seen, dup = set(), None
        for i in ids:
            if i in seen:
                dup = i
                break
            seen.add(i)
        raise ValueError(f"ids: expected distinct ids, got {dup!r} more than once")
    return ids


def _arrays(primitives, ids, t, min_samples, orientation=False):
    """``(id, t, Y, source)`` per primitive, rejections for unusable shapes, and the checked ids."""
    if isinstance(primitives, (Demonstration, np.ndarray)) or not isinstance(primitives, (list, tuple)):
        raise ValueError(
            "primitives: expected a list of Demonstrations or arrays (n_steps, n_dims), "
            f"got {type(primitives).__name__}"
        )
    if len(primitives) == 0:
        raise ValueError("primitives: expected at least one candidate, got an empty list")
    ids = _check_ids(ids, len(primitives))
    out, rejected = [], {}
    for k, (pid, prim) in enumerate(zip(ids, primitives, strict=True)):
        source = prim if isinstance(prim, Demonstration) else None
        if source is not None:
            if "position" not in prim.streams:
                rejected[pid] = f"no 'position' stream (streams {prim.stream_names})"
                continue
            Y, tk = prim["position"], prim.t
        else:
            Y = check_array(prim, name=f"primitives[{k}]", ndim=2)
            tk = np.arange(Y.shape[0], dtype=float)
        if orientation and (source is None or "orientation" not in source.streams):
            streams = ["position"] if source is None else source.stream_names
            rejected[pid] = f"no 'orientation' stream for the orientation constraints (streams {streams})"
            continue
        if Y.shape[0] < min_samples:
            rejected[pid] = f"too short: {Y.shape[0]} sample(s), need at least {min_samples}"
            continue
        if t is not None:
            Y, tk = resample(Y, t.shape[0]), t
        out.append((pid, tk, Y, source))
    return out, rejected, ids


@numerical_errors("select_candidates")
def select_candidates(primitives, constraints, *, ids=None, t=None, rank: str = "shortlist",
                      shortlist: int = SHORTLIST, min_samples: int = 2, progress=None,
                      **lte_params) -> Selection:
    """Adapt every candidate to ``constraints`` with LTE, drop the failures, rank the rest.

    Parameters
    ----------
    primitives : list of Demonstration or array of shape (n_steps, n_dims)
        Candidates (stream ``"position"`` of a Demonstration; an array gets
        the time base ``0, 1, 2, ...``).
    constraints : Constraints
        Start, goal, via-points, boundary velocities and obstacles of the task.
    ids : list, optional
        One id per primitive; default ``0 .. n-1``.
    t : array-like of shape (n_steps,), optional
        Common time base: every candidate is first resampled (linearly in
        phase) to ``len(t)`` samples on it. Default: each keeps its own.
    rank : {"shortlist", "length", "endpoints", "deformation"}, default="shortlist"
        ``"length"``: shortest adapted curve first, the paper's criterion
        applied to every candidate. ``"deformation"``: smallest
        root-mean-square displacement by the edit first, i.e. the candidates
        whose own context is nearest the task. ``"shortlist"``: the
        ``shortlist`` least deformed candidates, shortest adapted curve
        first, then the rest by deformation; the paper's curve length decides
        among candidates that fit the task. On RAIL leave-one-out it beats
        both ``"length"`` and ``"deformation"`` (``docs/benchmarks.md``).
        ``"endpoints"``: candidates whose own start and end lie nearest the
        requested ones first (curve length breaks ties).
    shortlist : int, default=3
        Size of the shortlist for ``rank="shortlist"``.
    min_samples : int, default=2
        Shorter candidates are rejected; :func:`reuse` passes what its
        representation needs (``Representation.min_samples``).
    progress : callable, optional
        Called as ``progress(done, total)`` after each candidate is adapted.
    **lte_params
        Passed to :func:`skillbank.editing.lte` (e.g. ``margin``, ``max_iter``).

    Returns
    -------
    Selection

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank import Constraints
    >>> s = np.linspace(0.0, 1.0, 50)
    >>> prims = [np.column_stack([s, a * np.sin(np.pi * s)]) for a in (0.5, 0.1, 0.3)]
    >>> sel = select_candidates(prims, Constraints(goal=[1.2, 0.0]))
    >>> [c.id for c in sel.candidates]
    [1, 2, 0]
    """
    if not isinstance(constraints, Constraints):
        raise ValueError(f"constraints: expected a skillbank Constraints, got {type(constraints).__name__}")
    if rank not in RANKINGS:
        raise ValueError(f"rank: expected one of {list(RANKINGS)}, got {rank!r}")
    shortlist = check_positive(shortlist, name="shortlist", integer=True)
    min_samples = max(2, check_positive(min_samples, name="min_samples", integer=True))
    if t is not None:
        t = check_time(t, name="t", min_samples=min_samples)
    items, rejected, ids = _arrays(primitives, ids, t, min_samples, constraints.has_orientation)
    n_dims = constraints.n_dims
    if n_dims is None and items:
        n_dims = items[0][2].shape[1]
    usable = []
    for done, (pid, tk, Y, source) in enumerate(items, 1):
        res = _adapt(Y, tk, constraints, n_dims, lte_params)
        if isinstance(res, str):
            rejected[pid] = res
        else:
            usable.append((pid, tk, Y, res, source))
        if progress is not None:
            progress(done, len(items))
    candidates = [_candidate(pid, tk, Y, res, constraints, source) for pid, tk, Y, res, source in usable]
    key = {
        "length": lambda c: (c.length,),
        "endpoints": lambda c: (c.endpoint_distance, c.length),
        "deformation": lambda c: (c.deformation, c.length),
        "shortlist": lambda c: (c.deformation, c.length),
    }[rank]
    candidates.sort(key=key)  # stable: equal keys keep the input order
    if rank == "shortlist":
        candidates[:shortlist] = sorted(candidates[:shortlist], key=lambda c: c.length)
    rejected = {pid: rejected[pid] for pid in ids if pid in rejected}  # input order
    return Selection(candidates=candidates, rejected=rejected, rank=rank)


def _adapt(Y, t, constraints, n_dims, lte_params):
    """The LTE edit of one candidate, or the reason (str) it is rejected."""
    if Y.shape[1] != n_dims:
        return f"has {Y.shape[1]} dimensions, the task has {n_dims}"
    try:
        res = lte(Y, constraints, t=t, **lte_params)
    except ValueError as exc:  # e.g. two constraints on one sample of a short candidate
        return f"cannot be edited: {exc}"
    if not res.success:
        what = "still collides" if res.collision else "misses a constraint"
        return f"{what} after editing: {res.message}"
    return res


def _candidate(pid, t, Y, res, constraints, source=None) -> Candidate:
    P = np.asarray(res.Y, dtype=float)
    steps = np.diff(P, axis=0)
    length = float(np.sqrt(np.einsum("ij,ij->i", steps, steps)).sum())
    ends = 0.0
    if constraints.start is not None:
        ends += float(np.linalg.norm(Y[0] - constraints.start))
    if constraints.goal is not None:
        ends += float(np.linalg.norm(Y[-1] - constraints.goal))
    D = P - Y
    deformation = float(np.sqrt(np.einsum("ij,ij->i", D, D).mean()))
    return Candidate(id=pid, t=t, original=Y, adapted=P, length=length, endpoint_distance=ends,
                     deformation=deformation, message=res.message, source=source)
