"""Obstacle geometry: one abstract type, its shapes, their registry and the one collision test.

Everything that asks whether a trajectory hits something (trajectory editing,
selection of candidates, metrics, the command line) goes through
:meth:`Obstacle.collides`: a trajectory collides when a sample lies strictly
inside an obstacle **or** the straight segment between two consecutive
samples passes through its inside. Checking the samples alone misses a
coarsely sampled path that jumps over a thin obstacle.

A shape is one subclass of :class:`Obstacle` plus one line in
:data:`OBSTACLES`; the text spec ``"kind:v1,v2,..."`` (the ``--obstacle``
syntax, also used by scene files) is read through that registry.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

from ._validation import MAX_MAGNITUDE, check_array, check_positive

__all__ = ["Obstacle", "Sphere", "Box", "OBSTACLES", "parse_obstacle"]


def _point(value, name: str) -> np.ndarray:
    return check_array(value, name=name, ndim=1, min_samples=1)


def _rows_dot(A, B) -> np.ndarray:
    return np.einsum("ij,ij->i", A, B)


class Obstacle(ABC):
    """A region a trajectory must stay out of.

    Subclasses implement the geometry: :meth:`signed_distance`,
    :meth:`segment_hits`, :meth:`push_out`, :attr:`size`, :meth:`bounds`,
    :meth:`outline`, and the spec round trip :meth:`from_values` /
    :meth:`values` with the class attribute ``kind``. Everything else
    (:meth:`collides`, :meth:`spec`, checking input) is shared.
    """

    kind: ClassVar[str] = ""
    #: How the spec's numbers are laid out, for error messages.
    usage: ClassVar[str] = ""

    @property
    @abstractmethod
    def n_dims(self) -> int:
        """Number of coordinates."""

    @property
    @abstractmethod
    def size(self) -> float:
        """A characteristic half-size (radius, or half the smallest side); clearances scale with it."""

    @abstractmethod
    def signed_distance(self, Y) -> np.ndarray:
        """Distance of each sample to the surface, negative inside; shape ``(n_steps,)``."""

    @abstractmethod
    def _segment_hits(self, A: np.ndarray, B: np.ndarray) -> np.ndarray:
        """Whether each segment ``A[i] -> B[i]`` passes through the open inside; shape ``(n,)``."""

    @abstractmethod
    def push_out(self, Y: np.ndarray, T: np.ndarray, margin: float) -> np.ndarray:
        """Move samples ``Y`` (inside) to ``margin`` outside, across the path (unit tangents ``T``)."""

    @abstractmethod
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corners of the axis-aligned box around the obstacle."""

    @abstractmethod
    def outline(self, resolution: int = 48) -> list[np.ndarray]:
        """Polylines to draw: in 2-D one closed polygon, in 3-D the lines of a wireframe."""

    @classmethod
    @abstractmethod
    def from_values(cls, values) -> Obstacle:
        """Build the obstacle from the flat list of numbers of its spec."""

    @abstractmethod
    def values(self) -> list[float]:
        """The flat list of numbers of its spec (inverse of :meth:`from_values`)."""

    # -- shared ----------------------------------------------------------------------------------
    def _points(self, Y) -> np.ndarray:
        """Samples as (n_steps, n_dims); a 1-D input is one point."""
        arr = check_array(Y, name="Y", ndim=(1, 2))
        if arr.ndim == 1:
            if arr.shape[0] != self.n_dims:
                raise ValueError(f"Y: expected a point with {self.n_dims} coordinates, got {arr.shape[0]}")
            return arr[None, :]
        if arr.shape[1] != self.n_dims:
            raise ValueError(f"Y: expected {self.n_dims} columns to match the obstacle, got {arr.shape[1]}")
        return arr

    def segment_hits(self, Y) -> np.ndarray:
        """Segments ``Y[i] -> Y[i+1]`` that pass through the inside; shape ``(n_steps - 1,)``."""
        P = self._points(Y)
        return self._segment_hits(P[:-1], P[1:])

    def collides(self, Y) -> bool:
        """True when a sample is strictly inside or a segment between two samples crosses the inside.

        Examples
        --------
        >>> Sphere([0.5, 0.0], 0.1).collides([[0.0, 0.0], [1.0, 0.0]])  # no sample inside
        True
        """
        P = self._points(Y)
        if bool((self.signed_distance(P) < 0.0).any()):
            return True
        return P.shape[0] > 1 and bool(self._segment_hits(P[:-1], P[1:]).any())

    def first_contact(self, Y) -> int:
        """The first sample :meth:`collides` would find: strictly inside, or whose segment to the next
        crosses the inside (its earlier end); -1 when none.

        Examples
        --------
        >>> Sphere([0.5, 0.0], 0.1).first_contact([[0.0, 0.0], [0.2, 0.0], [1.0, 0.0]])
        1
        """
        P = self._points(Y)
        inside = np.flatnonzero(self.signed_distance(P) < 0.0)
        crossing = np.flatnonzero(self._segment_hits(P[:-1], P[1:])) if P.shape[0] > 1 else inside[:0]
        hits = [int(x[0]) for x in (inside, crossing) if x.size]
        return min(hits) if hits else -1

    def spec(self) -> str:
        """The text spec, e.g. ``"sphere:0.5,0,0.1"``; :func:`parse_obstacle` reads it back."""
        return f"{self.kind}:" + ",".join(repr(float(v)) for v in self.values())

    def __eq__(self, other) -> bool:
        return type(other) is type(self) and np.array_equal(self.values(), other.values())

    def __hash__(self) -> int:
        return hash((self.kind, tuple(self.values())))


