"""The arm's joint servos: stiffness and damping per joint, by robot."""

from __future__ import annotations

import numpy as np

__all__ = ["SERVO_GAINS", "servo_gains", "joint_inertia", "SERVO_FREQUENCY"]

#: The servos' natural frequency (rad/s) for an arm without listed gains: the UR5e's listed gains give
#: 100 to 150 rad/s about its shoulder and elbow at home (docs/simulation.md); critically damped.
SERVO_FREQUENCY = 120.0

#: Robot -> (kp (N m / rad), kv (N m s / rad)) per joint. Chosen so that the recorded three-button
#: demonstration is tracked to about a millimetre at the tool (docs/simulation.md), like UR's servoj.
SERVO_GAINS = {
    "ur5e": ((2.0e4, 2.0e4, 1.0e4, 2.0e3, 2.0e3, 2.0e3), (4.0e2, 4.0e2, 2.0e2, 4.0e1, 4.0e1, 4.0e1)),
}


def joint_inertia(model, masses) -> np.ndarray:
    """Per joint, the moment of inertia (kg m^2) about its axis of every link after it, at home.

    Each link's mass sits at the middle of its capsules (at its frame's origin when it has none);
    at least 0.1 kg m^2, so a light wrist keeps a usable gain (the UR5e's listed wrist gains).
    """
    F = model.link_frames(np.asarray(model.home, float))[0]
    centres = [F[k, :3, 3] for k in range(model.n_joints + 1)]
    for k in range(1, model.n_joints + 1):
        caps = [c for c in model.bodies if c.frame == k]
        if caps:
            local = np.mean([np.add(c.a, c.b) / 2 for c in caps], axis=0)
            centres[k] = F[k, :3, :3] @ local + F[k, :3, 3]
    out = np.zeros(model.n_joints)
    for j in range(model.n_joints):
        axis, origin = F[j, :3, 2], F[j, :3, 3]
        for k in range(j + 1, model.n_joints + 1):
            r = centres[k] - origin
            out[j] += masses[k - 1] * float(np.sum(np.cross(axis, r) ** 2))
    return np.maximum(out, 0.1)


def servo_gains(robot: str, kp=None, kv=None, *, inertia=None):
    """``(kp, kv)`` for ``robot``: the given ones (checked), the listed defaults, or from ``inertia``.

    An arm without listed gains gets ``kp = w^2 I`` and ``kv = 2 w I`` per joint (critically damped at
    ``w`` = :data:`SERVO_FREQUENCY`) from its joints' ``inertia`` (:func:`joint_inertia`).

    Examples
    --------
    >>> servo_gains("ur5e")[0][0]
    20000.0
    """
    default = SERVO_GAINS.get(robot)
    if default is None and inertia is not None:
        inertia = np.asarray(inertia, float)
        default = (tuple(SERVO_FREQUENCY**2 * inertia), tuple(2 * SERVO_FREQUENCY * inertia))
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
