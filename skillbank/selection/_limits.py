"""Limits on an executable reproduction: the keys, their checks, the robot's own, durations.

:func:`check_limits` validates a ``limits`` dict, :func:`robot_limits` adds a
robot's own joint limits to it, :func:`check_duration` bounds a duration.
"""

from __future__ import annotations

import numpy as np

from ..core._validation import check_array, check_positive
from ..robots import RobotModel

__all__ = ["LIMITS", "DURATION_RANGE", "check_limits", "check_duration", "robot_limits"]

#: Keys of ``limits``: task-space limits are on the norm (m/s, m/s^2, rad/s, rad/s^2), joint limits
#: per joint (a number for all or one per joint; rad/s, rad/s^2).
LIMITS = ("velocity", "acceleration", "angular_velocity", "angular_acceleration", "joint_velocity",
          "joint_acceleration")
#: Durations accepted (seconds): below a nanosecond rates overflow; up to 1e9 s (32 years) a ROS 2
#: bag's int32 seconds still hold the last stamp. A short one is stretched to the limits anyway.
DURATION_RANGE = (1e-9, 1e9)
# Smallest limit accepted (units/s, rad/s, ... per second): below it the stretch overflows.
_MIN_LIMIT = 1e-9


def check_duration(value, *, name: str = "duration") -> float:
    """A duration in seconds within :data:`DURATION_RANGE`, else ValueError.

    Examples
    --------
    >>> check_duration(2)
    2.0
    >>> check_duration(1e-12)
    Traceback (most recent call last):
    ...
    ValueError: duration: expected seconds in [1e-09, 1e+09], got 1e-12 (a short duration is stretched to \
the robot's limits anyway: give at least 1e-09 s)
    """
    seconds = float(check_positive(value, name=name))
    low, high = DURATION_RANGE
    if not low <= seconds <= high:
        advice = (f"a short duration is stretched to the robot's limits anyway: give at least {low:g} s"
                  if seconds < low else "split a longer task into steps")
        raise ValueError(f"{name}: expected seconds in [{low:g}, {high:g}], got {seconds:g} ({advice})")
    return seconds


def robot_limits(model: RobotModel, limits) -> tuple[dict, list]:
    """``limits`` with the robot's own joint limits applied, and notes where a given one was above them.

    Each of the robot's :attr:`~skillbank.robots.RobotModel.rate_limits` is
    added, or replaces a given limit per joint where it is smaller.

    Examples
    --------
    >>> from skillbank.robots import UR5e
    >>> merged, notes = robot_limits(UR5e(), {"joint_velocity": 1.0})
    >>> merged["joint_velocity"].tolist(), merged["joint_acceleration"].round(4).tolist()[:2], notes
    ([1.0, 1.0, 1.0, 1.0, 1.0, 1.0], [3.1416, 3.1416], [])
    """
    limits = dict(check_limits(limits))
    notes = []
    for key, own in model.rate_limits.items():
        given = limits.get(key)
        if given is None:
            limits[key] = own
            continue
        if np.ndim(given) and np.shape(given) != own.shape:
            raise ValueError(f"limits[{key!r}]: expected one number, or one per joint of {model.name} "
                             f"({model.n_joints}), got {np.shape(given)[0]}")
        given = np.broadcast_to(np.asarray(given, dtype=float), own.shape)
        if (given > own).any():
            notes.append(f"{key}: {_show(given)} is above the {model.name}'s own limit {_show(own)}; the "
                         "robot's limit applies")
        limits[key] = np.minimum(given, own)
    return limits, notes


def check_limits(limits) -> dict:
    """``limits`` as ``{key: float or (n,) array}``, validated; ``{}`` for None.

    Examples
    --------
    >>> check_limits({"joint_velocity": 1.0})
    {'joint_velocity': 1.0}
    """
    if limits is None:
        return {}
    if not isinstance(limits, dict):
        raise ValueError(f"limits: expected a dict with keys among {list(LIMITS)}, got "
                         f"{type(limits).__name__}")
    unknown = sorted(set(limits) - set(LIMITS))
    if unknown:
        raise ValueError(f"limits: expected keys among {list(LIMITS)}, got {unknown}")
    out = {}
    for key, value in limits.items():
        if value is None:
            continue
        if key.startswith("joint_") and np.ndim(value) == 1:
            arr = check_array(value, name=f"limits[{key!r}]", ndim=1)
            if (arr <= 0).any():
                raise ValueError(f"limits[{key!r}]: expected numbers > 0, got {arr.tolist()}")
            out[key] = arr
        else:
            out[key] = check_positive(value, name=f"limits[{key!r}]")
        if np.min(out[key]) < _MIN_LIMIT:
            raise ValueError(f"limits[{key!r}]: expected at least {_MIN_LIMIT:g} (a smaller limit stretches "
                             f"any motion past {DURATION_RANGE[1]:g} s), got {_show(out[key])}")
    return out


def _show(limit) -> str:
    """A limit as typed: one number when every joint has the same."""
    arr = np.asarray(limit, dtype=float)
    if arr.ndim and (arr == arr.flat[0]).all():
        arr = arr.flat[0]
    return f"{float(arr):.4g}" if np.ndim(arr) == 0 else str([float(f"{v:.4g}") for v in arr])
