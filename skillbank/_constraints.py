"""Task constraints shared by trajectory editing and the LfD representations.

A :class:`Constraints` object holds what a new execution environment asks of a
trajectory: where it starts and ends, via-points it must pass, boundary
velocities, and regions (:class:`Sphere`, :class:`Box`) it must avoid. It works
in any number of dimensions and turns phases into sample indices with
:meth:`Constraints.resolve`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ._validation import check_array, check_fraction, check_positive, check_time

__all__ = ["Constraints", "ViaPoint", "Sphere", "Box"]


def _point(value, name: str) -> np.ndarray:
    return check_array(value, name=name, ndim=1, min_samples=1)


def _as_points(Y, n_dims: int) -> np.ndarray:
    """Samples as (n_steps, n_dims); a 1-D input is one point."""
    arr = check_array(Y, name="Y", ndim=(1, 2))
    if arr.ndim == 1:
        if arr.shape[0] != n_dims:
            raise ValueError(f"Y: expected a point with {n_dims} coordinates, got {arr.shape[0]}")
        return arr[None, :]
    if arr.shape[1] != n_dims:
        raise ValueError(f"Y: expected {n_dims} columns to match the obstacle, got {arr.shape[1]}")
    return arr


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


class Sphere:
    """A ball the trajectory must stay out of.

    Parameters
    ----------
    center : array-like of shape (n_dims,)
    radius : float > 0

    Examples
    --------
    >>> Sphere([0.0, 0.0], 1.0).signed_distance([[2.0, 0.0], [0.0, 0.5]]).tolist()
    [1.0, -0.5]
    """

    def __init__(self, center, radius):
        self.center = _point(center, "sphere center")
        self.radius = check_positive(radius, name="sphere radius")

    @property
    def n_dims(self) -> int:
        """Number of coordinates."""
        return int(self.center.shape[0])

    def _points(self, Y) -> np.ndarray:
        return _as_points(Y, self.n_dims)

    def signed_distance(self, Y) -> np.ndarray:
        """Distance of each sample to the surface, negative inside; shape ``(n_steps,)``."""
        D = self._points(Y) - self.center
        return np.sqrt(np.einsum("ij,ij->i", D, D)) - self.radius

    def exterior_point(self, Y, *, margin: float = 0.0, fallback=None) -> np.ndarray:
        """Nearest points at distance ``margin`` outside the surface.

        A sample exactly at the center has no nearest direction; it is moved
        along ``fallback`` (one vector per sample, e.g. the path's normal),
        else along the first axis.
        """
        Y = self._points(Y)
        D = Y - self.center
        norm = np.sqrt(np.einsum("ij,ij->i", D, D))
        at_center = norm <= 1e-12 * max(1.0, self.radius)
        if at_center.any():
            if fallback is None:
                fb = np.zeros_like(D)
                fb[:, 0] = 1.0
            else:
                fb = np.broadcast_to(np.asarray(fallback, dtype=float), D.shape)
            D = np.where(at_center[:, None], fb, D)
            norm = np.sqrt(np.einsum("ij,ij->i", D, D))
        return self.center + D * ((self.radius + margin) / norm)[:, None]

    def __repr__(self) -> str:
        return f"Sphere({self.center.tolist()}, {self.radius})"


class Box:
    """An axis-aligned box the trajectory must stay out of.

    Parameters
    ----------
    lower, upper : array-like of shape (n_dims,)
        Opposite corners, ``lower < upper`` in every coordinate.

    Examples
    --------
    >>> Box([0.0, 0.0], [2.0, 2.0]).signed_distance([[1.0, 1.5], [3.0, 1.0]]).tolist()
    [-0.5, 1.0]
    """

    def __init__(self, lower, upper):
        self.lower = _point(lower, "box lower")
        self.upper = _point(upper, "box upper")
        if self.lower.shape != self.upper.shape:
            raise ValueError(
                f"box: expected lower and upper corners of equal length, got {self.lower.shape[0]} "
                f"and {self.upper.shape[0]}"
            )
        if not np.all(self.lower < self.upper):
            raise ValueError(
                f"box: expected lower < upper in every coordinate, got lower={self.lower.tolist()} "
                f"upper={self.upper.tolist()}"
            )

    @property
    def n_dims(self) -> int:
        """Number of coordinates."""
        return int(self.lower.shape[0])

    def _points(self, Y) -> np.ndarray:
        return _as_points(Y, self.n_dims)

    def signed_distance(self, Y) -> np.ndarray:
        """Euclidean distance to the box surface, negative inside; shape ``(n_steps,)``."""
        Y = self._points(Y)
        q = np.maximum(self.lower - Y, Y - self.upper)  # per-axis distance outside (>0) / inside (<0)
        outside = np.sqrt(np.einsum("ij,ij->i", np.maximum(q, 0.0), np.maximum(q, 0.0)))
        return outside + np.minimum(q.max(axis=1), 0.0)

    def exterior_point(self, Y, *, margin: float = 0.0, fallback=None) -> np.ndarray:
        """Nearest points at distance ``margin`` outside, through the nearest face (no fallback needed)."""
        Y = self._points(Y).copy()
        to_low = Y - self.lower
        to_up = self.upper - Y
        depth = np.minimum(to_low, to_up)
        axis = np.argmin(depth, axis=1)
        rows = np.arange(Y.shape[0])
        low_side = to_low[rows, axis] <= to_up[rows, axis]
        Y[rows, axis] = np.where(low_side, self.lower[axis] - margin, self.upper[axis] + margin)
        return Y

    def __repr__(self) -> str:
        return f"Box({self.lower.tolist()}, {self.upper.tolist()})"


class Constraints:
    """What a task asks of a trajectory: end points, via-points, velocities, obstacles.

    Parameters
    ----------
    start, goal : array-like of shape (n_dims,), optional
        First and last positions.
    via : sequence of ViaPoint or (phase, position) tuples, default=()
    start_velocity, end_velocity : array-like of shape (n_dims,), optional
        Velocities (units per second) at the first and last samples.
    obstacles : sequence of Sphere or Box, default=()
        Regions the trajectory must avoid.

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
    """

    def __init__(self, *, start=None, goal=None, via=(), start_velocity=None, end_velocity=None,
                 obstacles=()):
        given = dict(start=start, goal=goal, start_velocity=start_velocity, end_velocity=end_velocity)
        for name, value in given.items():
            setattr(self, name, None if value is None else _point(value, name))
        self.via = tuple(self._as_via(v, k) for k, v in enumerate(self._as_list(via, "via")))
        obstacles = self._as_list(obstacles, "obstacles")
        for k, ob in enumerate(obstacles):
            if not isinstance(ob, (Sphere, Box)):
                raise ValueError(f"obstacles[{k}]: expected a Sphere or Box, got {type(ob).__name__}")
        self.obstacles = tuple(obstacles)
        dims = self._dims()
        if len(set(dims.values())) > 1:
            listing = ", ".join(f"{name} has {n}" for name, n in dims.items())
            raise ValueError(f"constraints: expected the same number of dimensions everywhere, got {listing}")
        self.n_dims = next(iter(dims.values())) if dims else None

    @staticmethod
    def _as_list(value, name):
        if isinstance(value, (ViaPoint, Sphere, Box)):
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

    def with_defaults(self, Y) -> Constraints:
        """A copy whose missing start / goal are taken from trajectory ``Y`` (n_steps, n_dims)."""
        Y = check_array(Y, name="Y", ndim=2)
        self.check_dims(Y.shape[1])
        return Constraints(
            start=Y[0] if self.start is None else self.start,
            goal=Y[-1] if self.goal is None else self.goal,
            via=self.via, start_velocity=self.start_velocity, end_velocity=self.end_velocity,
            obstacles=self.obstacles,
        )

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
        """True when any sample is strictly inside an obstacle."""
        return bool(self.collision_mask(Y).any())

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

    @classmethod
    def from_cli(cls, start=None, goal=None, via=(), obstacle=(), *, start_velocity=None,
                 end_velocity=None) -> Constraints:
        """Build constraints from command-line strings.

        Parameters
        ----------
        start, goal, start_velocity, end_velocity : str, optional
            ``"X,Y[,Z...]"``.
        via : sequence of str
            ``"PHASE:X,Y[,Z...]"`` with PHASE in [0, 1].
        obstacle : sequence of str
            ``"sphere:X,Y,Z,R"`` or ``"box:XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX"``
            (in 2-D ``"sphere:X,Y,R"`` and ``"box:XMIN,YMIN,XMAX,YMAX"``).

        Examples
        --------
        >>> c = Constraints.from_cli(start="0,0", goal="1,1", via=["0.5:0.5,0.9"],
        ...                          obstacle=["sphere:0.5,0.5,0.1"])
        >>> c.n_dims, len(c.via), c.obstacles[0].radius
        (2, 1, 0.1)
        """
        via, obstacle = ([v] if isinstance(v, str) else v for v in (via, obstacle))
        vias = []
        for text in via or ():
            phase, sep, coords = str(text).partition(":")
            if not sep:
                raise ValueError(f"via: expected 'PHASE:X,Y[,Z]', got {text!r}")
            vias.append(ViaPoint(_numbers(coords, "via", text), phase=_number(phase, "via phase", text)))
        obstacles = [_parse_obstacle(str(text)) for text in (obstacle or ())]
        given = dict(start=start, goal=goal, start_velocity=start_velocity, end_velocity=end_velocity)
        vec = {k: None if v is None else _numbers(str(v), k, v) for k, v in given.items()}
        return cls(via=vias, obstacles=obstacles, **vec)

    def __repr__(self) -> str:
        parts = [f"{k}={getattr(self, k).tolist()}" for k in _VECTORS if getattr(self, k) is not None]
        parts += [f"{k}={list(getattr(self, k))}" for k in ("via", "obstacles") if getattr(self, k)]
        return f"Constraints({', '.join(parts)})"


_VECTORS = ("start", "goal", "start_velocity", "end_velocity")


def _number(text: str, name: str, whole) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{name}: expected a number, got {text.strip()!r} in {whole!r}") from None
    if not np.isfinite(value):
        raise ValueError(f"{name}: expected a finite number, got {text.strip()!r} in {whole!r}")
    return value


def _numbers(text: str, name: str, whole) -> list[float]:
    parts = text.split(",")
    if not text.strip() or any(not p.strip() for p in parts):
        raise ValueError(f"{name}: expected comma-separated numbers like '0.1,0.2,0.3', got {whole!r}")
    return [_number(p, name, whole) for p in parts]


def _parse_obstacle(text: str):
    kind, sep, coords = text.partition(":")
    kind = kind.strip().lower()
    usage = "'sphere:X,Y[,Z],R' or 'box:XMIN,YMIN[,ZMIN],XMAX,YMAX[,ZMAX]'"
    if not sep or kind not in ("sphere", "box"):
        raise ValueError(f"obstacle: expected {usage}, got {text!r}")
    values = _numbers(coords, "obstacle", text)
    if kind == "sphere" and len(values) < 2:
        raise ValueError(f"obstacle: a sphere needs a center and a radius, got {len(values)} "
                         f"number(s) in {text!r}")
    if kind == "box" and len(values) % 2:
        raise ValueError(f"obstacle: a box needs an even number of values (lower then upper corner), "
                         f"got {len(values)} in {text!r}")
    try:
        if kind == "sphere":
            return Sphere(values[:-1], values[-1])
        return Box(values[: len(values) // 2], values[len(values) // 2:])
    except ValueError as exc:
        raise ValueError(f"obstacle {text!r}: {exc}") from None
