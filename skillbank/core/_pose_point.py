"""Which point of the robot a demonstration's poses are of: the one grammar of that statement.

A pose stream (``position`` and ``orientation``) is the pose of one point of
the robot: its flange (ROS's ``tool0``), a gripper's tool centre point (where
its closed fingertips meet) or grip site (robosuite's ``grip_site``, between
the pads), or a fixed offset from the flange. The statement travels with the
demonstration as ``metadata["pose_of"]``, in one canonical text:

- ``"flange"``;
- ``"GRIPPER:tcp"`` or ``"GRIPPER:grip_site"``: a named gripper's point
  (``GRIPPER`` as in :data:`skillbank.robots.GRIPPERS`; ``"GRIPPER"`` alone
  means its TCP);
- ``"X,Y,Z,QX,QY,QZ,QW"``: an offset in the flange frame (metres and a
  scalar-last unit quaternion; ``"X,Y,Z"`` alone is a translation).

This module only reads and writes the text (numpy only, like the rest of
``core``); :func:`skillbank.robots.pose_point` resolves it to a transform and
converts poses between points. A demonstration without the key has an unknown
point: with a robot that is an error, never a guess.
"""

from __future__ import annotations

import math
import re

import numpy as np

from ._rotations import matrix_to_quaternion

__all__ = ["POSE_OF", "check_pose_of", "parse_pose_of", "state_pose_of", "offset_pose_of", "POINT_KINDS"]

#: The metadata key that says which point of the robot the pose streams are of.
POSE_OF = "pose_of"
#: The named points of a gripper.
POINT_KINDS = ("tcp", "grip_site")
_NAME = re.compile(r"[a-z][a-z0-9_]*\Z")
_GRAMMAR = ("'flange', GRIPPER, GRIPPER:tcp, GRIPPER:grip_site, X,Y,Z or X,Y,Z,QX,QY,QZ,QW (the flange "
            "frame, m)")


def _refuse(name: str, value, why: str) -> ValueError:
    shown = value if isinstance(value, str) and len(value) <= 80 else f"{str(value)[:80]}..."
    return ValueError(f"{name}: expected {_GRAMMAR}; got {shown!r} ({why})")


def parse_pose_of(value, *, name: str = "pose_of"):
    """The parts of a point's text: ``("flange",)``, ``("gripper", NAME, KIND)`` or ``("offset", x, q)``.

    ``x`` is the translation (3,) and ``q`` the unit quaternion (4,) of the
    offset in the flange frame. Names are checked for their form here and
    against the known grippers by :func:`skillbank.robots.pose_point`.

    Examples
    --------
    >>> parse_pose_of("robotiq_2f85")
    ('gripper', 'robotiq_2f85', 'tcp')
    >>> kind, x, q = parse_pose_of("0,0,0.1")
    >>> kind, x.tolist(), q.tolist()
    ('offset', [0.0, 0.0, 0.1], [0.0, 0.0, 0.0, 1.0])
    """
    if not isinstance(value, str):
        raise _refuse(name, value, f"a {type(value).__name__}, not text")
    text = value.strip()
    if text == "flange":
        return ("flange",)
    if text == "tcp":
        raise _refuse(name, value, "'tcp' alone does not say whose: name the gripper, as in "
                      "robotiq_2f85:tcp or panda_hand:tcp")
    if "," in text:
        try:
            numbers = [float(v) for v in text.split(",")]
        except ValueError:
            raise _refuse(name, value, "not numbers separated by commas") from None
        if len(numbers) not in (3, 7):
            raise _refuse(name, value, f"{len(numbers)} numbers")
        if not all(math.isfinite(v) for v in numbers):
            raise _refuse(name, value, "a number that is not finite")
        x = np.array(numbers[:3])
        if np.abs(x).max() > 10.0:
            raise _refuse(name, value, "an offset of more than 10 m from the flange")
        q = np.array([0.0, 0.0, 0.0, 1.0] if len(numbers) == 3 else numbers[3:])
        norm = float(np.linalg.norm(q))
        if abs(norm - 1.0) > 0.01:
            raise _refuse(name, value, f"a quaternion of norm {norm:.4g}, not 1")
        # a quaternion of unit norm to round-off keeps its bits: the canonical text reads back as itself
        unit = abs(float(q @ q) - 1.0) <= 8 * np.finfo(float).eps
        return ("offset", x, q if unit else q / norm)
    gripper, _, kind = text.partition(":")
    kind = kind or "tcp"
    if not _NAME.match(gripper):
        raise _refuse(name, value, "not a gripper's name")
    if kind not in POINT_KINDS:
        raise _refuse(name, value, f"a gripper's point is one of {list(POINT_KINDS)}")
    return ("gripper", gripper, kind)


def check_pose_of(value, *, name: str = "pose_of") -> str:
    """The canonical text of a point (see the module): what ``metadata["pose_of"]`` holds.

    Examples
    --------
    >>> check_pose_of("robotiq_2f85"), check_pose_of(" flange ")
    ('robotiq_2f85:tcp', 'flange')
    >>> check_pose_of("0,0,0.163")
    '0,0,0.163,0,0,0,1'
    """
    return pose_of_text(parse_pose_of(value, name=name))


def pose_of_text(parts) -> str:
    """The canonical text of the parts :func:`parse_pose_of` gives."""
    if parts[0] == "flange":
        return "flange"
    if parts[0] == "gripper":
        return f"{parts[1]}:{parts[2]}"
    # the shortest text that reads back as the same float: stored, exported and compared as text
    return ",".join(np.format_float_positional(float(v), trim="-") for v in (*parts[1], *parts[2]))


def offset_pose_of(T, *, name: str = "pose_of") -> str:
    """The canonical text of an offset given as a 4 x 4 rigid transform in the flange frame.

    Examples
    --------
    >>> T = np.eye(4)
    >>> T[2, 3] = 0.097
    >>> offset_pose_of(T)
    '0,0,0.097,0,0,0,1'
    """
    T = np.asarray(T, float)
    q = matrix_to_quaternion(T[:3, :3])
    return check_pose_of(",".join(repr(float(v)) for v in (*T[:3, 3], *q)), name=name)


def state_pose_of(demos, value, *, source="the file") -> list:
    """Give ``demos`` the point ``value`` (``--pose-of``) where their format did not state one.

    A demonstration whose reader stated a point keeps it; ``value`` must then
    agree (two statements that differ are an error, never a silent choice).
    ``value=None`` changes nothing. Returns the same list, metadata updated.

    Examples
    --------
    >>> from skillbank.core import Demonstration
    >>> d = [Demonstration([0.0], {"position": [[0.0, 0.0, 0.0]]})]
    >>> state_pose_of(d, "robotiq_2f85")[0].metadata["pose_of"]
    'robotiq_2f85:tcp'
    """
    if value is None:
        return demos
    text = check_pose_of(value, name="pose_of")
    for demo in demos:
        stated = demo.metadata.get(POSE_OF)
        if stated is not None and check_pose_of(stated) != text:
            raise ValueError(f"pose_of: {source} states its poses are of {stated!r}, and --pose-of / pose_of "
                             f"says {text!r}: leave pose_of out, or give the point the file states")
        demo.metadata[POSE_OF] = text
    return demos
