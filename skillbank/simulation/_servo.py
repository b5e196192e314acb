"""The arm's joint servos: stiffness and damping per joint, by robot."""

from __future__ import annotations

import numpy as np

__all__ = ["SERVO_GAINS", "servo_gains"]

#: Robot -> (kp (N m / rad), kv (N m s / rad)) per joint. Chosen so that the recorded three-button
#: demonstration is tracked to about a millimetre at the tool (docs/simulation.md), like UR's servoj.
SERVO_GAINS = {
    "ur5e": ((2.0e4, 2.0e4, 1.0e4, 2.0e3, 2.0e3, 2.0e3), (4.0e2, 4.0e2, 2.0e2, 4.0e1, 4.0e1, 4.0e1)),
}


def servo_gains(robot: str, kp=None, kv=None):
    """``(kp, kv)`` for ``robot``: the given ones (checked) or the defaults.

    Examples
    --------
    >>> servo_gains("ur5e")[0][0]
    20000.0
    """
    default = SERVO_GAINS.get(robot)
    out = []
    for name, value, k in (("kp", kp, 0), ("kv", kv, 1)):
        if value is None:
            if default is None:
                raise ValueError(f"{name}: no default servo gains for robot {robot!r}; give {name} per joint")
            value = default[k]
        arr = np.asarray(value, dtype=float).ravel()
        if arr.size == 1 and default is not None:
            arr = np.full(len(default[k]), arr[0])
        if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
            raise ValueError(f"{name}: expected positive servo gains, one per joint, got "
                             f"{np.ravel(value).tolist()}")
        out.append(tuple(float(x) for x in arr))
    return tuple(out)
