"""How the tool must move so that a body of the arm clears an obstacle: the repair's direction.

A reuse or an edit shapes the tool's path; the rest of the arm follows by
inverse kinematics. When a link far from the tool (the forearm, the upper
arm) comes too near an obstacle, moving the tool away from the obstacle is
often the wrong repair: the link may move the other way. :func:`clearing_move`
measures instead how the link's distance to the obstacle changes when the
tool point moves (its gradient with respect to the tool position, the
orientation held, by central differences through the model's own inverse
kinematics on the same branch) and returns the shortest tool displacement
that, to first order, adds the distance the link lacks. Any robot model
with ``fk``, ``ik`` and bodies works; nothing is specific to the UR5e.
"""

from __future__ import annotations

import numpy as np

from ..core._obstacles import Obstacle
from ..core._validation import check_array, check_positive
from ._clearance import clearance

__all__ = ["CLEARANCE", "clearing_move"]

#: Metres every body of the robot keeps from obstacles, the table, the workspace bounds and itself, on top
#: of its capsules (already envelopes of the links' collision meshes, docs/robots.md): the default margin.
CLEARANCE = 0.005
#: Below this gain (metres of distance per metre of tool motion) moving the tool cannot clear the body.
_MIN_GAIN = 0.05


def _pair_distance(model, q, body, obstacle) -> float:
    res = clearance(model, q[None], {"x": obstacle}, self_collision=False)
    return float(res.per_pair[(body, "x")])


def clearing_move(model, q, body, obstacle, lack, *, step=0.005, max_move=0.25):
    """The tool displacement (m, base frame) that moves ``body`` ``lack`` metres further from ``obstacle``.

    Parameters
    ----------
    model : RobotModel
    q : array-like of shape (n_joints,)
        The configuration where ``body`` is too near.
    body : str
        A name of :attr:`RobotModel.bodies`.
    obstacle : Obstacle
        A 3-D sphere or box (the table too is a box).
    lack : float
        Metres of distance the body needs (> 0).
    step : float, default=0.005
        Tool displacement of the finite differences (m).
    max_move : float, default=0.25
        Longest displacement returned (m): a repair that needs more is not a local one.

    Returns
    -------
    ndarray of shape (3,) or None
        None when moving the tool point barely moves ``body`` relative to ``obstacle`` (the body is
        on the base or the shoulder, or every nearby pose is out of reach), or when the first-order
        move would be longer than ``max_move``.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank.core import Sphere
    >>> from skillbank.robots import robot_model
    >>> robot = robot_model("ur5e")
    >>> ball = Sphere([-0.2, -0.018, 0.806], 0.05)  # about 10 cm above the forearm at home
    >>> move = clearing_move(robot, robot.home, "forearm", ball, 0.02)
    >>> bool(np.linalg.norm(move) < 0.25)
    True
    """
    q = check_array(q, name="q", ndim=1, n_dims=None)
    if q.shape != (len(model.joint_names),):
        raise ValueError(f"q: expected {len(model.joint_names)} joint angles, got shape {q.shape}")
    if body not in {b.name for b in model.bodies}:
        raise ValueError(f"body: expected one of the model's bodies {[b.name for b in model.bodies]}, "
                         f"got {body!r}")
    if not isinstance(obstacle, Obstacle):
        raise ValueError(f"obstacle: expected an Obstacle (Sphere, Box), got {type(obstacle).__name__}")
    lack = check_positive(lack, name="lack")
    step = check_positive(step, name="step")
    position, quaternion = model.fk(q)
    gradient = np.zeros(3)
    for axis in range(3):
        values = []
        for sign in (1.0, -1.0):
            target = position.copy()
            target[axis] += sign * step
            try:
                # the same branch as q: a nearby pose's solution seeded from q
                qs = model.ik(target[None], quaternion[None], q_seed=q)[0]
            except ValueError:  # out of reach or at a limit that way: a one-sided difference
                values.append(None)
                continue
            values.append(_pair_distance(model, qs, body, obstacle))
        if values[0] is not None and values[1] is not None:
            gradient[axis] = (values[0] - values[1]) / (2 * step)
        elif values[0] is not None or values[1] is not None:
            here = _pair_distance(model, q, body, obstacle)
            gradient[axis] = ((values[0] - here) if values[0] is not None else (here - values[1])) / step
    gain = float(np.linalg.norm(gradient))
    if gain < _MIN_GAIN:
        return None
    move = gradient * (lack / gain ** 2)
    if np.linalg.norm(move) > max_move:
        return None
    return move
