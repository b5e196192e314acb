"""Robot bodies: the capsules that stand for every link, the tool and the gripper, in the links' frames.

A robot model lists its links' collision geometry as :class:`Capsule` s, each
fixed in one of the frames :meth:`~skillbank.robots.RobotModel.link_frames`
returns (frame 0 the base, frame ``i`` the link moved by joint ``i``, the
last one the flange). A gripper (:class:`Gripper`) adds its own capsules in
the flange frame and its tool centre point (TCP). Collision checks, planning
and the simulator all read this one description.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["Capsule", "Gripper", "GRIPPERS"]


class Capsule(NamedTuple):
    """A capsule fixed in a link frame: the segment ``a -> b`` (metres, in that frame) swept by a ball.

    Attributes
    ----------
    name : str
        The body's name (``"upper_arm"``, ``"gripper_fingers"``).
    frame : int
        Index into :meth:`RobotModel.link_frames`: 0 the base, ``i`` after joint ``i``.
    a, b : tuple of 3 float
        The segment's ends in that frame (equal ends: a sphere).
    radius : float
    """

    name: str
    frame: int
    a: tuple
    b: tuple
    radius: float


class Gripper(NamedTuple):
    """A gripper mounted on the flange: its capsules (frame = the flange's index) and its TCP.

    Attributes
    ----------
    name : str
    capsules : tuple of Capsule
        In the flange frame (their ``frame`` is replaced by the arm's flange index when mounted).
    tcp : tuple of 3 float
        The tool centre point in the flange frame (metres): where the fingertips meet.
    stroke : float
        Largest opening between the fingers (metres).
    source : str
        Where the dimensions come from.
    """

    name: str
    capsules: tuple
    tcp: tuple
    stroke: float
    source: str

    def tool(self) -> np.ndarray:
        """The TCP as a flange-to-tool transform (a translation along the flange's axes)."""
        T = np.eye(4)
        T[:3, 3] = self.tcp
        return T


#: Placeholder dimensions, refined from the Robotiq 2F-85's published drawing (docs/robots.md).
ROBOTIQ_2F85 = Gripper(
    name="robotiq_2f85",
    capsules=(Capsule("gripper_body", -1, (0.0, 0.0, 0.0), (0.0, 0.0, 0.09), 0.045),
              Capsule("gripper_fingers", -1, (0.0, 0.0, 0.09), (0.0, 0.0, 0.14), 0.03)),
    tcp=(0.0, 0.0, 0.15),
    stroke=0.085,
    source="placeholder",
)

#: Gripper name -> description.
GRIPPERS = {"robotiq_2f85": ROBOTIQ_2F85}
