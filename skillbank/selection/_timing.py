"""Timing of an executable reproduction: its peak rates, and the laws that meet limits on them.

:func:`peak_rates` measures a trajectory; :func:`_scale_needed` finds the
smallest uniform stretch meeting every limit; :func:`_uniform` applies it,
:func:`_joint_law` times a joint trajectory with
:func:`skillbank.robots.time_law` (TOPP-RA) instead. :func:`timed_to_limits`
chooses between them, for :func:`make_executable` and a plan's steps.
"""

from __future__ import annotations

import numpy as np

from ..core import Demonstration
from ..core._validation import numerical_errors
from ..editing import relative_rotations
from ..robots import time_law as joint_time_law
from ._limits import DURATION_RANGE, _show

_STREAM_OF = {"velocity": "position", "acceleration": "position", "angular_velocity": "orientation",
              "angular_acceleration": "orientation", "joint_velocity": "joints",
              "joint_acceleration": "joints"}
# A limit met to round-off: the scaled peak may exceed it by a few ulps otherwise.
_MARGIN = 1.0 + 1e-12


def _rates(values: np.ndarray, t: np.ndarray):
    """First and second time derivatives by finite differences (uneven steps allowed)."""
    dt = np.diff(t)
    v = values / dt[:, None]
    a = np.diff(v, axis=0) / (0.5 * (dt[1:] + dt[:-1]))[:, None]
    return v, a


def _steps(name: str, data: np.ndarray) -> np.ndarray:
    """Per-step changes: rotation vectors for orientations, differences otherwise."""
    return relative_rotations(data) if name == "orientation" else np.diff(data, axis=0)


def peak_rates(demo: Demonstration) -> dict:
    """Peak velocity and acceleration of ``position``, ``orientation`` and ``joints`` (those present).

    Task space: the norm of the velocity (units/s) and of the acceleration;
    orientation: of the angular velocity (rad/s, from the relative rotation
    between samples); joints: the largest absolute value of any joint.

    Examples
    --------
    >>> t = np.linspace(0.0, 2.0, 5)
    >>> peak_rates(Demonstration(t, {"position": np.c_[t, 0 * t]}))["position"]
    {'velocity': 1.0, 'acceleration': 0.0}
    """
    out = {}
    if demo.n_steps < 2:
        return out
    for name in ("position", "orientation", "joints"):
        if name not in demo.streams:
            continue
        v, a = _rates(_steps(name, demo[name]), demo.t)
        out[name] = {"velocity": float(_size(name, v).max()),
                     "acceleration": float(_size(name, a).max()) if len(a) else 0.0}
    return out


def _size(name: str, x: np.ndarray) -> np.ndarray:
    """Per-sample size of a rate: the largest joint's for joints, the norm otherwise."""
    return np.abs(x).max(axis=1) if name == "joints" else np.linalg.norm(x, axis=1)


def _scale_needed(demo: Demonstration, limits: dict) -> tuple[float, str]:
    """The smallest uniform time stretch meeting every limit, and the limit that sets it."""
    best, why = 1.0, ""
    for key, limit in limits.items():
        stream = _STREAM_OF[key]
        if stream not in demo.streams:
            continue
        v, a = _rates(_steps(stream, demo[stream]), demo.t)
        x = a if key.endswith("acceleration") else v
        if not len(x):
            continue
        if stream == "joints":
            limit = np.broadcast_to(limit, (x.shape[1],))
            ratio = float((np.abs(x) / limit).max())
        else:
            ratio = float(np.linalg.norm(x, axis=1).max() / limit)
        # Time stretched by s divides velocities by s and accelerations by s^2.
        need = np.sqrt(ratio) if key.endswith("acceleration") else ratio
        if need * _MARGIN > best:
            best, why = need * _MARGIN, key
    return best, why


_JOINT_KEYS = ("joint_velocity", "joint_acceleration")


def _plain(limit):
    """A limit for metadata (JSON): a number, or a list per joint."""
    return float(limit) if np.ndim(limit) == 0 else [float(v) for v in np.asarray(limit)]


def _whose(model, key, limit) -> str:
    own = model is not None and key in model.rate_limits and np.array_equal(
        np.broadcast_to(limit, model.rate_limits[key].shape), model.rate_limits[key])
    return f" (the {model.name}'s own limit)" if own else ""


def _check_range(duration: float, why: str) -> None:
    if duration > DURATION_RANGE[1]:
        raise ValueError(f"limits: {why} would stretch the motion to {duration:.3g} s, more than "
                         f"{DURATION_RANGE[1]:g} s: give a larger limit")


def _uniform(demo: Demonstration, limits: dict, scale: float, key: str, model):
    """Today's law: every time stretched by ``scale`` (from :func:`_scale_needed`); and its note."""
    t = demo.t
    before = float(t[-1] - t[0])
    _check_range(before * scale, f"{key} {_show(limits[key])}")
    out = Demonstration(t[0] + (t - t[0]) * scale, demo.streams, demo.metadata)
    return out, (f"time stretched by {scale:.4g} to meet {key} {_show(limits[key])}"
                 f"{_whose(model, key, limits[key])}: {before:.6g} s -> {before * scale:.6g} s")


