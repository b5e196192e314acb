"""Task constraints shared by trajectory editing and the LfD representations.

A :class:`Constraints` object holds what a new execution environment asks of a
trajectory: where it starts and ends, via-points it must pass, boundary
velocities, and regions (:class:`Sphere`, :class:`Box`) it must avoid. It works
in any number of dimensions and turns phases into sample indices with
:meth:`Constraints.resolve`. Optionally it also asks for orientations (unit
quaternions, scalar-last) at the start, the goal and via phases
(:meth:`Constraints.resolve_orientation`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ._obstacles import Obstacle
from ._rotations import check_quaternions, quaternion_angle
from ._validation import _digits, check_array, check_fraction, check_positive, check_time, summarise

__all__ = ["Constraints", "ViaPoint"]


def _point(value, name: str) -> np.ndarray:
    return check_array(value, name=name, ndim=1, min_samples=1)


def _quaternion(value, name: str) -> np.ndarray:
    """One unit quaternion, scalar-last; ValueError naming ``name`` for a wrong length or norm."""
    q = check_array(value, name=name, ndim=1, min_samples=1)
    if q.shape[0] != 4:
        raise ValueError(f"{name}: expected a quaternion of 4 components (x, y, z, w), scalar-last, got "
                         f"{q.shape[0]} component(s)")
    return check_quaternions(q, name=name)


class ViaPoint:
    """A position the trajectory must pass, at a sample index or at a phase.

    Parameters
    ----------
    position : array-like of shape (n_dims,)
    index : int, optional
        Sample index (negative counts from the end, as in Python).
    phase : float in [0, 1], optional
        Fraction of the trajectory; sample ``round(phase * (n_steps - 1))``.
        Exactly one of ``index`` and ``phase`` must be given.

    Examples
    --------
    >>> ViaPoint([1.0, 2.0], phase=0.5).sample(11)
    5
    """

    def __init__(self, position, *, index=None, phase=None):
        self.position = _point(position, "via position")
        if (index is None) == (phase is None):
            raise ValueError(
                f"ViaPoint: expected exactly one of index or phase, got index={index!r}, phase={phase!r}"
            )
        if index is not None:
            if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
                raise ValueError(f"ViaPoint index: expected an integer sample index, got {index!r}")
            index = int(index)
            if abs(index) >= 2 ** 63:  # no trajectory has that many samples; keep the message short
                raise ValueError(f"ViaPoint index: expected a sample index within the signed 64-bit range, "
                                 f"got an integer of {_digits(index)}")
        else:
            phase = check_fraction(phase, name="ViaPoint phase")
        self.index = index
        self.phase = phase

    @property
    def n_dims(self) -> int:
        """Number of coordinates."""
        return int(self.position.shape[0])

    def sample(self, n_steps: int) -> int:
        """The sample index this via-point lands on in a trajectory of ``n_steps`` samples."""
        if self.phase is not None:
            # Round half up (not to even) so that phase 0.5 of 2 samples is the last one.
            return int(math.floor(self.phase * (n_steps - 1) + 0.5))
        i = self.index + n_steps if self.index < 0 else self.index
        if not 0 <= i < n_steps:
            raise ValueError(
                f"ViaPoint index: expected an index in [-{n_steps}, {n_steps}) for {n_steps} samples, "
                f"got {self.index}"
            )
        return i

    def __repr__(self) -> str:
        where = f"index={self.index}" if self.phase is None else f"phase={self.phase}"
        return f"ViaPoint({self.position.tolist()}, {where})"


class Constraints:
    """What a task asks of a trajectory: end points, via-points, velocities, obstacles.

    Parameters
    ----------
    start, goal : array-like of shape (n_dims,), optional
        First and last positions.
    via : sequence of ViaPoint or (phase, position) tuples, default=()
    start_velocity, end_velocity : array-like of shape (n_dims,), optional
        Velocities (units per second) at the first and last samples.
    obstacles : sequence of Obstacle, default=()
        Regions the trajectory must avoid (:class:`Sphere`, :class:`Box`, ...).
    start_orientation, goal_orientation : array-like of shape (4,), optional
        Orientations of the first and last samples: unit quaternions,
        scalar-last ``(x, y, z, w)`` (see :mod:`skillbank.core._rotations`;
        a norm within ``UNIT_TOLERANCE`` of 1 is renormalised).
    via_orientation : sequence of ViaPoint or (phase, quaternion) tuples, default=()
        Orientations at phases (or sample indices); a ViaPoint's ``position``
        holds the quaternion.

    Attributes
    ----------
    n_dims : int or None
        Common number of coordinates, None when no point is given.

    Examples
    --------
    >>> c = Constraints(start=[0.0, 0.0], goal=[1.0, 1.0], via=[(0.5, [0.5, 0.8])])
    >>> idx, pts = c.resolve(11)
    >>> idx.tolist(), pts[1].tolist()
    ([0, 5, 10], [0.5, 0.8])
    >>> c = Constraints(goal=[1.0, 1.0], goal_orientation=[0.0, 0.0, 1.0, 0.0])
    >>> c.has_orientation, c.resolve_orientation(11)[0].tolist()
    (True, [10])
    """

    def __init__(self, *, start=None, goal=None, via=(), start_velocity=None, end_velocity=None,
                 obstacles=(), start_orientation=None, goal_orientation=None, via_orientation=()):
        given = dict(start=start, goal=goal, start_velocity=start_velocity, end_velocity=end_velocity)
        for name, value in given.items():
            setattr(self, name, None if value is None else _point(value, name))
        self.via = tuple(self._as_via(v, k) for k, v in enumerate(self._as_list(via, "via")))
        obstacles = self._as_list(obstacles, "obstacles")
        for k, ob in enumerate(obstacles):
            if not isinstance(ob, Obstacle):
                raise ValueError(f"obstacles[{k}]: expected an Obstacle (Sphere, Box, ...), got "
                                 f"{type(ob).__name__}")
        self.obstacles = tuple(obstacles)
        for name, value in (("start_orientation", start_orientation), ("goal_orientation", goal_orientation)):
            setattr(self, name, None if value is None else _quaternion(value, name))
        vias = self._as_list(via_orientation, "via_orientation")
        self.via_orientation = tuple(self._as_orientation_via(v, k) for k, v in enumerate(vias))
        dims = self._dims()
        if len(set(dims.values())) > 1:
            # The first item sets the expectation; list the first few that differ from it.
            (first, n0), = list(dims.items())[:1]
            others = [f"{name} has {n}" for name, n in dims.items() if n != n0]
            raise ValueError(f"constraints: expected the same number of dimensions everywhere, got "
                             f"{first} has {n0}, {summarise(others)}")
        self.n_dims = next(iter(dims.values())) if dims else None

    @staticmethod
    def _as_list(value, name):
        if isinstance(value, (ViaPoint, Obstacle)):
            return [value]
        if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
            raise ValueError(f"{name}: expected a sequence, got {type(value).__name__}")
        return list(value)

    @staticmethod
    def _as_via(v, k):
        if isinstance(v, ViaPoint):
            return v
        if isinstance(v, (tuple, list)) and len(v) == 2:
            try:
                return ViaPoint(v[1], phase=v[0])
            except ValueError as exc:
                raise ValueError(f"via[{k}]: {exc}") from None
        raise ValueError(f"via[{k}]: expected a ViaPoint or a (phase, position) pair, got {v!r}")

    @staticmethod
    def _as_orientation_via(v, k):
        name = f"via_orientation[{k}]"
        if isinstance(v, ViaPoint):
            q = _quaternion(v.position, name)
            return ViaPoint(q, index=v.index) if v.phase is None else ViaPoint(q, phase=v.phase)
        if isinstance(v, (tuple, list)) and len(v) == 2:
            try:
                return ViaPoint(_quaternion(v[1], name), phase=v[0])
            except ValueError as exc:
                raise ValueError(f"{name}: {exc}") from None
        raise ValueError(f"{name}: expected a ViaPoint or a (phase, quaternion) pair, got {v!r}")

    def _dims(self) -> dict:
        dims = {k: getattr(self, k).shape[0] for k in _VECTORS if getattr(self, k) is not None}
        for k, v in enumerate(self.via):
            dims[f"via[{k}]"] = v.n_dims
        for k, ob in enumerate(self.obstacles):
            dims[f"obstacles[{k}]"] = ob.n_dims
        return dims

    @property
    def is_empty(self) -> bool:
        """True when no positional constraint (start, goal, via) is given."""
        return self.start is None and self.goal is None and not self.via

    @property
    def has_orientation(self) -> bool:
        """True when a start, goal or via orientation is given."""
        return (self.start_orientation is not None or self.goal_orientation is not None
                or bool(self.via_orientation))

    @property
    def has_velocity(self) -> bool:
        """True when a start or end velocity is given."""
        return self.start_velocity is not None or self.end_velocity is not None

    def check_dims(self, n_dims: int) -> None:
        """Raise ValueError naming the first constraint whose dimension is not ``n_dims``."""
        for name, n in self._dims().items():
            if n != n_dims:
                raise ValueError(
                    f"constraints: {name} has {n} dimensions but the trajectory has {n_dims}"
                )

    def resolve(self, n_steps: int):
        """Sorted unique sample indices ``(k,)`` and positions ``(k, n_dims)`` in ``n_steps`` samples.

        Raises ValueError when two different positions land on one sample.
        """
        n_steps = check_positive(n_steps, name="n_steps", integer=True)
        items = [(k, i, getattr(self, k)) for k, i in (("start", 0), ("goal", n_steps - 1))
                 if getattr(self, k) is not None]
        items += [(f"via[{k}]", v.sample(n_steps), v.position) for k, v in enumerate(self.via)]
        taken: dict[int, tuple[str, np.ndarray]] = {}
        for name, i, p in items:
            if i in taken:
                other, q = taken[i]
                if not np.allclose(p, q, rtol=1e-12, atol=1e-12):
                    raise ValueError(
                        f"constraints: {other} and {name} put different positions {q.tolist()} and "
                        f"{p.tolist()} on sample {i} of {n_steps}"
                    )
                continue
            taken[i] = (name, p)
        indices = np.array(sorted(taken), dtype=np.intp)
        width = self.n_dims if self.n_dims is not None else 0
        points = np.array([taken[i][1] for i in indices], dtype=float).reshape(len(indices), width)
        return indices, points

    def resolve_orientation(self, n_steps: int):
        """Sorted unique sample indices ``(k,)`` and unit quaternions ``(k, 4)`` of orientation constraints.

        Phases land on samples as for :meth:`resolve`. Raises ValueError when
        two different orientations (not ``q`` and ``-q``) land on one sample.

        Examples
        --------
        >>> c = Constraints(start_orientation=[0, 0, 0, 1.0], via_orientation=[(0.5, [0, 0, 1.0, 0])])
        >>> idx, qs = c.resolve_orientation(5)
        >>> idx.tolist(), qs[1].tolist()
        ([0, 2], [0.0, 0.0, 1.0, 0.0])
        """
        n_steps = check_positive(n_steps, name="n_steps", integer=True)
        ends = (("start_orientation", 0), ("goal_orientation", n_steps - 1))
        items = [(k, i, getattr(self, k)) for k, i in ends if getattr(self, k) is not None]
        items += [(f"via_orientation[{k}]", v.sample(n_steps), v.position)
                  for k, v in enumerate(self.via_orientation)]
        taken: dict[int, tuple[str, np.ndarray]] = {}
        for name, i, q in items:
            if i in taken:
                other, p = taken[i]
                if float(quaternion_angle(p, q)) > 1e-12:
                    raise ValueError(f"constraints: {other} and {name} put different orientations "
                                     f"{p.tolist()} and {q.tolist()} on sample {i} of {n_steps}")
                continue
            taken[i] = (name, q)
        indices = np.array(sorted(taken), dtype=np.intp)
        return indices, np.array([taken[i][1] for i in indices], dtype=float).reshape(len(indices), 4)

    def orientation_error(self, q) -> float:
        """Largest angle (radians) between a constrained sample of orientations ``q`` and its target.

        0.0 without orientation constraints. ``q`` and ``-q`` are the same orientation.

        Examples
        --------
        >>> c = Constraints(goal_orientation=[0.0, 0.0, 0.0, 1.0])
        >>> round(c.orientation_error([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, np.sin(0.05), np.cos(0.05)]]), 12)
        0.1
        """
        q = check_quaternions(q, name="q")
        if q.ndim != 2:
            raise ValueError(f"q: expected an orientation stream of shape (n, 4), got shape {q.shape}")
        idx, targets = self.resolve_orientation(q.shape[0])
        if idx.size == 0:
            return 0.0
        return float(quaternion_angle(q[idx], targets).max())

    def replace(self, **changes) -> Constraints:
        """A copy with some fields replaced, e.g. ``c.replace(via=(), end_velocity=None)``.

        Examples
        --------
        >>> Constraints(goal=[1.0], via=[(0.5, [2.0])]).replace(via=()).via
        ()
        """
        fields = ("start", "goal", "via", "start_velocity", "end_velocity", "obstacles", "start_orientation",
                  "goal_orientation", "via_orientation")
        unknown = sorted(set(changes) - set(fields))
        if unknown:
            raise ValueError(f"replace: expected fields among {list(fields)}, got {unknown}")
        return Constraints(**{k: changes.get(k, getattr(self, k)) for k in fields})

    def with_defaults(self, Y) -> Constraints:
        """A copy whose missing start / goal are taken from trajectory ``Y`` (n_steps, n_dims)."""
        Y = check_array(Y, name="Y", ndim=2)
        self.check_dims(Y.shape[1])
        return self.replace(start=Y[0] if self.start is None else self.start,
                            goal=Y[-1] if self.goal is None else self.goal)

    def _trajectory(self, Y) -> np.ndarray:
        Y = check_array(Y, name="Y", ndim=2)
        self.check_dims(Y.shape[1])
        return Y

    def signed_distances(self, Y) -> np.ndarray:
        """Signed distance of each sample to each obstacle; shape ``(n_obstacles, n_steps)``."""
        Y = self._trajectory(Y)
        if not self.obstacles:
            return np.empty((0, Y.shape[0]))
        return np.stack([ob.signed_distance(Y) for ob in self.obstacles])

    def collision_mask(self, Y) -> np.ndarray:
        """Samples strictly inside any obstacle; shape ``(n_steps,)``."""
        return (self.signed_distances(Y) < 0.0).any(axis=0)

    def collides(self, Y) -> bool:
        """True when ``Y`` collides with an obstacle: see :meth:`Obstacle.collides`.

        A sample strictly inside, or a segment between two consecutive samples
        through the inside, is a collision. This is the one definition used by
        editing, selection, metrics and the command line.

        Examples
        --------
        >>> from skillbank.core import Sphere
        >>> Constraints(obstacles=[Sphere([0.5, 0.0], 0.1)]).collides([[0.0, 0.0], [1.0, 0.0]])
        True
        """
        Y = self._trajectory(Y)
        return any(ob.collides(Y) for ob in self.obstacles)

    def position_error(self, Y) -> float:
        """Largest Euclidean distance between a constrained sample and its target (0.0 if none)."""
        Y = self._trajectory(Y)
        idx, pts = self.resolve(Y.shape[0])
        if idx.size == 0:
            return 0.0
        D = Y[idx] - pts
        return float(np.sqrt(np.einsum("ij,ij->i", D, D)).max())

    def velocities(self, Y, t=None):
        """Boundary velocities ``(v_start, v_end)`` by one-sided differences (``t``: unit spacing)."""
        Y = self._trajectory(Y)
        if Y.shape[0] < 2:
            raise ValueError(f"Y: expected at least 2 samples to measure velocity, got {Y.shape[0]}")
        t = np.arange(Y.shape[0], dtype=float) if t is None else check_time(t, n_steps=Y.shape[0])
        return (Y[1] - Y[0]) / (t[1] - t[0]), (Y[-1] - Y[-2]) / (t[-1] - t[-2])

    def velocity_error(self, Y, t=None) -> float:
        """Largest Euclidean error of the boundary velocities (0.0 without velocity constraints).

        Velocities are measured by one-sided first differences, ``(Y[1] - Y[0]) / (t[1] - t[0])``
        at the start and likewise at the end; ``t`` defaults to unit sample spacing.
        """
        if not self.has_velocity:
            self._trajectory(Y)
            return 0.0
        pairs = zip(self.velocities(Y, t), (self.start_velocity, self.end_velocity), strict=True)
        return float(max(np.linalg.norm(v - w) for v, w in pairs if w is not None))

    def __repr__(self) -> str:
        parts = [f"{k}={getattr(self, k).tolist()}" for k in _VECTORS if getattr(self, k) is not None]
        parts += [f"{k}={list(getattr(self, k))}" for k in ("via", "obstacles") if getattr(self, k)]
        parts += [f"{k}={getattr(self, k).tolist()}" for k in ("start_orientation", "goal_orientation")
                  if getattr(self, k) is not None]
        if self.via_orientation:
            parts.append(f"via_orientation={list(self.via_orientation)}")
        return f"Constraints({', '.join(parts)})"


_VECTORS = ("start", "goal", "start_velocity", "end_velocity")
