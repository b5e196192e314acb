"""Whole-arm clearance: every body of a robot against obstacles, a table, workspace bounds and itself.

:func:`clearance` places the robot's capsules (:attr:`RobotModel.bodies`)
at every sample of a joint trajectory and measures, all at once (samples x
bodies x obstacles in numpy arrays), the signed distance of every capsule
to every obstacle (exact for spheres and boxes), to the table, to the
inside of the workspace bounds and to every other capsule it may not touch
(self-collision). Negative distances are overlaps.

Between samples a body could jump over a thin obstacle, so the trajectory
is densified first: interpolated joint samples are inserted wherever a body
point could move by more than ``max_move`` between consecutive samples. A
point's path between two samples interpolated linearly in joint space is no
longer than ``sum_j |dq_j| rho_j``, ``rho_j`` the largest distance from joint
``j``'s axis of any capsule point it moves (link lengths plus the capsule's
extent), so with that rule every configuration in between has every body
point within ``max_move / 2`` of where it is at a checked sample, and the
true smallest distance is at least the reported one minus ``max_move / 2``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..core._obstacles import Box, Obstacle, Sphere
from ..core._validation import check_array, check_positive, summarise

__all__ = ["Clearance", "clearance", "segment_distance", "segment_box_distance"]

#: Samples measured at once: bounds the memory of the (samples x pairs) arrays.
_CHUNK = 8192
#: Most samples after densification; beyond it the trajectory's steps are far too coarse.
_MAX_SAMPLES = 10_000_000
#: ``max_move`` when not given, as a fraction of the smallest capsule radius.
MAX_MOVE_FRACTION = 0.2


def _dot(u, v):
    return np.einsum("...i,...i->...", u, v)


def segment_distance(p0, p1, q0, q1) -> np.ndarray:
    """Distance between segments ``p0 -> p1`` and ``q0 -> q1`` (broadcast over leading axes).

    The closest points of the two lines clamped to the segments, the
    degenerate cases (a point, parallel segments) included.

    Examples
    --------
    >>> float(segment_distance([0, 0, 0], [1, 0, 0], [0.5, 1, -1], [0.5, 1, 1]))
    1.0
    """
    p0, p1, q0, q1 = (np.asarray(x, dtype=float) for x in (p0, p1, q0, q1))
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e, f = _dot(d1, d1), _dot(d2, d2), _dot(d2, r)
    c, b = _dot(d1, r), _dot(d1, d2)
    tiny = 1e-300
    point_p, point_q = a <= tiny, e <= tiny
    denom = a * e - b * b
    safe_a, safe_e = np.where(point_p, 1.0, a), np.where(point_q, 1.0, e)
    # general case: s on the infinite lines (0 when parallel: any s is as good), then t, then s again
    parallel = denom <= 1e-12 * np.maximum(a * e, tiny)
    s = np.where(parallel, 0.0, np.clip((b * f - c * e) / np.where(parallel, 1.0, denom), 0.0, 1.0))
    t = (b * s + f) / safe_e
    s = np.where(t < 0.0, np.clip(-c / safe_a, 0.0, 1.0),
                 np.where(t > 1.0, np.clip((b - c) / safe_a, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    # one or both segments a point
    s = np.where(point_p, 0.0, np.where(point_q, np.clip(-c / safe_a, 0.0, 1.0), s))
    t = np.where(point_q, 0.0, np.where(point_p, np.clip(f / safe_e, 0.0, 1.0), t))
    gap = p0 + s[..., None] * d1 - (q0 + t[..., None] * d2)
    return np.sqrt(_dot(gap, gap))


def _point_segment(a, b, p) -> np.ndarray:
    ab = b - a
    L = _dot(ab, ab)
    s = np.clip(_dot(p - a, ab) / np.where(L > 0, L, 1.0), 0.0, 1.0)
    gap = a + s[..., None] * ab - p
    return np.sqrt(_dot(gap, gap))


def _box_sdf(p, lower, upper) -> np.ndarray:
    q = np.maximum(lower - p, p - upper)
    outside = np.maximum(q, 0.0)
    return np.sqrt(_dot(outside, outside)) + np.minimum(q.max(axis=-1), 0.0)


def segment_box_distance(a, b, lower, upper) -> np.ndarray:
    """Smallest signed distance from segment ``a -> b`` to an axis-aligned box (negative: inside it).

    Exact: along the segment the signed distance is smooth between
    breakpoints (where a coordinate crosses a face's plane or the box's
    mid-plane, or two axes' depths inside are equal): a quadratic outside
    the box, linear inside. Its minimum is at a breakpoint or at the
    stationary point of a quadratic piece, and all of those candidates are
    evaluated at once. Broadcasts over leading axes.

    Examples
    --------
    >>> float(segment_box_distance([-1, 0, 2], [1, 0, 2], [-1, -1, -1], [1, 1, 1]))
    1.0
    >>> float(segment_box_distance([-2, 0, 0], [2, 0, 0], [-1, -1, -1], [1, 1, 1]))
    -1.0
    """
    # a tiny step puts a crossing at +-inf before clipping: the right limit, so no warning
    with np.errstate(over="ignore", divide="ignore"):
        return _segment_box(a, b, lower, upper)


def _segment_box(a, b, lower, upper) -> np.ndarray:
    a, b, lower, upper = (np.asarray(x, dtype=float) for x in (a, b, lower, upper))
    shape = np.broadcast_shapes(a.shape, b.shape, lower.shape, upper.shape)
    a, b, lower, upper = (np.broadcast_to(x, shape) for x in (a, b, lower, upper))
    v = b - a
    moving = v != 0.0
    safe = np.where(moving, v, 1.0)

    def at(value):  # where coordinate k reaches value[..., k] (0 when it does not move)
        return np.where(moving, np.clip((value - a) / safe, 0.0, 1.0), 0.0)

    ends = [np.zeros(shape[:-1] + (1,)), np.ones(shape[:-1] + (1,))]
    faces = np.concatenate([at(lower), at(upper)], axis=-1)  # (..., 6)
    breaks = np.sort(np.concatenate(ends + [faces], axis=-1), axis=-1)  # (..., 8)
    lo, hi = breaks[..., :-1], breaks[..., 1:]  # the 7 pieces between face crossings
    mid = a[..., None, :] + ((lo + hi) / 2)[..., None] * v[..., None, :]  # (..., 7, 3)
    below, above = mid < lower[..., None, :], mid > upper[..., None, :]
    bound = np.where(below, lower[..., None, :], upper[..., None, :])
    out = below | above
    vv = np.where(out, v[..., None, :] ** 2, 0.0).sum(axis=-1)
    av = np.where(out, (a[..., None, :] - bound) * v[..., None, :], 0.0).sum(axis=-1)
    stationary = np.clip(-av / np.where(vv > 0, vv, 1.0), lo, hi)
    candidates = np.concatenate(ends + [faces, stationary], axis=-1)
    points = a[..., None, :] + candidates[..., None] * v[..., None, :]
    out = _box_sdf(points, lower[..., None, :], upper[..., None, :]).min(axis=-1)
    # A segment that reaches the box reaches it at an end or a face crossing (a candidate at <= 0, up to
    # the round-off of the crossing's point: the extra candidates are harmless when not needed); only then
    # can the minimum be inside, at a mid-plane crossing or where two axes' depths are equal.
    inside = out <= 1e-9 * (1.0 + np.abs(upper - lower).max(axis=-1) + np.abs(v).max(axis=-1))
    if inside.any():
        out = np.array(out)  # writable, also for one segment
        a, v, lower, upper = a[inside], v[inside], lower[inside], upper[inside]
        extra = _inside_breaks(a, v, lower, upper)
        points = a[:, None, :] + extra[..., None] * v[:, None, :]
        deeper = _box_sdf(points, lower[:, None, :], upper[:, None, :]).min(axis=-1)
        out[inside] = np.minimum(out[inside], deeper)
    return out


def _inside_breaks(a, v, lower, upper) -> np.ndarray:
    """Where a segment inside a box may have its deepest point: ``(m, 15)`` parameters in [0, 1].

    Inside, the depth along axis k, ``max(lower_k - p_k, p_k - upper_k)``, is linear on each side of
    the box's mid-plane, ``c + d s`` with ``(c, d) = (lower - a, -v)`` or ``(a - upper, v)``; the signed
    distance is the largest of the three, so its kinks are the mid-plane crossings and where two axes'
    branches are equal.
    """
    moving = v != 0.0
    middle = np.where(moving, np.clip(((lower + upper) / 2 - a) / np.where(moving, v, 1.0), 0.0, 1.0), 0.0)
    branch_c = np.stack([lower - a, a - upper], axis=-1)  # (m, 3, 2)
    branch_d = np.stack([-v, v], axis=-1)
    equal = []
    for i, j in ((0, 1), (0, 2), (1, 2)):
        for bi in range(2):
            for bj in range(2):
                dd = branch_d[..., i, bi] - branch_d[..., j, bj]
                cc = branch_c[..., j, bj] - branch_c[..., i, bi]
                ok = dd != 0.0
                equal.append(np.where(ok, np.clip(cc / np.where(ok, dd, 1.0), 0.0, 1.0), 0.0))
    return np.concatenate([middle, np.stack(equal, axis=-1)], axis=-1)


@dataclass
class Clearance:
    """The whole robot's clearance along a joint trajectory (:func:`clearance`).

    Attributes
    ----------
    distance : ndarray of shape (n,)
        Per caller sample, the smallest signed distance (m) over every checked pair, over the
        densified samples nearest it; negative: an overlap.
    min_distance : float
    index : int
        The caller's sample where the distance is smallest (nearest the densified sample).
    time : float or None
        When it is smallest (interpolated between samples), if ``t`` was given.
    body, other : str
        The limiting pair: a body's name, and an obstacle's name, ``"table"``, ``"workspace"`` or
        another body's (self-collision).
    per_pair : dict of (str, str) to float
        The smallest distance of every checked (body, other) pair.
    pair : ndarray of shape (n,) of int
        Per caller sample, the limiting pair as an index into :attr:`pairs`.
    pairs : tuple of (str, str)
        Every checked pair, in the order of ``per_pair``.
    t : ndarray of shape (n,) or None
        The caller's times, if given.
    n_checked : int
        Configurations checked after densification.
    max_move : float
        The densification bound used (m).
    """

    distance: np.ndarray
    min_distance: float
    index: int
    time: float | None
    body: str
    other: str
    per_pair: dict
    pair: np.ndarray = field(repr=False)
    pairs: tuple = field(repr=False)
    t: np.ndarray | None = field(default=None, repr=False)
    n_checked: int = 0
    max_move: float = 0.0

    def collides(self, margin: float = 0.0) -> bool:
        """Whether any body comes closer than ``margin`` (m) to anything it is checked against."""
        return bool(self.min_distance < check_positive(margin, name="margin", allow_zero=True))

    def first_contact(self, margin: float = 0.0):
        """``(index, body, other)`` of the first caller sample closer than ``margin``, or None."""
        margin = check_positive(margin, name="margin", allow_zero=True)
        close = np.flatnonzero(self.distance < margin)
        if not close.size:
            return None
        k = int(close[0])
        body, other = self.pairs[int(self.pair[k])]
        return k, body, other

    def summary(self) -> dict:
        """The limiting pair only: ``{"min_distance", "body", "other", "time"}``."""
        return {"min_distance": float(self.min_distance), "body": self.body, "other": self.other,
                "time": None if self.time is None else float(self.time)}

    def to_dict(self) -> dict:
        """JSON-able summary: the limiting sample and pair, and every pair's smallest distance."""
        order = sorted(self.per_pair.items(), key=lambda item: item[1])
        return {"min_distance": float(self.min_distance), "index": int(self.index),
                "time": None if self.time is None else float(self.time), "body": self.body,
                "other": self.other, "n_samples": int(self.distance.shape[0]),
                "n_checked": int(self.n_checked), "max_move": float(self.max_move),
                "per_pair": [{"body": b, "other": o, "min_distance": float(d)} for (b, o), d in order]}


# ---------------------------------------------------------------------------------------------- input

def _check_obstacles(obstacles) -> list:
    if obstacles is None:
        return []
    if isinstance(obstacles, Obstacle):
        raise ValueError("obstacles: expected a mapping of name to obstacle or a sequence of obstacles, got "
                         "one obstacle: wrap it in a list")
    if isinstance(obstacles, Mapping):
        items = [(str(k), v) for k, v in obstacles.items()]
    elif isinstance(obstacles, Sequence) and not isinstance(obstacles, str):
        items = [(f"obstacles[{k}]", v) for k, v in enumerate(obstacles)]
    else:
        raise ValueError(f"obstacles: expected a mapping of name to obstacle or a sequence of obstacles, got "
                         f"{type(obstacles).__name__}")
    for name, obstacle in items:
        if not isinstance(obstacle, (Sphere, Box)):
            raise ValueError(f"obstacles[{name!r}]: expected a skillbank.core Sphere or Box, got "
                             f"{type(obstacle).__name__}")
        if obstacle.n_dims != 3:
            raise ValueError(f"obstacles[{name!r}]: expected a 3-D obstacle (the robot's world), got "
                             f"{obstacle.n_dims}-D {obstacle!r}")
        if name in ("table", "workspace"):
            raise ValueError(f"obstacles: the name {name!r} is reserved for the table= / workspace= "
                             "arguments; rename the obstacle")
    return items


def _check_workspace(workspace):
    if workspace is None:
        return None
    if isinstance(workspace, Box):
        lower, upper = workspace.lower, workspace.upper
    else:
        if not isinstance(workspace, Sequence) or len(workspace) != 2:
            raise ValueError("workspace: expected (lower, upper), two points of 3 coordinates, got "
                             f"{workspace!r}")
        lower = check_array(workspace[0], name="workspace lower", ndim=1)
        upper = check_array(workspace[1], name="workspace upper", ndim=1)
    if lower.shape != (3,) or upper.shape != (3,):
        raise ValueError(f"workspace: expected lower and upper of 3 coordinates each, got shapes "
                         f"{lower.shape} and {upper.shape}")
    if not np.all(lower < upper):
        raise ValueError(f"workspace: expected lower < upper in every coordinate, got lower={lower.tolist()} "
                         f"upper={upper.tolist()}")
    return lower, upper


def _check_times(t, n):
    if t is None:
        return None
    t = check_array(t, name="t", ndim=1)
    if t.shape[0] != n:
        raise ValueError(f"t: expected one time per joint sample ({n}), got {t.shape[0]}")
    if n > 1 and np.any(np.diff(t) < 0):
        k = int(np.flatnonzero(np.diff(t) < 0)[0]) + 1
        raise ValueError(f"t: expected non-decreasing times, got t[{k}] = {t[k]:g} < "
                         f"t[{k - 1}] = {t[k - 1]:g}")
    return t


def _check_ignore(ignore, body_names, others):
    if isinstance(ignore, str):
        ignore = (ignore,)
    bodies, pairs = set(), set()
    known_others = set(others) | set(body_names)
    for item in ignore:
        if isinstance(item, str):
            if item not in body_names:
                raise ValueError(f"ignore: unknown body {item!r}; the robot's bodies are {list(body_names)}")
            bodies.add(item)
            continue
        if not isinstance(item, Sequence) or len(item) != 2 or not all(isinstance(x, str) for x in item):
            raise ValueError(f"ignore: expected body names or (body, other) pairs, got {item!r}")
        body, other = item
        if body not in body_names:
            raise ValueError(f"ignore: unknown body {body!r} in {tuple(item)!r}; the robot's bodies are "
                             f"{list(body_names)}")
        if other not in known_others:
            raise ValueError(f"ignore: unknown other {other!r} in {tuple(item)!r}; expected one of "
                             f"{summarise(map(repr, sorted(known_others)))}")
        pairs.add((body, other))
        pairs.add((other, body))
    return bodies, pairs


# ---------------------------------------------------------------------------------------------- densify

def _reach_per_joint(model, bodies) -> np.ndarray:
    """``rho_j``: the largest distance from joint ``j``'s axis of a capsule point it moves (module docs).

    Joint ``j`` turns frames ``j..`` about an axis through frame ``j - 1``'s origin (a DH chain); the
    distance between consecutive frame origins does not depend on the joints.
    """
    F = model._frames(np.asarray(model.home, dtype=float)[None])[0]
    link = np.zeros(F.shape[0])
    link[1:] = np.linalg.norm(F[1:, :3, 3] - F[:-1, :3, 3], axis=1)
    rho = np.zeros(model.n_joints)
    for c in bodies:
        extent = max(np.linalg.norm(c.a), np.linalg.norm(c.b)) + c.radius
        for j in range(1, min(c.frame, model.n_joints) + 1):
            rho[j - 1] = max(rho[j - 1], link[j:c.frame + 1].sum() + extent)
    return rho


def _densify(q, rho, max_move):
    """Joint samples with interpolated ones inserted, and each one's fractional caller index."""
    n = q.shape[0]
    if n < 2:
        return q, np.zeros(n)
    bound = np.abs(np.diff(q, axis=0)) @ rho
    pieces = np.maximum(np.ceil(bound / max_move - 1e-9), 1).astype(np.int64)
    total = int(pieces.sum()) + 1
    if total > _MAX_SAMPLES:
        raise ValueError(f"joints: the steps are too coarse to check with max_move={max_move:g} m "
                         f"({total} samples after densification, at most {_MAX_SAMPLES}); sample the "
                         "trajectory more finely or raise max_move")
    start = np.repeat(np.arange(n - 1), pieces)
    offset = np.arange(total - 1) - np.repeat(np.cumsum(pieces) - pieces, pieces)
    frac = offset / np.repeat(pieces, pieces)
    position = np.concatenate([start + frac, [n - 1.0]])
    dense = np.concatenate([q[start] + frac[:, None] * (q[start + 1] - q[start]), q[-1:]])
    return dense, position


# ---------------------------------------------------------------------------------------------- measure

def clearance(model, joints, obstacles=None, *, table=None, workspace=None, self_collision=True, t=None,
              ignore=(), max_move=None) -> Clearance:
    """The smallest signed distance of every body of the robot along a joint trajectory.

    Parameters
    ----------
    model : RobotModel
        With bodies (:attr:`RobotModel.bodies`: the arm's capsules and the mounted gripper's).
    joints : array-like of shape (n, n_joints) or (n_joints,)
    obstacles : mapping of str to Obstacle, or sequence of Obstacle, optional
        3-D :class:`~skillbank.core.Sphere` s and :class:`~skillbank.core.Box` es, in the world frame
        (the model's ``base`` applies); a sequence's are named ``"obstacles[k]"``.
    table : Box, optional
        The table, its top face the surface the robot stands on. The bodies on frame 0 (the base,
        mounted on it) are not checked against it.
    workspace : (lower (3,), upper (3,)) or Box, optional
        Every body must stay inside; the distance is to the bounds, negative outside.
    self_collision : bool, default=True
        Check the model's :meth:`~RobotModel.self_collision_pairs` (capsules on the same or consecutive
        frames, and the model's ``SELF_COLLISION_SKIP``, are never checked).
    t : array-like of shape (n,), optional
        Sample times, for the report (non-decreasing).
    ignore : iterable of str or (str, str)
        Body names not checked at all, or (body, other) pairs not checked, e.g.
        ``[("finger_left", "b3"), ("finger_right", "b3")]`` for fingers meant to press button ``b3``.
    max_move : float, optional
        Densification bound (m, default 0.2 x the smallest capsule radius): samples are inserted so
        that no body point moves more between checked samples (module docstring).

    Returns
    -------
    Clearance

    Examples
    --------
    >>> from skillbank.core import Sphere
    >>> from skillbank.robots import robot_model
    >>> robot = robot_model("ur5e")
    >>> ball = Sphere([-0.2, -0.018, 0.806], 0.05)  # about 10 cm above the forearm at home
    >>> result = clearance(robot, [robot.home, [0.0, -1.4, 1.5, -1.6, -1.6, 0.0]], {"ball": ball},
    ...                    t=[0.0, 2.0], self_collision=False)
    >>> result.body, result.other, round(result.min_distance, 3), result.index, result.time
    ('forearm', 'ball', 0.101, 0, 0.0)
    >>> result.collides(margin=0.15), result.first_contact(margin=0.15)
    (True, (0, 'forearm', 'ball'))
    >>> round(clearance(robot, robot.home).per_pair[("forearm", "wrist_3")], 3)  # self-collision
    0.064
    """
    q = model.check_joints(joints, name="joints")
    n = q.shape[0]
    if n == 0:
        raise ValueError("joints: expected at least one sample, got none")
    times = _check_times(t, n)
    items = _check_obstacles(obstacles)
    if table is not None and not (isinstance(table, Box) and table.n_dims == 3):
        raise ValueError(f"table: expected a 3-D skillbank.core Box (its top face the table's surface), got "
                         f"{table!r}")
    bounds = _check_workspace(workspace)
    bodies = model.bodies
    if not bodies:
        raise ValueError(f"robot {model.name}: describes no bodies to check")
    names = [c.name for c in bodies]
    others = [name for name, _ in items] + (["table"] if table is not None else []) \
        + (["workspace"] if bounds is not None else [])
    skip_bodies, skip_pairs = _check_ignore(ignore, names, others)
    if max_move is None:
        max_move = MAX_MOVE_FRACTION * min(c.radius for c in bodies)
    max_move = check_positive(max_move, name="max_move")

    # the columns: (body index, other) in a fixed order; the kinds measured in blocks
    checked = [k for k, name in enumerate(names) if name not in skip_bodies]
    spheres = [(name, o) for name, o in items if isinstance(o, Sphere)]
    boxes = [(name, o) for name, o in items if isinstance(o, Box)]
    if table is not None:
        boxes.append(("table", table))
    blocks = []  # (kind, body indices, other names, params)
    for kind, group in (("sphere", spheres), ("box", boxes)):
        for name, o in group:
            rows = [k for k in checked if (names[k], name) not in skip_pairs
                    and not (name == "table" and bodies[k].frame == 0)]
            if rows:
                blocks.append((kind, rows, name, o))
    if bounds is not None:
        rows = [k for k in checked if (names[k], "workspace") not in skip_pairs]
        if rows:
            blocks.append(("workspace", rows, "workspace", bounds))
    self_pairs = []
    if self_collision:
        index = {name: k for k, name in enumerate(names)}
        self_pairs = [(index[a], index[b]) for a, b in model.self_collision_pairs()
                      if a not in skip_bodies and b not in skip_bodies and (a, b) not in skip_pairs]
    pairs = [(names[k], name) for _, rows, name, _ in blocks for k in rows]
    pairs += [(names[i], names[j]) for i, j in self_pairs]
    if not pairs:
        raise ValueError("clearance: nothing to check (no obstacles, table, workspace or self-collision "
                         "pairs left after ignore)")

    dense, position = _densify(q, _reach_per_joint(model, bodies), max_move)
    local_a = np.array([c.a for c in bodies], dtype=float)
    local_b = np.array([c.b for c in bodies], dtype=float)
    radius = np.array([c.radius for c in bodies], dtype=float)
    frame = np.array([c.frame for c in bodies])
    m = dense.shape[0]
    best = np.empty(m)
    which = np.empty(m, dtype=np.int64)
    per_pair = np.full(len(pairs), np.inf)
    for s in range(0, m, _CHUNK):
        F = model.link_frames(dense[s:s + _CHUNK])[:, frame]  # (c, n_bodies, 4, 4)
        A = np.einsum("cbij,bj->cbi", F[..., :3, :3], local_a) + F[..., :3, 3]
        B = np.einsum("cbij,bj->cbi", F[..., :3, :3], local_b) + F[..., :3, 3]
        columns = []
        for kind, rows, _, o in blocks:
            a, b, r = A[:, rows], B[:, rows], radius[rows]
            if kind == "sphere":
                columns.append(_point_segment(a, b, o.center) - r - o.radius)
            elif kind == "box":
                columns.append(segment_box_distance(a, b, o.lower, o.upper) - r)
            else:
                lower, upper = o
                inner = np.minimum(np.minimum(a - lower, upper - a).min(axis=-1),
                                   np.minimum(b - lower, upper - b).min(axis=-1))
                columns.append(inner - r)
        if self_pairs:
            i, j = np.array(self_pairs).T
            columns.append(segment_distance(A[:, i], B[:, i], A[:, j], B[:, j]) - radius[i] - radius[j])
        D = np.concatenate(columns, axis=1)
        which[s:s + _CHUNK] = np.argmin(D, axis=1)
        best[s:s + _CHUNK] = D[np.arange(D.shape[0]), which[s:s + _CHUNK]]
        per_pair = np.minimum(per_pair, D.min(axis=0))

    # back to the caller's samples: each densified sample belongs to the nearest one
    owner = np.rint(position).astype(np.int64)
    order = np.lexsort((best, owner))
    first = order[np.unique(owner[order], return_index=True)[1]]
    distance, pair = best[first], which[first]
    k = int(np.argmin(best))
    time = None
    if times is not None:
        i = min(int(np.floor(position[k])), n - 1)
        frac = position[k] - i
        time = float(times[i] if frac == 0 else times[i] + frac * (times[i + 1] - times[i]))
    body, other = pairs[int(which[k])]
    return Clearance(distance=distance, min_distance=float(best[k]), index=int(owner[k]), time=time,
                     body=body, other=other, per_pair=dict(zip(pairs, per_pair.tolist(), strict=True)),
                     pair=pair, pairs=tuple(pairs),
                     t=times, n_checked=m, max_move=float(max_move))