def _joint_law(demo: Demonstration, limits: dict, uniform: float, model, ends: str = "given"):
    """The joint path timed by TOPP-RA under the joint limits, then the other limits by a uniform stretch.

    Never faster than the given time base: a duration asked for is kept when
    the law would be faster (the law's profile, slowed down to it). ``ends``:
    as :func:`skillbank.robots.time_law`'s.
    """
    t, streams = demo.t, demo.streams
    before = float(t[-1] - t[0])
    velocity, acceleration = limits.get("joint_velocity"), limits.get("joint_acceleration")
    # from and to the given boundary speeds, as slowed by the uniform law: a reproduction that starts at
    # rest starts at rest, one that starts moving keeps the start it would have had before the time law
    times = joint_time_law(streams["joints"], velocity=velocity, acceleration=acceleration, t=t, ends=ends)
    _check_range(float(times[-1]), "the joint limits")
    timed = Demonstration(t[0] + times, streams, demo.metadata)
    with numerical_errors("reuse (time scaling)"):
        rest, key = _scale_needed(timed, limits)
    # the law meets the joint limits exactly, so their own check may ask for a stretch of a few ulps
    rest = rest if rest > 1.0 + 1e-9 else 1.0
    slow = max(rest, before / float(times[-1]))
    _check_range(float(times[-1]) * slow, f"{key} {_show(limits[key])}" if rest > 1.0 else "the limits")
    if slow > 1.0:
        timed = Demonstration(t[0] + times * slow, streams, demo.metadata)
    after = float(timed.t[-1] - timed.t[0])
    joint = " and ".join(f"{k} {_show(limits[k])}{_whose(model, k, limits[k])}" for k in _JOINT_KEYS
                         if k in limits)
    note = (f"time law toppra (TOPP-RA, path kept) for {joint}: {before:.6g} s -> "
            f"{after:.6g} s (a uniform stretch: {before * uniform:.6g} s)")
    if rest > 1.0 and rest >= before / float(times[-1]):
        note += f"; then stretched by {rest:.4g} to meet {key} {_show(limits[key])}"
    elif slow > 1.0:
        note += f"; slowed to the {before:.6g} s asked for"
    return timed, after / before, note


def timed_to_limits(demo: Demonstration, limits: dict, scale: float, key: str, model=None,
                    time_law: str = "toppra", *, ends: str = "given"):
    """A trajectory that breaks its limits, re-timed: ``(demo, scale, law, note)``.

    ``scale`` and ``key``: the uniform stretch that meets every limit and the
    limit that sets it (:func:`_scale_needed`, or larger). A joint trajectory
    under joint limits with ``time_law="toppra"`` is timed by
    :func:`_joint_law`; when task-space limits make that slower than the
    uniform stretch (both meet every limit), or the law fails, the uniform
    stretch is kept, its note saying why. Otherwise the uniform stretch.
    ``ends``: where the law starts and ends (:func:`skillbank.robots.time_law`):
    ``"given"`` for a reproduction, ``"rest"`` for a plan's step that joins
    the next at rest.
    The one choice of a law, for ``make_executable`` and a plan's steps
    (:mod:`skillbank.planning`).

    Returns
    -------
    demo : Demonstration
        Re-timed, the samples unchanged.
    scale : float
        Duration after over duration before.
    law : {"toppra", "uniform"}
    note : str
        Which law, under which limits, from what duration to what.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 5)
    >>> d = Demonstration(t, {"position": np.c_[t, t]})
    >>> out, s, law, note = timed_to_limits(d, {"velocity": 0.5}, 2.0 * 2 ** 0.5, "velocity")
    >>> law, round(float(out.t[-1]), 4)
    ('uniform', 2.8284)
    """
    joint_limits = "joints" in demo.streams and any(k in limits for k in _JOINT_KEYS)
    law = "uniform"
    stretched, note = _uniform(demo, limits, scale, key, model)
    if time_law == "toppra" and joint_limits:
        try:
            timed, law_scale, law_note = _joint_law(demo, limits, scale, model, ends)
        except ValueError as exc:  # the uniform stretch meets the limits: kept, with the reason
            timed, law_scale, law_note = None, np.inf, str(exc)
        # task-space limits bound after the joint law can make it slower than a uniform stretch:
        # both meet every limit, the shorter is kept
        if law_scale <= scale:
            stretched, scale, note, law = timed, law_scale, law_note, "toppra"
        elif timed is None:
            note += f" (the toppra time law failed: {law_note})"
        else:
            note += (f" (shorter than the toppra time law's {float(timed.t[-1] - timed.t[0]):.6g} s, "
                     "which task-space limits slowed down)")
    return stretched, scale, law, note


def _check_stretch(constraints, fixed_time, scale, t, key, limit) -> None:
    duration = float(t[-1] - t[0])
    if fixed_time:
        raise ValueError(f"limits: {key} {_show(limit)} cannot be met on the {duration:.6g} s time base "
                         f"given: it needs at least {duration * scale:.6g} s (give a duration instead of "
                         "time stamps to slow down as needed)")
    for name in ("start_velocity", "end_velocity"):
        v = getattr(constraints, name)
        if v is not None and np.any(v != 0):
            raise ValueError(f"limits: {key} {_show(limit)} needs the motion slowed down {scale:.4g} times, "
                             f"which would change the non-zero {name.replace('_', ' ')} {v.tolist()}")
