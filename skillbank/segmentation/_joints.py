"""What a hand does to a part of an articulated object: the chain of joints the part moved about.

A door's handle, held and pulled, moves about two joints: its latch turns it in the door, and the door
turns about its hinge. From the recorded poses alone (:func:`skillbank.core.fit_joint`), the part's motion
is explained either by one joint of its own, or by one joint of another recorded part that moved with it
(its parent: the door) and one joint of the part in that parent's frame; the account that leaves the
smaller residual is kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import Demonstration, Joint, fit_joint
from ..core._joints import _STILL
from ..core._rotations import log_map, quaternion_conjugate, quaternion_multiply, quaternion_to_matrix
from ._phases import object_streams

__all__ = ["PartJoints", "part_joints"]


@dataclass(frozen=True)
class PartJoints:
    """The joints a part moved about over a demonstration, in the world frame of its first sample.

    ``joints``: one or two :class:`~skillbank.core.Joint`, outermost last (a handle's latch, then the
    door's hinge), each with its value at every sample; ``anchor``: the recorded object whose pose at the
    first sample they are fixed to (the parent, else the part itself), so that a new scene moves them with
    that object's pose there; ``residual`` (m): the chain's account of the part's poses, as
    :attr:`~skillbank.core.Joint.residual` measures it.
    """

    part: str
    anchor: str
    joints: tuple
    residual: float

    def move(self, positions, quaternions, k):
        """Poses (the tool holding the part at the first sample) moved as the part moved by sample ``k``
        (an int or an array of them)."""
        p, q = np.asarray(positions, float), np.asarray(quaternions, float)
        for joint in self.joints:
            p, q = joint.move(p, q, np.asarray(joint.values)[k])
        return p, q

    def measure(self, start: dict, now: dict) -> np.ndarray:
        """How far each joint has moved between two scenes' poses of the part and its anchor.

        ``start`` and ``now``: ``{name: (position, quaternion)}`` of :attr:`part` and :attr:`anchor`, the
        chain fixed where the anchor stood at ``start`` (as :meth:`moved_with` puts it). The anchor's own
        joint is read from the anchor's motion in the world; the part's joint in its anchor, from the
        part's motion in the anchor's frame.
        """
        out = []
        a0, a1 = start[self.anchor], now[self.anchor]
        for k, joint in enumerate(self.joints):
            outer = k == len(self.joints) - 1
            if outer:  # the anchor's (or a lone part's) motion in the world
                p0, q0, p1, q1 = a0[0], a0[1], a1[0], a1[1]
                axis = joint.axis
                turn = log_map(quaternion_multiply(q1, quaternion_conjugate(q0)))
                slide = np.asarray(p1, float) - np.asarray(p0, float)
            else:  # the part in its anchor's frame (the axis, fitted with the anchor at its start, into it)
                R0 = quaternion_to_matrix(a0[1])
                axis = R0.T @ joint.axis
                rel = [quaternion_multiply(quaternion_conjugate(a[1]), part[1])
                       for a, part in ((a0, start[self.part]), (a1, now[self.part]))]
                turn = log_map(quaternion_multiply(rel[1], quaternion_conjugate(rel[0])))
                at = [quaternion_to_matrix(a[1]).T @ (np.asarray(part[0], float) - np.asarray(a[0], float))
                      for a, part in ((a0, start[self.part]), (a1, now[self.part]))]
                slide = at[1] - at[0]
            out.append(float((turn if joint.kind == "revolute" else slide) @ axis))
        return np.array(out)

    def moved_with(self, frame_from, frame_to) -> PartJoints:
        """The same chain in a scene where its anchor stands at ``frame_to`` (position, quaternion)
        instead of ``frame_from``."""
        turn = quaternion_multiply(np.asarray(frame_to[1], float), quaternion_conjugate(frame_from[1]))
        R = quaternion_to_matrix(turn)
        joints = tuple(Joint(j.kind, R @ j.axis, frame_to[0] + R @ (j.point - frame_from[0]), j.values,
                             j.residual, j.scale) for j in self.joints)
        return PartJoints(self.part, self.anchor, joints, self.residual)


def _moved(p, q) -> bool:
    """Whether poses ``p``, ``q`` moved by more than :func:`~skillbank.core.fit_joint` takes for still."""
    return bool(np.linalg.norm(p - p[0], axis=1).max() >= _STILL[0] or
                np.linalg.norm(log_map(q, q[0]), axis=1).max() >= _STILL[1])


def _poses(demo, name):
    return np.asarray(demo[f"{name}_pos"], float), np.asarray(demo[f"{name}_quat"], float)


def _in_parent(demo, part, parent):
    """The part's poses in the parent's frame, shown in the world as if the parent stayed at its first
    pose."""
    pp, pq = demo[f"{parent}_pos"], demo[f"{parent}_quat"]
    R = quaternion_to_matrix(pq)
    local_p = np.einsum("nji,nj->ni", R, demo[f"{part}_pos"] - pp)
    local_q = quaternion_multiply(quaternion_conjugate(pq), demo[f"{part}_quat"])
    return (local_p @ quaternion_to_matrix(pq[0]).T + pp[0],
            quaternion_multiply(np.broadcast_to(pq[0], local_q.shape), local_q))


def part_joints(demo: Demonstration, part: str) -> PartJoints | None:
    """The chain of joints ``part`` moved about over ``demo`` (a carry of it), or None if it did not move.

    Parameters
    ----------
    demo : Demonstration
        Records ``{part}_pos`` and ``{part}_quat`` (and the other objects' poses it may have moved with).
    part : str

    Returns
    -------
    PartJoints or None

    Examples
    --------
    A handle turned 1 rad about its latch and then, with its door, 0.4 rad about the hinge:

    >>> import numpy as np
    >>> from skillbank.core import Demonstration
    >>> a = np.r_[np.linspace(0, 1, 10), np.ones(10)]
    >>> h = np.r_[np.zeros(10), np.linspace(0, 0.4, 10)]
    >>> z = lambda v: np.c_[np.zeros((len(v), 2)), np.sin(v / 2), np.cos(v / 2)]
    >>> door_p = np.c_[np.cos(h), np.sin(h), np.zeros(20)]      # the door turns about the origin's z
    >>> latch = np.c_[np.sin(a / 2), np.zeros((20, 2)), np.cos(a / 2)]  # the handle turns about x in it
    >>> from skillbank.core._rotations import quaternion_multiply
    >>> demo = Demonstration(np.arange(20.0), {"door_pos": door_p, "door_quat": z(h),
    ...     "handle_pos": door_p, "handle_quat": quaternion_multiply(z(h), latch)})
    >>> chain = part_joints(demo, "handle")
    >>> chain.anchor, [j.kind for j in chain.joints], round(float(chain.joints[1].values[-1]), 6)
    ('door', ['revolute', 'revolute'], 0.4)
    """
    if part not in object_streams(demo) or not _moved(*_poses(demo, part)):
        return None
    own = fit_joint(*_poses(demo, part))
    best = PartJoints(part, part, (own,), own.residual)
    for parent in object_streams(demo):
        if parent == part or not _moved(*_poses(demo, parent)):
            continue
        outer = fit_joint(*_poses(demo, parent))
        local = _in_parent(demo, part, parent)
        if not _moved(*local):
            continue  # the part rode with its parent: the parent's joint alone is the part's
        inner = fit_joint(*local)
        chain = PartJoints(part, parent, (inner, outer), inner.residual + outer.residual)
        if chain.residual < best.residual:
            best = chain
    return best
