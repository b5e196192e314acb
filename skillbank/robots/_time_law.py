"""The time law of a joint path: the fastest timing of given joint samples under per-joint rate limits.

:func:`time_law` keeps every sample of a joint path and gives each a new time
stamp, so the geometry is exactly the given one; only the speed along it
changes. Two laws:

- ``"toppra"`` (default): time-optimal path parameterisation by reachability
  analysis (TOPP-RA, Pham & Pham, IEEE T-RO 2018) from the maintained
  ``toppra`` package (MIT). The samples are joined by a cubic spline
  parameterised by chord length, TOPP-RA finds the fastest speed along it
  under per-joint velocity and acceleration bounds, from rest to rest, and
  each sample gets the time at which the spline passes it. Where the path
  stops (a step below :data:`STILL`, rad), the robot is at rest and the
  given time base's dwell is kept, so a gripper that switches during a stop
  still has its time.
- ``"uniform"``: the given time base stretched uniformly by the smallest
  factor (at least 1) that meets the limits: what skillbank did before the
  time law, kept for comparisons.

Either way the limits are met *as the exports measure them*: finite
differences of the samples (segment velocities, and accelerations between
segment midpoints: what a CSV holds and what URScript's servo steps stay
within, :func:`skillbank.io.blended_joints`) and the second-order differences
a ROS 2 bag's ``JointTrajectory`` points carry (``numpy.gradient``, as
:func:`skillbank.io._trajectory_export.joint_rates`). TOPP-RA's spline is not
the piecewise-linear path the samples describe, so its timing is then scaled
by the one factor (close to 1) that makes the tightest measured limit exact.
TOPP-RA bounds velocity and acceleration only, not jerk (docs/robots.md: why
TOPP-RA and not ruckig, measured).
"""

from __future__ import annotations

import logging
from contextlib import contextmanager

import numpy as np

from ..core._validation import check_array, check_finite_result, check_time, numerical_errors

__all__ = ["TIME_LAWS", "STILL", "time_law", "rate_ratio"]

#: Time laws :func:`time_law` knows.
TIME_LAWS = ("toppra", "uniform")
#: A step whose largest joint change is at most this (radians) is a stop, not motion.
STILL = 1e-12
# Fewest gridpoints TOPP-RA gets per moving piece: a piece of few samples is subdivided, so that its
# speed can rise from rest and fall back within the piece instead of over one whole step.
_MIN_GRID = 64
# The exact fit: scaled until the tightest measured limit holds to this (a few ulps over otherwise).
_MARGIN = 1.0 + 1e-12
# Smallest and largest per-joint limits accepted (rad/s, rad/s^2): beyond them durations overflow.
_LIMIT_RANGE = (1e-9, 1e9)


def _per_joint(value, name: str, n_joints: int):
    if value is None:
        return None
    arr = check_array(value, name=name, ndim=(0, 1))
    arr = np.broadcast_to(arr, (n_joints,)) if arr.ndim == 0 or arr.shape == (1,) else arr
    if arr.shape != (n_joints,):
        raise ValueError(f"{name}: expected one number, or one per joint ({n_joints}), got {arr.shape[0]}")
    low, high = _LIMIT_RANGE
    if not ((arr >= low) & (arr <= high)).all():
        raise ValueError(f"{name}: expected limits in [{low:g}, {high:g}] per joint (rad/s or rad/s^2), got "
                         f"{arr.tolist()}")
    return np.array(arr, dtype=float)


def _measured(t: np.ndarray, q: np.ndarray):
    """The rates the exports state: finite differences, and the bag's second-order ones (absolute)."""
    dt = np.diff(t)
    v = np.diff(q, axis=0) / dt[:, None]
    a = np.diff(v, axis=0) / (0.5 * (dt[1:] + dt[:-1]))[:, None]
    # a ROS 2 bag's JointTrajectory points carry numpy.gradient's rates (skillbank.io's joint_rates)
    gv = np.gradient(q, t, axis=0)
    ga = np.gradient(gv, t, axis=0)
    return np.abs(np.vstack([v, gv])), np.abs(np.vstack([a, ga]))


def rate_ratio(t, joints, *, velocity=None, acceleration=None) -> float:
    """How far a timing is from its limits: the time stretch that would just meet them (>1: broken).

    ``max(peak v / velocity, sqrt(peak a / acceleration))`` over every joint,
    the rates measured as the exports state them (finite differences of the
    samples and ``numpy.gradient``'s; see the module docstring). Stretching
    time by ``s`` divides velocities by ``s`` and accelerations by ``s**2``.

    Examples
    --------
    >>> t = np.array([0.0, 1.0, 2.0])
    >>> float(rate_ratio(t, [[0.0], [1.0], [3.0]], velocity=1.0, acceleration=4.0))
    2.0
    """
    q = check_array(joints, name="joints", ndim=2, min_samples=2)
    t = check_time(t, n_steps=q.shape[0])
    velocity = _per_joint(velocity, "velocity", q.shape[1])
    acceleration = _per_joint(acceleration, "acceleration", q.shape[1])
    with numerical_errors("time law (rates)"):
        v, a = _measured(t, q)
        need = 0.0
        if velocity is not None:
            need = max(need, float((v / velocity).max()))
        if acceleration is not None and len(a):
            need = max(need, float(np.sqrt((a / acceleration).max())))
    return need


