"""Laplacian trajectory editing with positional, velocity and obstacle constraints."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import Constraints, Demonstration
from ..core._validation import (
    MAX_MAGNITUDE,
    check_array,
    check_finite_result,
    check_positive,
    check_time,
    numerical_errors,
)
from ._laplacian import LaplacianSystem

__all__ = ["EditResult", "lte"]


@dataclass
class EditResult:
    """Outcome of one trajectory edit.

    Attributes
    ----------
    Y : ndarray of shape (n_steps, n_dims)
        The edited trajectory.
    constraint_error : float
        Largest distance between a constrained sample and its target.
    collision : bool
        True when a sample is still strictly inside an obstacle.
    n_iter : int
        Obstacle-avoidance rounds used (0 without obstacles).
    success : bool
        Constraints met (to ``tol`` when hard) and no collision.
    message : str
        What happened, in words.
    velocity_error : float
        Largest boundary-velocity error (0.0 without velocity constraints).
    added : list of (int, ndarray)
        Via-points added to push the path out of obstacles.
    """

    Y: np.ndarray
    constraint_error: float
    collision: bool
    n_iter: int
    success: bool
    message: str
    velocity_error: float = 0.0
    added: list = field(default_factory=list)


def _merge(indices, points, extra):
    """Add ``(name, index, point)`` items to the resolved constraints; ValueError on a clash."""
    table = {int(i): ("constraint", p) for i, p in zip(indices, points, strict=True)}
    for name, i, p in extra:
        if i in table and not np.allclose(table[i][1], p, rtol=1e-12, atol=1e-12):
            raise ValueError(
                f"constraints: {name} fixes sample {i} at {np.round(p, 12).tolist()}, but a "
                f"{table[i][0]} already puts it at {np.round(table[i][1], 12).tolist()}"
            )
        table[i] = (name, p)
    order = np.array(sorted(table), dtype=np.intp)
    return order, np.array([table[i][1] for i in order]).reshape(len(order), -1)


def _velocity_points(c: Constraints, n: int, t):
    """Velocity constraints as positions of the second and second-to-last samples."""
    extra = []
    if c.start_velocity is not None or c.end_velocity is not None:
        if n < 2:
            raise ValueError(f"Y: expected at least 2 samples for a velocity constraint, got {n}")
    if c.start_velocity is not None:
        if c.start is None:
            raise ValueError("start_velocity: LTE needs a start position with it; give start= or "
                             "keep anchor_ends=True")
        extra.append(("start_velocity", 1, c.start + c.start_velocity * (t[1] - t[0])))
    if c.end_velocity is not None:
        if c.goal is None:
            raise ValueError("end_velocity: LTE needs a goal position with it; give goal= or "
                             "keep anchor_ends=True")
        extra.append(("end_velocity", n - 2, c.goal - c.end_velocity * (t[-1] - t[-2])))
    return extra


# Default clearance of the via-points pushed out of an obstacle, as a fraction of its size
# (Obstacle.size): enough that the next solve does not slide the path straight back in.
_MARGIN = 0.1


def _tangents(P, rows):
    n = P.shape[0]
    T = P[np.minimum(rows + 1, n - 1)] - P[np.maximum(rows - 1, 0)]
    norm = np.linalg.norm(T, axis=1)
    return T / np.where(norm > 0, norm, 1.0)[:, None]


def _pushes(P, sd, fixed, obstacles, margins):
    """Deepest movable sample of each run of penetrating samples, moved just outside its obstacle.

    Returns ``(pushes, blocked)``: a list of (index, point) and the first
    (sample, obstacle) whose whole penetrating run is pinned by user constraints.
    """
    pushes = {}
    for j, ob in enumerate(obstacles):
        inside = sd[j] < 0.0
        if not inside.any():
            continue
        edges = np.diff(np.concatenate([[0], inside.view(np.int8), [0]]))
        starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        # Outside samples count as inf too: reduceat runs from one start to the next, past the run's end.
        depth = np.where(fixed | ~inside, np.inf, sd[j])
        best = np.minimum.reduceat(depth, starts)
        pinned = ~np.isfinite(best)
        if pinned.any():
            return [], (int(starts[np.argmax(pinned)]), j)
        rows = np.array([s + np.argmin(depth[s:e]) for s, e in zip(starts, stops, strict=True)])
        out = ob.push_out(P[rows], _tangents(P, rows), margins[j])
        for i, p in zip(rows, out, strict=True):
            pushes.setdefault(int(i), p)
    return sorted(pushes.items()), None


@numerical_errors("lte")
def lte(Y, constraints=None, *, hard=True, weight=1e6, t=None, anchor_ends=True, avoid_obstacles=True,
        margin=None, max_iter=50, tol=1e-9) -> EditResult:
    """Laplacian trajectory editing: move a path to meet constraints, keeping its shape.

    The Laplacian coordinates of ``Y`` (each sample minus the weighted mean of
    its neighbours; ``P_0 - P_1`` and ``P_{n-1} - P_{n-2}`` at the ends) are kept
    in the least-squares sense while the constrained samples move. Velocity
    constraints are met as positions of the second (last-but-one) sample:
    ``P_1 = start + v_0 (t_1 - t_0)``. Obstacles are avoided by adding, at the
    deepest sample of each run inside a region, a via-point ``margin`` outside
    it and solving again, up to ``max_iter`` times.

    Parameters
    ----------
    Y : array-like of shape (n_steps, n_dims) or Demonstration
        The path to edit (a Demonstration gives its ``"position"`` stream and ``t``).
    constraints : Constraints, optional
    hard : bool, default=True
        Equality constraints; otherwise least-squares rows of weight ``weight``.
    weight : float, default=1e6
        Weight of the soft constraint rows relative to the Laplacian rows.
    t : array-like of shape (n_steps,), optional
        Time stamps: they convert velocities and weight the Laplacian so that a
        constant-velocity path has zero Laplacian. Default unit spacing.
    anchor_ends : bool, default=True
        Hold a start or goal that is not given at the path's own.
    avoid_obstacles : bool, default=True
    margin : float, optional
        Clearance of the added via-points; default 10 % of each obstacle's size
        (radius, or half the smallest side of a box).
    max_iter : int, default=50
        Obstacle-avoidance rounds.
    tol : float, default=1e-9
        Hard constraints count as met within ``tol`` (relative to the path's scale).

    Returns
    -------
    EditResult

    Raises
    ------
    ValueError
        On invalid input (naming the argument), and, naming ``lte``, when the
        solve overflows or its result is not finite (magnitudes near
        :data:`~skillbank.core._validation.MAX_MAGNITUDE` on tiny time steps).

    Examples
    --------
    >>> import numpy as np
    >>> s = np.linspace(0.0, np.pi, 50)
    >>> Y = np.column_stack([s, np.sin(s)])
    >>> res = lte(Y, Constraints(goal=[4.0, 0.5]))
    >>> bool(res.success), res.Y[-1].tolist(), res.Y[0].tolist() == Y[0].tolist()
    (True, [4.0, 0.5], True)
    """
    if isinstance(Y, Demonstration):
        t = Y.t if t is None else t
        Y = Y["position"]
    Y = check_array(Y, name="Y", ndim=2)
    n, d = Y.shape
    t = np.arange(n, dtype=float) if t is None else check_time(t, n_steps=n)
    c = Constraints() if constraints is None else constraints
    if not isinstance(c, Constraints):
        raise ValueError(f"constraints: expected a skillbank Constraints, got {type(c).__name__}")
    c.check_dims(d)
    weight = check_positive(weight, name="weight")
    if weight < 1.0 / MAX_MAGNITUDE:  # the soft rows need 1 / weight^2
        raise ValueError(f"weight: expected a number in [{1.0 / MAX_MAGNITUDE:g}, {MAX_MAGNITUDE:g}], "
                         f"got {weight!r}")
    max_iter = check_positive(max_iter, name="max_iter", integer=True, allow_zero=True)
    if margin is not None:
        margin = check_positive(margin, name="margin", allow_zero=True)
    c = c.with_defaults(Y) if anchor_ends else c
    idx, pts = c.resolve(n)
    idx, pts = _merge(idx, pts, _velocity_points(c, n, t))
    user = np.zeros(n, dtype=bool)
    user[idx] = True
    obstacles = c.obstacles if avoid_obstacles else ()
    margins = [_MARGIN * ob.size if margin is None else margin for ob in obstacles]
    system = LaplacianSystem(n, t)
    added: dict[int, np.ndarray] = {}
    message, blocked, n_iter = "", None, 0
    while True:
        if added:
            all_idx, all_pts = _merge(idx, pts, [("obstacle via-point", i, p) for i, p in added.items()])
        else:
            all_idx, all_pts = idx, pts
        P = Y + system.solve(all_idx, all_pts - Y[all_idx], hard=hard, weight=weight)
        if hard and len(all_idx):
            P[all_idx] = all_pts
        check_finite_result(P, name="lte")
        if not obstacles:
            break
        sd = np.stack([ob.signed_distance(P) for ob in obstacles])
        if not (sd < 0).any() or n_iter >= max_iter:
            break
        pushes, blocked = _pushes(P, sd, user, obstacles, margins)
        if blocked is not None:
            break
        n_iter += 1
        added.update(pushes)
    error = check_finite_result(c.position_error(P), name="lte (constraint error)")
    vel_error = check_finite_result(c.velocity_error(P, t), name="lte (velocity error)")
    collision = c.collides(P) if c.obstacles else False
    crossing = None
    if collision and not c.collision_mask(P).any():  # no sample inside: a segment crosses
        for j, ob in enumerate(c.obstacles):
            hits = np.flatnonzero(ob.segment_hits(P))
            if hits.size:
                crossing = (int(hits[0]), j, hits.size)
                break
    scale = max(1.0, float(np.abs(Y).max()))
    dt_min = float(np.diff(t).min()) if n > 1 else 1.0
    # A velocity is a position difference over dt, so its round-off scales with 1 / dt.
    met = not hard or (error <= tol * scale and vel_error <= tol * scale / dt_min)
    if blocked is not None:
        i, j = blocked
        message = (f"sample {i} is pinned by a constraint inside obstacle {j} ({obstacles[j]!r}); "
                   "no collision-free edit exists")
    elif crossing is not None:
        i, j, count = crossing
        message = (f"no sample is inside an obstacle, but {count} segment(s) cross obstacle {j} "
                   f"(first between samples {i} and {i + 1}): sample more densely")
    elif collision and not avoid_obstacles:
        message = f"path collides at {int(c.collision_mask(P).sum())} samples (avoid_obstacles=False)"
    elif collision:
        depth = -float(np.stack([ob.signed_distance(P) for ob in c.obstacles]).min())
        message = (f"no collision-free edit within max_iter={max_iter} rounds: "
                   f"{int(c.collision_mask(P).sum())} samples still inside, deepest by {depth:.3g}")
    elif not met:
        message = f"hard constraints missed: position error {error:.3g}, velocity error {vel_error:.3g}"
    else:
        kind = "hard" if hard else f"soft (weight {weight:g})"
        message = f"{kind} constraints met to {max(error, vel_error):.3g}"
        if obstacles:
            message += f"; collision-free after {n_iter} obstacle round(s), {len(added)} via-point(s) added"
    return EditResult(
        Y=P, constraint_error=error, collision=bool(collision), n_iter=n_iter,
        success=bool(met and not collision), message=message, velocity_error=vel_error,
        added=sorted(added.items()),
    )

