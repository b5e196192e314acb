"""What a primitive acts on: the object it moves with or ends at, and its end pose in that object's frame.

A demonstration that records object poses (robosuite's and robomimic's
``<name>_pos`` (n, 3) and ``<name>_quat`` (n, 4, x, y, z, w) streams) says
which object each primitive acts on, from the data alone: the object that
moves *with* the tool during the primitive (it is carried: it moves by more
than ``moved`` metres while it stays within ``rigid`` metres of where it is in
the tool's frame, for at least the first half of the primitive, up to where the
tool lets it go), else the object the tool *ends*
nearest (within ``near`` metres; a reach to a grasp). Nothing is named by
hand. The tool's end pose in that object's frame (:class:`Relation`) is
what a new scene needs: :func:`compose` puts it on the object's new pose,
``T_tool = T_object_new · T_relative`` (the goal of the primitive there).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import Demonstration, quaternion_to_matrix
from ..core._relation_words import describe_relation
from ..core._rotations import check_quaternions, quaternion_conjugate, quaternion_multiply
from ..core._validation import check_positive
from ..segmentation import object_streams, part_joints
from ..segmentation._phases import travel_with_tool

__all__ = ["Relation", "object_streams", "acted_on", "compose", "describe_relation"]


@dataclass(frozen=True)
class Relation:
    """The object a primitive acts on and the tool's end pose in its frame.

    Attributes
    ----------
    object : str
        Its name (``cube`` for the streams ``cube_pos`` and ``cube_quat``).
    moves_with : bool
        True when the object moved with the tool during the primitive (carried), False when the tool
        only ended near it (a reach).
    distance : float
        Tool to object at the primitive's end (m).
    position : ndarray of shape (3,)
        The tool's end position in the object's frame (m).
    orientation : ndarray of shape (4,) or None
        The tool's end orientation in the object's frame (x, y, z, w), if the tool's is recorded.
    start_position, start_orientation : ndarray or None
        The tool's end pose in the object's frame *at the primitive's start*: for a carried object
        (``moves_with``), where the primitive takes it, relative to where it was (a lift's height, a
        carry's displacement); the same as ``position`` and ``orientation`` for an object that stays.
    target : str or None
        For a carried object, the other object the tool ends nearest (within ``near``): where it is
        put (on a cube, into a bin that is an object); None when it ends near no other.
    target_position, target_orientation : ndarray or None
        The tool's end pose in the target's frame at the end.
    """

    object: str
    moves_with: bool
    distance: float
    position: np.ndarray
    orientation: np.ndarray | None
    start_position: np.ndarray | None = None
    start_orientation: np.ndarray | None = None
    target: str | None = None
    target_position: np.ndarray | None = None
    target_orientation: np.ndarray | None = None
    joints: tuple = ()

    @classmethod
    def from_dict(cls, doc: dict) -> Relation:
        """The relation of :meth:`to_dict` (as ``library list --json`` shows it under ``acts_on``).

        Examples
        --------
        >>> r = Relation("cube", False, 0.08, np.array([0.0, 0.0, 0.08]), None)
        >>> Relation.from_dict(r.to_dict()).position.tolist()
        [0.0, 0.0, 0.08]
        """
        if not isinstance(doc, dict) or not {"object", "moves_with", "distance", "position"} <= set(doc):
            raise ValueError("relation: expected a dict with object, moves_with, distance and position, as "
                             "Relation.to_dict writes it")

        def array(key):
            value = doc.get(key)
            return None if value is None else np.asarray(value, dtype=float)

        joints = doc.get("joints") or ()
        if not isinstance(joints, list | tuple) or not all(
                isinstance(j, dict) and {"kind", "in", "value"} <= set(j) for j in joints):
            raise ValueError("relation: expected joints as a list of {kind, in, value}, as Relation.to_dict "
                             "writes them")
        return cls(str(doc["object"]), bool(doc["moves_with"]), float(doc["distance"]), array("position"),
                   array("orientation"), array("start_position"), array("start_orientation"),
                   doc.get("target"), array("target_position"), array("target_orientation"),
                   tuple({"kind": str(j["kind"]), "in": str(j["in"]), "value": float(j["value"])}
                         for j in joints))

    def to_dict(self) -> dict:
        return {"object": self.object, "moves_with": self.moves_with, "distance": float(self.distance),
                "position": self.position.tolist(),
                "orientation": None if self.orientation is None else self.orientation.tolist(),
                "start_position": None if self.start_position is None else self.start_position.tolist(),
                "start_orientation": None if self.start_orientation is None else
                self.start_orientation.tolist(), "target": self.target,
                "target_position": None if self.target_position is None else self.target_position.tolist(),
                "target_orientation": None if self.target_orientation is None else
                self.target_orientation.tolist(), "joints": [dict(j) for j in self.joints]}


def acted_on(demo: Demonstration, *, near: float = 0.15, moved: float = 0.01, rigid: float = 0.02):
    """The :class:`Relation` of primitive ``demo`` (with ``position`` and object poses), or None.

    Parameters
    ----------
    demo : Demonstration
        A primitive: stream ``position`` (the tool's, m) and, optionally, ``orientation``, and the object
        poses of :func:`object_streams`.
    near : float, default=0.15
        Farthest an object may be from the tool's end and still be what a reach acts on (m); a reach
        that closes the gripper (robosuite's ``actions``, open at its start and shut at its end) acts on
        the nearest object however far.
    moved : float, default=0.01
        How far an object must move during the primitive to count as carried (m).
    rigid : float, default=0.02
        How far it may shift in the tool's frame meanwhile (m).

    Returns
    -------
    Relation or None
        None when no object moved with the tool and none is within ``near`` of its end (a move in free
        space) and the gripper did not close on one, or when ``demo`` records no object poses.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 5)
    >>> tool = np.column_stack([t, 0 * t, 0.1 + 0 * t])
    >>> d = Demonstration(t, {"position": tool, "cube_pos": np.tile([1.0, 0.0, 0.02], (5, 1)),
    ...                       "cube_quat": np.tile([0.0, 0.0, 0.0, 1.0], (5, 1))})
    >>> r = acted_on(d)
    >>> r.object, r.moves_with, r.position.round(3).tolist()
    ('cube', False, [0.0, 0.0, 0.08])
    """
    if not isinstance(demo, Demonstration) or "position" not in demo.streams:
        raise ValueError("demo: expected a Demonstration with a 'position' stream (the tool's)")
    near = check_positive(near, name="near")
    moved = check_positive(moved, name="moved")
    rigid = check_positive(rigid, name="rigid")
    P = demo["position"]
    if P.shape[1] != 3:
        raise ValueError(f"demo.position: expected 3-D tool positions, got {P.shape[1]}-D")
    frames = None
    if "orientation" in demo.streams and demo["orientation"].shape[1:] == (4,):
        frames = quaternion_to_matrix(check_quaternions(demo["orientation"], name="orientation"))
    carried, ends = [], []
    # the gripper's commands (robosuite's actions), where the primitive records them
    commands = demo["actions"][:, 6] if "actions" in demo.streams and demo["actions"].shape[1:] == (7,) \
        else None
    closed = commands is not None and bool(np.all(commands > 0))  # shut all along
    went, jointed = {}, {}  # how far each object went (with the tool or not); the joints that explain it
    slipped = set()  # the parts that moved in the fingers, where they went told by their joints alone

    def joints_of(name):
        """The chain of joints that explains the object's poses to a hundredth of how far it went, or
        None (a part of an articulated object moves about its joints; a carried box does not)."""
        if name not in jointed:
            chain = part_joints(demo, name)
            jointed[name] = chain if chain is not None and chain.residual < 0.01 * went[name] else None
        return jointed[name]

    for name in object_streams(demo):
        where = demo[f"{name}_pos"]
        gap = np.linalg.norm(where - P, axis=1)
        # carried while it stays where it is in the tool's frame (the wrist may turn it), until it is let
        # go (a primitive that ends with a release lets it fall after that); without the tool's
        # orientation, while it moves as the tool moves
        offset = where - P
        if frames is not None:
            offset = np.einsum("nji,nj->ni", frames, offset)
        off = np.flatnonzero(np.linalg.norm(offset - offset[0], axis=1) > rigid)
        held = len(gap) if off.size == 0 else int(off[0])
        went[name] = float(np.linalg.norm(where - where[0], axis=1).max())
        if held < len(gap) / 2 and went[name] > moved and closed and joints_of(name) is not None:
            slipped.add(name)
            # a part of an articulated object (a door's lever) pivots and slides between fingers that
            # give, 3 cm of a 16 cm pull, but it goes where its joints take it: when the gripper is
            # commanded shut all along and one chain of joints explains the part's poses, it is held
            # while the tool moves it (a lever springing back as the hand lets go and leaves moves about
            # its joint too, with the gripper open)
            held = len(gap)
        # it moved, and the tool's motion explains it (a cube settling at reset while the hand waits
        # above it moves too), for most of the primitive (an object that settles as the tool sets off
        # moves with it for a sample or two)
        travel = travel_with_tool(where[:held], offset[:held], moved=moved)
        if travel > 0.0 and held >= len(gap) / 2:
            carried.append((travel, name))
        ends.append((float(gap[-1]), name))
    if carried:
        name = max(carried)[1]  # the one carried furthest
    else:
        best = min(ends, default=None)
        # a reach that closes the gripper grasps something: the nearest object, however far its grip is
        # from the object's origin (a pot's handle, 17 cm out)
        grasps = commands is not None and commands[-1] > 0 >= commands[0]
        if best is None or (best[0] > near and not grasps):
            return None
        name = best[1]
    q_tool = None
    if "orientation" in demo.streams and demo["orientation"].shape[1:] == (4,):
        q_tool = check_quaternions(demo["orientation"][-1], name="orientation")

    def end_pose(obj, k):  # the tool's end pose in object obj's frame at sample k
        q_obj = check_quaternions(demo[f"{obj}_quat"][k], name=f"{obj}_quat")
        position = quaternion_to_matrix(q_obj).T @ (P[-1] - demo[f"{obj}_pos"][k])
        return position, None if q_tool is None else quaternion_multiply(quaternion_conjugate(q_obj), q_tool)

    (position, orientation), (start_position, start_orientation) = end_pose(name, -1), end_pose(name, 0)
    target, target_pose = None, (None, None)
    if carried:  # where it is put: the other object the tool ends nearest
        others = [(gap, other) for gap, other in ends if other != name and gap <= near]
        if others:
            target = min(others)[1]
            target_pose = end_pose(target, -1)
    joints = ()
    chain = joints_of(name) if carried else None  # what a carried part moved about (a door's handle)
    if chain is not None and name not in slipped and all(j.kind == "prismatic" for j in chain.joints):
        # held fast and carried along a line: a lift says nothing of a rail (any straight carry is a slide)
        chain = None
    if chain is not None:
        outer = len(chain.joints) - 1
        joints = tuple({"kind": j.kind, "in": "world" if k == outer else chain.anchor,
                        "value": round(float(j.values[np.argmax(np.abs(j.values))]), 4)}
                       for k, j in enumerate(chain.joints))
    return Relation(name, bool(carried), float(np.linalg.norm(P[-1] - demo[f"{name}_pos"][-1])), position,
                    orientation, start_position, start_orientation, target, *target_pose, joints)


def compose(relation: Relation, position, orientation, *, at: str = "end") -> tuple:
    """The tool pose ``(position (3,), orientation (4,) or None)`` of ``relation`` on an object's pose.

    ``at="end"``: the object's pose is where it is when the primitive ends (a reach: where it stands);
    ``at="start"``: where it is when the primitive starts (a carry: from where it is picked up);
    ``at="target"``: the pose of the relation's ``target`` (a carry: where it is put).

    Examples
    --------
    >>> r = Relation("cube", False, 0.08, np.array([0.0, 0.0, 0.08]), None)
    >>> p, q = compose(r, [0.5, 0.2, 0.02], [0.0, 0.0, 0.0, 1.0])
    >>> p.round(3).tolist(), q
    ([0.5, 0.2, 0.1], None)
    """
    if at not in ("end", "start", "target"):
        raise ValueError(f"at: expected 'end', 'start' or 'target', got {at!r}")
    if at == "target" and relation.target is None:
        raise ValueError(f"at: the relation to {relation.object!r} has no target (it is put near no other "
                         "object); use at='start'")
    rel_p, rel_q = {"end": (relation.position, relation.orientation),
                    "start": (relation.start_position, relation.start_orientation),
                    "target": (relation.target_position, relation.target_orientation)}[at]
    if rel_p is None:  # a relation made by hand with its end pose only
        rel_p, rel_q = relation.position, relation.orientation
    q_obj = check_quaternions(orientation, name="orientation")
    p_obj = np.asarray(position, dtype=float)
    if p_obj.shape != (3,) or not np.isfinite(p_obj).all():
        raise ValueError(f"position: expected 3 finite numbers, got {position!r}")
    p = p_obj + quaternion_to_matrix(q_obj) @ rel_p
    q = None if rel_q is None else quaternion_multiply(q_obj, rel_q)
    return p, q