@contextmanager
def _quiet():
    """toppra's logger held to errors: it warns of the round-off it recovers from, on every call."""
    logger = logging.getLogger("toppra")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def _toppra_piece(q: np.ndarray, velocity, acceleration, speeds=(0.0, 0.0), knots=None) -> np.ndarray:
    """Times (from 0) at which the fastest motion along the spline through ``q`` passes them.

    ``speeds``: chord length per second at the first and last sample (0: at rest), lowered towards rest
    where the limits cannot start or end there. ``knots``: the spline's parameter at the samples (the
    given time stamps), default the chord length.
    """
    # toppra imports matplotlib.pyplot (1.6 s here): only when a path is timed
    import toppra
    import toppra.algorithm
    import toppra.constraint

    chord = np.linalg.norm(np.diff(q, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(chord)])
    speeds = np.asarray(speeds, dtype=float) / s[-1]  # chord length per second -> path parameter per second
    s /= s[-1]  # exactly 1 at the end: toppra checks the grid spans the path's interval exactly
    if knots is not None:
        span = knots - knots[0]
        # the same speeds at the ends on the new parameter: d(knot)/d(chord) of the end steps
        speeds = speeds * np.array([span[1] / s[1], (span[-1] - span[-2]) / (s[-1] - s[-2])]) / span[-1]
        s = span / span[-1]
    path = toppra.SplineInterpolator(s, q)
    per_step = max(1, -(-_MIN_GRID // (len(q) - 1)))
    grid = np.concatenate([np.linspace(a, b, per_step, endpoint=False) for a, b in zip(s[:-1], s[1:],
                                                                                      strict=True)] + [[1.0]])
    constraints = []
    if velocity is not None:
        constraints.append(toppra.constraint.JointVelocityConstraint(np.column_stack([-velocity, velocity])))
    if acceleration is not None:
        # Interpolation: the bound holds at both ends of every grid step, not only at its gridpoints
        constraints.append(toppra.constraint.JointAccelerationConstraint(
            np.column_stack([-acceleration, acceleration]),
            discretization_scheme=toppra.constraint.DiscretizationType.Interpolation))
    solver = toppra.algorithm.TOPPRA(constraints, path, gridpoints=grid, parametrizer="ParametrizeConstAccel")
    if velocity is not None:  # no faster at the ends than the joint velocity limits allow there
        slope = np.abs(path(np.array([0.0, 1.0]), 1))
        with np.errstate(divide="ignore"):
            speeds = np.minimum(speeds, (velocity / slope).min(axis=1))
    # the start within what can still reach the end (toppra's controllable set, squared speeds); an end
    # speed on a limit can make the set empty (NaN) by round-off, one the limits cannot reach does
    # anyway: a little slower, then at rest
    with _quiet():
        for end in speeds[1] * np.array([1.0 - 1e-9, 0.999, 0.99, 0.9, 0.5, 0.0]):
            K = solver.compute_controllable_sets(end, end)
            if not np.isnan(K).any():
                break
        start = np.sqrt(np.clip(speeds[0] ** 2, K[0, 0], K[0, 1]))
        _, sd, _ = solver.compute_parameterization(start, end)
    if sd is None or not np.isfinite(sd).all() or (sd[1:] + sd[:-1] <= 0).any():
        raise ValueError("time law: TOPP-RA found no parameterisation of the path (a degenerate spline); "
                         "time it with law='uniform' (time_law='uniform' in reuse)")
    # constant path acceleration between gridpoints: each step takes 2 ds / (sd_i + sd_i+1)
    dt = 2.0 * np.diff(grid) / (sd[1:] + sd[:-1])
    times = np.concatenate([[0.0], np.cumsum(dt)])
    return times[::per_step]


def time_law(joints, *, velocity=None, acceleration=None, t=None, law: str = "toppra",
             ends: str = "rest") -> np.ndarray:
    """New time stamps for a joint path's samples that meet per-joint velocity and acceleration limits.

    The samples are kept as they are (the geometry is unchanged exactly);
    only their times change. See the module docstring for the two laws and
    how the limits are measured.

    Parameters
    ----------
    joints : array-like of shape (n_steps, n_joints)
        The joint path (rad), at least 2 samples, finite.
    velocity, acceleration : float or array-like of shape (n_joints,), optional
        Per-joint limits, rad/s and rad/s^2 (one number for every joint);
        at least one. A robot's own are its
        :attr:`~skillbank.robots.RobotModel.rate_limits`.
    t : array-like of shape (n_steps,), optional
        The given time base (s), strictly increasing. ``"uniform"`` stretches
        it; ``"toppra"`` keeps its dwell wherever the path stops (required
        when it does).
    law : {"toppra", "uniform"}, default="toppra"
        See :data:`TIME_LAWS`.
    ends : {"rest", "given"}, default="rest"
        ``"toppra"``: start and end at rest, or (``"given"``, needs ``t``) at
        the speed along the path of the given time base's first and last
        step once stretched uniformly to the limits (what ``"uniform"`` gives
        there), lowered where the limits cannot start or stop from it.

    Returns
    -------
    ndarray of shape (n_steps,)
        Time stamps from 0 (s). With ``"toppra"`` the tightest limit is met
        exactly; ``"uniform"`` never speeds the given time base up.

    Raises
    ------
    ValueError
        Fewer than 2 samples, non-finite or complex values, no limit or a
        limit outside [1e-9, 1e9], an unknown law, ``"uniform"`` without
        ``t``, a stop without ``t``.

    Examples
    --------
    >>> q = np.linspace(0.0, 1.0, 11)[:, None] * [1.0, -0.5]
    >>> times = time_law(q, velocity=1.0, acceleration=2.0)
    >>> round(float(times[-1]), 3), round(float(rate_ratio(times, q, velocity=1.0, acceleration=2.0)), 9)
    (1.5, 1.0)

    1 rad at 1 rad/s and 2 rad/s^2 from rest to rest: 0.5 s speeding up, 0.5 s
    at full speed, 0.5 s slowing down.
    """
    if law not in TIME_LAWS:
        raise ValueError(f"law: expected one of {list(TIME_LAWS)}, got {law!r}")
    q = check_array(joints, name="joints", ndim=2)
    if q.shape[0] < 2:
        raise ValueError(f"joints: a time law needs at least 2 samples, got {q.shape[0]} (one configuration "
                         "has no motion to time)")
    n_joints = q.shape[1]
    velocity = _per_joint(velocity, "velocity", n_joints)
    acceleration = _per_joint(acceleration, "acceleration", n_joints)
    if velocity is None and acceleration is None:
        raise ValueError("velocity, acceleration: expected at least one limit (rad/s, rad/s^2), got neither "
                         "(a robot's own are robot.rate_limits)")
    if ends not in ("rest", "given"):
        raise ValueError(f"ends: expected 'rest' or 'given', got {ends!r}")
    given = None if t is None else check_time(t, n_steps=q.shape[0])
    if given is None and (law == "uniform" or ends == "given"):
        what = "the uniform law stretches" if law == "uniform" else "ends='given' starts and ends as"
        raise ValueError(f"t: {what} a given time base; give t")
    if given is not None:
        stretch = max(1.0, rate_ratio(given, q, velocity=velocity, acceleration=acceleration) * _MARGIN)
    if law == "uniform":
        return (given - given[0]) * stretch
    moving = np.abs(np.diff(q, axis=0)).max(axis=1) > STILL
    if not moving.any():
        raise ValueError(f"joints: every sample is the same configuration (no step above {STILL:g} rad): "
                         "there is no motion to time")
    if given is None and not moving.all():
        i = int(np.flatnonzero(~moving)[0])
        raise ValueError(f"joints: samples {i} and {i + 1} are the same configuration (a stop): give t, "
                         "whose dwell the stop keeps")
    dt = np.zeros(q.shape[0] - 1)
    with numerical_errors("time law (toppra)"):
        # pieces of motion between stops, each from rest to rest
        edges = np.flatnonzero(np.diff(np.concatenate([[0], moving.astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            speeds = [0.0, 0.0]
            if ends == "given":  # a piece's end at a stop is at rest anyway
                step = np.linalg.norm(np.diff(q, axis=0), axis=1) / (np.diff(given) * stretch)
                speeds = [step[a] if a == 0 else 0.0, step[b - 1] if b == len(moving) else 0.0]
            piece = _toppra_piece(q[a:b + 1], velocity, acceleration, speeds)
            if given is not None:
                # chord length turns a joint's reversal into a kink the spline rounds off (and TOPP-RA
                # nearly stops for); the given time base, smooth through it, can be faster: the faster wins
                try:
                    other = _toppra_piece(q[a:b + 1], velocity, acceleration, speeds, knots=given[a:b + 1])
                except ValueError:  # a time base at rest inside the piece (a planned transit's waypoints,
                    other = piece   # minimum-jerk) makes that spline stop there: degenerate, so not faster
                piece = other if other[-1] < piece[-1] else piece
            dt[a:b] = np.diff(piece)
        if given is not None:
            dt[~moving] = np.diff(given)[~moving]
        times = np.concatenate([[0.0], np.cumsum(dt)])
        # the exact fit, on the motion only (a stop keeps its dwell): the boundary accelerations of a
        # stop move less than the rest, so a few rounds settle it
        for _ in range(8):
            need = rate_ratio(times, q, velocity=velocity, acceleration=acceleration)
            # need 0: the samples show no rate to fit (an acceleration limit on one step)
            if need == 0.0 or 1.0 - 1e-9 <= need <= 1.0:
                break
            dt[moving] *= need * _MARGIN
            times = np.concatenate([[0.0], np.cumsum(dt)])
        need = rate_ratio(times, q, velocity=velocity, acceleration=acceleration)
        if need > 1.0:
            times *= need * _MARGIN
    return check_finite_result(times, name="time law (toppra)")