class Sphere(Obstacle):
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

    kind = "sphere"
    usage = "sphere:X,Y[,Z],R"

    def __init__(self, center, radius):
        self.center = _point(center, "sphere center")
        self.radius = check_positive(radius, name="sphere radius")

    @property
    def n_dims(self) -> int:
        return int(self.center.shape[0])

    @property
    def size(self) -> float:
        return float(self.radius)

    def signed_distance(self, Y) -> np.ndarray:
        D = self._points(Y) - self.center
        return np.sqrt(_rows_dot(D, D)) - self.radius

    def _segment_hits(self, A, B) -> np.ndarray:
        V = B - A
        vv = _rows_dot(V, V)
        s = np.clip(_rows_dot(self.center - A, V) / np.where(vv > 0, vv, 1.0), 0.0, 1.0)
        closest = A + s[:, None] * V - self.center
        return _rows_dot(closest, closest) < self.radius**2

    def push_out(self, Y, T, margin) -> np.ndarray:
        D = Y - self.center
        U = D - T * _rows_dot(D, T)[:, None]  # away from the centre, across the path
        length = np.linalg.norm(U, axis=1)
        flat = length <= 1e-9 * self.radius
        if flat.any():  # through the centre: any direction normal to the tangent
            axis = np.argmin(np.abs(T[flat]), axis=1)
            V = np.zeros((int(flat.sum()), Y.shape[1]))
            V[np.arange(len(axis)), axis] = 1.0
            V -= T[flat] * _rows_dot(V, T[flat])[:, None]
            U[flat] = V
            length[flat] = np.linalg.norm(V, axis=1)
        along = length <= 1e-12  # 1-D: no direction across the path, so out along it, away from the centre
        if along.any():
            U[along] = np.where(D[along] >= 0.0, 1.0, -1.0) if Y.shape[1] == 1 else T[along]
            length[along] = np.linalg.norm(U[along], axis=1)
        U /= np.where(length > 0, length, 1.0)[:, None]
        # Y + s U on the sphere of radius r + margin; Y is inside, so one root is positive.
        b = _rows_dot(U, D)
        s = -b + np.sqrt(b * b - (_rows_dot(D, D) - (self.radius + margin) ** 2))
        return Y + s[:, None] * U

    def bounds(self):
        return self.center - self.radius, self.center + self.radius

    def outline(self, resolution: int = 48) -> list[np.ndarray]:
        c, r = self.center, self.radius
        u = np.linspace(0.0, 2.0 * np.pi, resolution + 1)
        if self.n_dims == 2:
            return [c + r * np.column_stack([np.cos(u), np.sin(u)])]
        if self.n_dims != 3:
            return []
        lines = []
        for v in np.linspace(0.0, np.pi, 9)[1:-1]:  # parallels
            lines.append(c + r * np.column_stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v),
                                                  np.full_like(u, np.cos(v))]))
        v = np.linspace(0.0, np.pi, resolution // 2 + 1)
        for a in np.linspace(0.0, 2.0 * np.pi, 13)[:-1]:  # meridians
            lines.append(c + r * np.column_stack([np.cos(a) * np.sin(v), np.sin(a) * np.sin(v), np.cos(v)]))
        return lines

    @classmethod
    def from_values(cls, values) -> Sphere:
        if len(values) < 2:
            raise ValueError(f"a sphere needs a center and a radius, got {len(values)} number(s)")
        return cls(values[:-1], values[-1])

    def values(self) -> list[float]:
        return [*self.center.tolist(), float(self.radius)]

    def __repr__(self) -> str:
        return f"Sphere({self.center.tolist()}, {self.radius})"


class Box(Obstacle):
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

    kind = "box"
    usage = "box:XMIN,YMIN[,ZMIN],XMAX,YMAX[,ZMAX]"

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
        return int(self.lower.shape[0])

    @property
    def size(self) -> float:
        return 0.5 * float(np.min(self.upper - self.lower))

    def signed_distance(self, Y) -> np.ndarray:
        Y = self._points(Y)
        q = np.maximum(self.lower - Y, Y - self.upper)  # per-axis distance outside (>0) / inside (<0)
        outside = np.maximum(q, 0.0)
        return np.sqrt(_rows_dot(outside, outside)) + np.minimum(q.max(axis=1), 0.0)

    def _segment_hits(self, A, B) -> np.ndarray:
        V = B - A
        # a tiny step overflows to +-inf, the right limit of the slab parameter
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            t1, t2 = (self.lower - A) / V, (self.upper - A) / V
        still = V == 0
        inside_slab = (A > self.lower) & (A < self.upper)
        t_lo = np.where(still, np.where(inside_slab, -np.inf, np.inf), np.minimum(t1, t2))
        t_hi = np.where(still, np.where(inside_slab, np.inf, -np.inf), np.maximum(t1, t2))
        enter, leave = np.maximum(t_lo.max(axis=1), 0.0), np.minimum(t_hi.min(axis=1), 1.0)
        return enter < leave

    def push_out(self, Y, T, margin) -> np.ndarray:
        lo, hi = Y - self.lower, self.upper - Y
        depth = np.minimum(lo, hi)
        if Y.shape[1] > 1:  # not along the axis the path mostly follows
            depth[np.arange(Y.shape[0]), np.argmax(np.abs(T), axis=1)] = np.inf
        axis = np.argmin(depth, axis=1)
        k = np.arange(Y.shape[0])
        out = Y.copy()
        out[k, axis] = np.where(lo[k, axis] <= hi[k, axis], self.lower[axis] - margin,
                                self.upper[axis] + margin)
        return out

    def bounds(self):
        return self.lower.copy(), self.upper.copy()

    def outline(self, resolution: int = 48) -> list[np.ndarray]:
        lo, hi = self.lower, self.upper
        if self.n_dims == 2:
            corners = [[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]], [lo[0], lo[1]]]
            return [np.array(corners)]
        if self.n_dims != 3:
            return []
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
        # The 12 edges join corners that differ in exactly one coordinate (one bit of the index).
        return [corners[[i, i | bit]] for i in range(8) for bit in (1, 2, 4) if not i & bit]

    @classmethod
    def from_values(cls, values) -> Box:
        if len(values) % 2 or not values:
            raise ValueError(f"a box needs an even number of values (lower then upper corner), "
                             f"got {len(values)}")
        half = len(values) // 2
        return cls(values[:half], values[half:])

    def values(self) -> list[float]:
        return [*self.lower.tolist(), *self.upper.tolist()]

    def __repr__(self) -> str:
        return f"Box({self.lower.tolist()}, {self.upper.tolist()})"


