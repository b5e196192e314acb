"""The registry of robot models: the one list of robot names.

Adding a robot is one :class:`~skillbank.robots.RobotModel` subclass and one
line here.
"""

from __future__ import annotations

from ._base import RobotModel
from ._ur5e import UR5e

__all__ = ["ROBOTS", "robot_model"]

#: Robot name (as on the command line) -> model class.
ROBOTS: dict[str, type[RobotModel]] = {
    "ur5e": UR5e,
}


def robot_model(name: str, **params) -> RobotModel:
    """The model registered as ``name``, built with ``params`` (``base``, ``tool``, ...).

    Examples
    --------
    >>> robot_model("ur5e").joint_names[0]
    'shoulder_pan_joint'
    """
    try:
        cls = ROBOTS[name]
    except (KeyError, TypeError):
        raise ValueError(f"robot: expected one of {list(ROBOTS)}, got {name!r}") from None
    return cls(**params)
