"""The point of the robot a pose is of, resolved, and poses converted from one point to a robot's tool.

``metadata["pose_of"]`` (:mod:`skillbank.core._pose_point`: ``flange``, ``GRIPPER:tcp``,
``GRIPPER:grip_site`` or an offset in the flange frame) says which point a demonstration's pose
streams are of. A robot model speaks of its own tool (``model.tool``, a flange-to-tool transform). A
pose of point ``P`` becomes the pose of the tool by one rigid transform on the right::

    T_world_tool = T_world_P @ inv(T_flange_P) @ T_flange_tool

exact for position and orientation alike. One case goes through another gripper rather than the
flange: a gripper's named point (its TCP or grip site) reused on a robot that mounts a *different*
gripper is taken as that gripper's same point (where the hand holds or touches is what the task
depends on; the flange of another hand is not), and a note says so.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..core import Demonstration, matrix_to_quaternion, quaternion_to_matrix
from ..core._pose_point import POSE_OF, offset_pose_of, parse_pose_of, pose_of_text
from ..core._rotations import quaternion_multiply
from ._bodies import GRIPPERS

__all__ = ["PosePoint", "pose_point", "tool_point", "to_tool", "POSE_OF"]

# A transform this close to the identity changes nothing worth a conversion (and keeps the bits).
_IDENTITY = 1e-12
#: Where the option that states a point is, for every message about an unknown one.
HOW_TO_SAY = ("say which point of the robot its poses are of with --pose-of flange|GRIPPER:tcp|"
              "GRIPPER:grip_site|X,Y,Z (library add, segment, edit; metadata['pose_of'] in the API)")


class PosePoint(NamedTuple):
    """A resolved point: its canonical text, its pose in the flange frame, and what it is.

    Attributes
    ----------
    text : str
        The canonical text (``metadata["pose_of"]``).
    transform : ndarray of shape (4, 4)
        The point's pose in the flange frame.
    gripper : str or None
        The gripper it belongs to (a name of :data:`GRIPPERS`), or None.
    kind : str
        ``"flange"``, ``"tcp"``, ``"grip_site"`` or ``"offset"``.
    """

    text: str
    transform: np.ndarray
    gripper: str | None
    kind: str


def pose_point(value, *, name: str = "pose_of") -> PosePoint:
    """Resolve a point's text (see :mod:`skillbank.core._pose_point`) to its pose in the flange frame.

    Examples
    --------
    >>> p = pose_point("robotiq_2f85")
    >>> p.text, p.transform[:3, 3].tolist()
    ('robotiq_2f85:tcp', [0.0, 0.0, 0.163])
    >>> pose_point("panda_hand:grip_site").transform[2, 3]
    0.097
    """
    parts = parse_pose_of(value, name=name)
    text = pose_of_text(parts)
    if parts[0] == "flange":
        return PosePoint(text, np.eye(4), None, "flange")
    if parts[0] == "gripper":
        _, gripper, kind = parts
        if gripper not in GRIPPERS:
            raise ValueError(f"{name}: unknown gripper {gripper!r} in {value!r}; known grippers are "
                             f"{list(GRIPPERS)} (or give the offset X,Y,Z in the flange frame, metres)")
        return PosePoint(text, GRIPPERS[gripper].tool(kind), gripper, kind)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = quaternion_to_matrix(parts[2]), parts[1]
    return PosePoint(text, T, None, "offset")


def tool_point(model) -> str:
    """The canonical text of ``model``'s tool: a gripper's point when it is one (the mounted one first).

    Examples
    --------
    >>> from skillbank.robots import robot_model
    >>> tool_point(robot_model("ur5e")), tool_point(robot_model("ur5e", tool="flange"))
    ('robotiq_2f85:tcp', 'flange')
    """
    T = np.asarray(model.tool, float)
    if np.abs(T - np.eye(4)).max() <= _IDENTITY:
        return "flange"
    mounted = getattr(model, "gripper_", None)
    grippers = ([mounted] if mounted is not None else []) + [g for g in GRIPPERS.values() if g is not mounted]
    for g in grippers:
        for kind in ("tcp", "grip_site"):
            if getattr(g, kind) is not None and np.abs(g.tool(kind) - T).max() <= 1e-9:
                return f"{g.name}:{kind}"
    return offset_pose_of(T)


def _to_tool_transform(point: PosePoint, model) -> tuple[np.ndarray, str | None]:
    """``inv(T_flange_P) @ T_flange_tool``, through the robot's own gripper for another gripper's point."""
    source, note = point.transform, None
    mounted = getattr(model, "gripper_", None)
    if point.gripper is not None and mounted is not None and point.gripper != mounted.name:
        if getattr(mounted, point.kind) is None:
            raise ValueError(f"pose_of: the poses are of the {point.gripper}'s {point.kind}, and the "
                             f"{model.name}'s {mounted.name} has no known {point.kind}; "
                             "give the robot's tool with --tool / tool=")
        source = mounted.tool(point.kind)
        note = (f"pose_of: poses of the {point.gripper}'s {point.kind} taken as the {mounted.name}'s "
                f"{point.kind} (another gripper: where the hand works is kept, not its flange)")
    inv = np.eye(4)
    inv[:3, :3] = source[:3, :3].T
    inv[:3, 3] = -source[:3, :3].T @ source[:3, 3]
    return inv @ np.asarray(model.tool, float), note


def to_tool(demo: Demonstration, model, *, what: str = "demonstration") -> tuple[Demonstration, list]:
    """``demo`` with its pose streams converted from ``metadata["pose_of"]`` to ``model``'s tool.

    The whole pose is converted (``position`` and ``orientation``); ``metadata["pose_of"]`` then
    names the tool (:func:`tool_point`), so converting again changes nothing. A pose stream already
    of the tool is returned unchanged (the same object), and so is a demonstration without a 3-D
    pose (``position`` and ``orientation``): inverse kinematics says what it lacks.

    Parameters
    ----------
    demo : Demonstration
    model : RobotModel
    what : str
        How the demonstration is named in messages (``"primitive 4"``).

    Returns
    -------
    (Demonstration, list of str)
        The converted demonstration and notes (what was converted to what).

    Raises
    ------
    ValueError
        No ``pose_of`` (an unknown point: never guessed) or an unknown gripper.

    Examples
    --------
    >>> from skillbank.robots import robot_model
    >>> d = Demonstration([0.0, 1.0], {"position": [[0.4, 0.0, 0.5]] * 2,
    ...                                "orientation": [[1.0, 0.0, 0.0, 0.0]] * 2}, {"pose_of": "flange"})
    >>> tcp, notes = to_tool(d, robot_model("ur5e"))      # tool pointing down: the TCP is 0.163 m below
    >>> tcp["position"][0].round(3).tolist(), tcp.metadata["pose_of"]
    ([0.4, 0.0, 0.337], 'robotiq_2f85:tcp')
    """
    if "position" not in demo.streams or "orientation" not in demo.streams or demo["position"].shape[1] != 3:
        return demo, []  # no pose of a point of a robot: inverse kinematics names what it lacks
    stated = demo.metadata.get(POSE_OF)
    if stated is None:
        raise ValueError(f"pose_of: the {what}'s poses are of an unknown point of the robot, and "
                         f"{model.name} needs its tool's ({tool_point(model)}): {HOW_TO_SAY}")
    point = pose_point(stated, name=f"pose_of of the {what}")
    target = tool_point(model)
    if point.text == target:
        return demo, []
    T, note = _to_tool_transform(point, model)
    notes = [] if note is None else [note]
    if np.abs(T - np.eye(4)).max() <= _IDENTITY:
        meta = {**demo.metadata, POSE_OF: target}
        return Demonstration(demo.t, demo.streams, meta), notes
    position, q = demo["position"], demo["orientation"]
    streams = dict(demo.streams)
    streams["position"] = position + np.einsum("nij,j->ni", quaternion_to_matrix(q), T[:3, 3])
    streams["orientation"] = quaternion_multiply(q, matrix_to_quaternion(T[:3, :3])[None, :])
    shift = float(np.linalg.norm(T[:3, 3]))
    notes.append(f"pose_of: poses of the {point.text} converted to {model.name}'s tool {target} "
                 f"({shift * 1000:.4g} mm)")
    return Demonstration(demo.t, streams, {**demo.metadata, POSE_OF: target}), notes
