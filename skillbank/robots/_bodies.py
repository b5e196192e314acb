"""Robot bodies: the capsules that stand for every link, the tool and the gripper, in the links' frames.

A robot model lists its links' collision geometry as :class:`Capsule` s, each
fixed in one of the frames :meth:`~skillbank.robots.RobotModel.link_frames`
returns (frame 0 the base, frame ``i`` the link moved by joint ``i``, the
last one the flange). A gripper (:class:`Gripper`) adds its own capsules in
the flange frame and its tool centre point (TCP). Collision checks
(:func:`~skillbank.robots.clearance`), planning and the simulator all read
this one description.

Every capsule is the smallest-volume capsule that contains the convex hull
of one collision mesh of robosuite 1.5.2's UR5e, Robotiq 85 and Panda hand
models (MIT; ``robosuite/models/assets/robots/ur5e``,
``grippers/robotiq_gripper_85.xml`` and ``grippers/panda_gripper.xml``)
expressed in our frames, rounded to the millimetre and grown by 1 to 2 mm for
robosuite's kinematic constants, which differ from the manufacturer's DH
table by up to 1.5 mm (the Panda hand's: for the rounding). MuJoCo collides a mesh as its convex hull, and a
capsule (convex) contains a hull exactly when it contains the mesh's
vertices, which ``tests/robots/test_bodies.py`` checks at random
configurations (docs/robots.md, "Bodies and clearance").
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["Capsule", "Gripper", "GRIPPERS", "ROBOTIQ_2F85", "PANDA_HAND"]


class Capsule(NamedTuple):
    """A capsule fixed in a link frame: the segment ``a -> b`` (metres, in that frame) swept by a ball.

    Attributes
    ----------
    name : str
        The body's name (``"upper_arm"``, ``"finger_left"``).
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
    fingers : tuple of str
        The names of the capsules that touch what the gripper presses or grasps.
    grip_site : tuple of 3 float or None
        robosuite's ``grip_site`` of the gripper in the flange frame (metres): between the pads, the
        point robosuite's observations report as ``robot0_eef_pos``; None when unknown.
    axis : tuple of 3 float
        The unit vector in the flange frame (perpendicular to its z) along which the simulator's
        jaws slide: ``finger_left`` opens towards ``+axis``, ``finger_right`` towards ``-axis``.
        Default the flange's x; the 2F-85's fingers close along the flange's y (its left finger
        towards -y), the Franka hand's along its y (left towards +y).

    Examples
    --------
    >>> ROBOTIQ_2F85.tool()[:3, 3].tolist()
    [0.0, 0.0, 0.163]
    """

    name: str
    capsules: tuple
    tcp: tuple
    stroke: float
    source: str
    fingers: tuple = ()
    axis: tuple = (1.0, 0.0, 0.0)
    grip_site: tuple | None = None

    def tool(self, point: str = "tcp") -> np.ndarray:
        """A point of the gripper as a flange-to-point transform (a translation along the flange's axes).

        ``point`` is ``"tcp"`` (default) or ``"grip_site"``.
        """
        offset = self.tcp if point == "tcp" else self.grip_site if point == "grip_site" else None
        if offset is None:
            raise ValueError(f"pose_of: the {self.name}'s {point!r} is not known; its points are "
                             f"{[k for k in ('tcp', 'grip_site') if getattr(self, k) is not None]}")
        T = np.eye(4)
        T[:3, 3] = offset
        return T


#: The Robotiq 2F-85 as robosuite 1.5.2 mounts it on the UR5e: its base (``robotiq_85_adapter_link``)
#: on the flange, no coupling between them (robosuite's ``right_hand`` body is the flange: it lies
#: within 1.5 mm of DH frame 6, same axes). The capsules contain the convex hulls of the collision
#: meshes and boxes over the whole stroke (the outer and inner knuckles at 0 to 0.8 rad, the inner
#: finger kept parallel, as the linkage does); the fingers' capsules end 8 mm beyond the closed
#: fingertips (a capsule's round end about a flat tip). The TCP is the middle of the closed fingertips'
#: ends, 0.163 m along the flange's z: the fingertip boxes' far faces at full closure (robosuite's
#: ``eef`` site, 0.145 m, is the middle of the pads, 18.75 mm, half a fingertip, above).
ROBOTIQ_2F85 = Gripper(
    name="robotiq_2f85",
    capsules=(
        # robotiq_arg2f_base_link.stl: x +-37.5 mm, y +-42.4 mm, z -2.7 to 90 mm
        Capsule("gripper_body", -1, (0.0, 0.0, 0.024), (0.0, 0.0, 0.051), 0.045),
        # knuckles, fingers, pads on the flange's -y side (robosuite's left_*), swept over the stroke
        Capsule("finger_left", -1, (0.0, -0.040, 0.077), (0.0, -0.021, 0.128), 0.044),
        Capsule("finger_right", -1, (0.0, 0.040, 0.077), (0.0, 0.021, 0.128), 0.044),
    ),
    tcp=(0.0, 0.0, 0.163),
    stroke=0.085,
    source="robosuite 1.5.2 robotiq_gripper_85.xml and meshes (MIT), fitted in tests/robots/test_bodies.py",
    fingers=("finger_left", "finger_right"),
    axis=(0.0, -1.0, 0.0),  # robosuite's left finger opens towards the flange's -y, as its capsule lies
    grip_site=(0.0, 0.0, 0.145),  # robotiq_gripper_85.xml's grip_site, read with robosuite's UR5e in a test
)

#: The Franka hand as robosuite 1.5.2 mounts it on the Panda (``grippers/panda_gripper.xml``): its
#: ``right_gripper`` body in the arm's ``right_hand`` (the flange) turned by -90 degrees about z, its hand
#: mesh and finger bodies each turned back by +90 degrees, so the hand mesh lies in the flange's axes and the
#: fingers slide along the flange's y (``finger_left``, robosuite's ``leftfinger``, 0 to 0.04 m towards
#: +y; ``finger_right`` towards -y: stroke 0.08 m). The capsules are the smallest-volume ones containing
#: the convex hulls of the hand mesh and of each finger's mesh and pad box swept over its whole slide,
#: rounded to the millimetre and grown by about 1.5 mm. The TCP is where the closed fingertips meet: the
#: ends of the finger meshes, 0.106 m along the flange's z, in the plane between them (robosuite's grip
#: site, the Panda's registered tool point, is 0.097 m: 9 mm above it).
PANDA_HAND = Gripper(
    name="panda_hand",
    capsules=(
        # hand.stl: x +-31.6 mm, y -104 to 100.4 mm, z -25.9 to 66 mm
        Capsule("hand", -1, (0.0, -0.076, 0.021), (0.0, 0.060, 0.031), 0.051),
        # finger.stl and its pad box, x +-10.5 mm, y -0.5 to 66.4 mm over the slide, z 52.5 to 106.2 mm
        Capsule("finger_left", -1, (0.0, 0.011, 0.079), (0.0, 0.053, 0.077), 0.031),
        Capsule("finger_right", -1, (0.0, -0.011, 0.079), (0.0, -0.053, 0.077), 0.031),
    ),
    tcp=(0.0, 0.0, 0.106),
    stroke=0.08,
    source="robosuite 1.5.2 panda_gripper.xml and meshes (MIT), fitted in tests/robots/test_panda_hand.py",
    fingers=("finger_left", "finger_right"),
    axis=(0.0, 1.0, 0.0),
    grip_site=(0.0, 0.0, 0.097),  # panda_gripper.xml's grip_site, read with robosuite's Panda in a test
)

#: Gripper name -> description.
GRIPPERS = {"robotiq_2f85": ROBOTIQ_2F85, "panda_hand": PANDA_HAND}