#: Obstacle shapes by spec name; a new shape is one class and one line here.
OBSTACLES: dict[str, type[Obstacle]] = {"sphere": Sphere, "box": Box}


def _short(text: str, limit: int = 40) -> str:
    """``repr`` of user text, cut so that a message stays one short line."""
    text = text.strip()
    return repr(text if len(text) <= limit else text[:limit - 3] + "...")


def _number(text: str, whole: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"obstacle: expected a number, got {_short(text, 20)} in {_short(whole)}") from None
    literal = text.strip().lower().lstrip("+-") in ("nan", "inf", "infinity")
    if literal:
        raise ValueError(f"obstacle: expected a finite number, got {_short(text, 20)} in {_short(whole)}")
    if not np.isfinite(value) or abs(value) > MAX_MAGNITUDE:  # inf here: a literal beyond float64
        raise ValueError(f"obstacle: expected numbers of magnitude at most {MAX_MAGNITUDE:g} (larger ones "
                         f"overflow the solvers), got {_short(text, 20)} in {_short(whole)}")
    return value


def parse_obstacle(text) -> Obstacle:
    """Read an obstacle spec ``"kind:v1,v2,..."``, e.g. ``"sphere:0.5,0,0.1"`` or ``"box:0,0,1,1"``.

    The kinds are the keys of :data:`OBSTACLES`; the numbers are each shape's
    :meth:`Obstacle.from_values`. This is the ``--obstacle`` syntax of the
    command line and the obstacle syntax of scene files.

    Examples
    --------
    >>> parse_obstacle("sphere:0.5,0.5,0.1")
    Sphere([0.5, 0.5], 0.1)
    >>> parse_obstacle(Box([0, 0], [1, 2]).spec())
    Box([0.0, 0.0], [1.0, 2.0])
    """
    if not isinstance(text, str):
        raise ValueError(f"obstacle: expected a spec string like 'sphere:X,Y,Z,R', got {type(text).__name__}")
    kind, sep, coords = text.partition(":")
    kind = kind.strip().lower()
    usage = " or ".join(f"'{cls.usage}'" for cls in OBSTACLES.values())
    if not sep or kind not in OBSTACLES:
        raise ValueError(f"obstacle: expected {usage}, got {_short(text)}")
    parts = coords.split(",")
    if not coords.strip() or any(not p.strip() for p in parts):
        raise ValueError(f"obstacle: expected comma-separated numbers after '{kind}:', got {_short(text)}")
    values = [_number(p, text) for p in parts]
    try:
        return OBSTACLES[kind].from_values(values)
    except ValueError as exc:
        raise ValueError(f"obstacle {_short(text)}: {exc}") from None
