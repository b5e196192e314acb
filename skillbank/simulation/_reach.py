"""Commanded tool paths kept inside the arm's well-conditioned workspace, for robosuite's arms.

robosuite's operational-space controller tracks the tool, not the joints: a 6-joint arm has no null
space to hold its posture by, so the posture follows the tool through inverse kinematics' continuity
alone. Near the edge of the workspace the elbow is almost straight; a tool that tracks a few
centimetres off its path (measured: 3-4 cm where a carry swings out at the UR5e's reach) then
straightens it, and the arm can come out of that on the other elbow branch. After a placement at the
far side of a bin, the next reach then runs with the elbow below the arm and its upper arm strikes the
bin's wall (docs/benchmarks.md, "Composed tasks in physics").

:class:`Reach` reads the arm that a robosuite scene holds with the robot model registered for it
(:data:`REACH_MODELS`: its base where robosuite put it, its tool the point robosuite reports,
:func:`~skillbank.simulation.robot_frames`) and pulls a path's poses towards the arm's base axis,
horizontally, just enough that inverse kinematics on the arm's current branch keeps the elbow bent
by at least :data:`REACH_MARGIN` (the sine of the elbow angle), spreading each pull over the
neighbouring poses so the path eases in and out of it; the pose the task needs where it is (where the
gripper closes or opens, :meth:`Reach.needed`; else the path's last) is kept, the pull easing out over
the half second before it and in again after it. A path that stays within the margin is returned
unchanged. An arm without a registered model is not changed. Composed tasks use it
(:func:`~skillbank.simulation.execute_plan`: the arm goes on from where each step leaves it); ``sim
evaluate`` does not (docs/benchmarks.md: a nut carried over its peg at the edge of the workspace is
placed worse when its way there is pulled in).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..robots import robot_model
from ._robosuite import robot_frames

__all__ = ["Reach", "REACH_MODELS", "REACH_MARGIN"]


class ReachModel(NamedTuple):
    """How a robosuite arm maps onto a registered robot model.

    Attributes
    ----------
    name : str
        The registered model (:func:`~skillbank.robots.robot_model`).
    turn : tuple of 16 float
        robosuite's base body in the model's base frame, row-major 4 x 4.
    kind : str
        The model's singularity (``SINGULARITIES``) whose measure is the reach: 1 with the elbow at a
        right angle, 0 stretched (or folded).
    """

    name: str
    turn: tuple
    kind: str


#: robosuite arm name -> its model. The UR5e's base body in robosuite is ROS's ``base_link``, UR's
#: ``base`` turned by pi about z (``UR5e`` speaks in ``base``; docs/robots.md): with that turn the model's
#: FK of robosuite's joints is the reported tool pose within 3 mm.
REACH_MODELS = {
    "UR5e": ReachModel("ur5e", tuple(np.diag([-1.0, -1.0, 1.0, 1.0]).ravel()), "elbow"),
}
#: The least elbow measure (|sin| of the elbow joint: at least 37 degrees from straight) a commanded
#: path keeps. Chosen on the tuning scenes (docs/benchmarks.md): the tool's tracking error near the edge
#: of the workspace bends a commanded 0.3-0.45 into a straight arm; 0.6 keeps it bent.
REACH_MARGIN = 0.6
_SHRINK = np.linspace(1.0, 0.6, 41)  # the horizontal distances from the base axis tried, as fractions
_SPREAD = 10  # poses (half a second at 20 Hz) over which a pull eases in and out


class Reach:
    """The arm of a robosuite scene, to keep commanded tool paths within its reach margin.

    Parameters
    ----------
    env : robosuite environment
        A one-arm scene after its reset.
    margin : float, default=REACH_MARGIN
        The least reach measure along a path.

    Attributes
    ----------
    model_ : RobotModel or None
        The arm's model in robosuite's world frame; None when the arm has no entry in
        :data:`REACH_MODELS` (its paths are kept as they are).
    """

    def __init__(self, env, *, margin: float = REACH_MARGIN):
        self.margin = margin
        frames = robot_frames(env)
        entry = REACH_MODELS.get(frames["name"])
        self.kind_ = None if entry is None else entry.kind
        self.model_ = None if entry is None else robot_model(
            entry.name, base=np.array(frames["base"]) @ np.reshape(entry.turn, (4, 4)),
            tool=np.array(frames["tool"]))

    @staticmethod
    def needed(grip, *, let_go: bool = False) -> int:
        """The index of the pose a path of gripper commands ``grip`` needs where it is: its last change of
        command (the first pose with the new command), or its end when the command never changes; -1
        (none) for a path that keeps the gripper open right after one that let go (``let_go``): it only
        leaves what it let go of, and a retreat straight up from the edge of the workspace straightens
        the elbow.

        Examples
        --------
        >>> Reach.needed([-1, -1, 1, 1, 1]), Reach.needed([1, 1, 1]), Reach.needed([-1, -1], let_go=True)
        (2, 2, -1)
        """
        grip = np.asarray(grip, float)
        changes = np.flatnonzero(np.diff(np.sign(grip)) != 0)
        if len(changes):
            return int(changes[-1] + 1)
        return -1 if let_go and (grip <= 0).all() else len(grip) - 1

    def reaches(self, P, Q, joints) -> np.ndarray:
        """Whether each pose of ``P (n, 3)``, ``Q (n, 4)`` is within the margin on ``joints``' branch (all
        of them for an arm without a model)."""
        P = np.atleast_2d(np.asarray(P, float))
        if self.model_ is None:
            return np.ones(len(P), bool)
        branch = int(self.model_.branch_of(np.asarray(joints, float))[0])
        return self._measure(P, np.atleast_2d(np.asarray(Q, float)), branch) >= self.margin

    def _measure(self, P, Q, branch) -> np.ndarray:
        """The reach measure of each pose on ``branch`` (0 where the branch does not reach it)."""
        joints = self.model_.ik_all(P, Q)[:, branch]
        m = np.full(len(P), 0.0)
        ok = ~np.isnan(joints).any(axis=1)
        if ok.any():
            m[ok] = self.model_.singularity(joints[ok])[self.kind_]
        return m

    def keep(self, P, Q, joints, *, need=None) -> np.ndarray:
        """The path ``P (n, 3)`` (orientations ``Q (n, 4)``) pulled within the margin from ``joints``' branch.

        ``need``: the index of the pose the task needs where it is (where the gripper closes on an
        object or lets it go; default the last), which the pull eases out to and in from: a tool that
        moves on after letting go at the edge of the workspace is pulled in, not left with a straight
        elbow for the next step to start from.

        Examples
        --------
        >>> import numpy as np
        >>> reach = Reach.__new__(Reach); reach.model_ = None
        >>> reach.keep(np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 1)), np.zeros(6)).tolist()
        [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
        """
        P = np.array(P, float)
        if self.model_ is None or not len(P):
            return P
        Q = np.asarray(Q, float)
        branch = int(self.model_.branch_of(np.asarray(joints, float))[0])
        todo = self._measure(P, Q, branch) < self.margin
        if not todo.any():
            return P
        axis = self.model_.base[:2, 3]
        kept = np.ones(len(P))
        for s in _SHRINK[1:]:  # the largest fraction that brings each pose within the margin
            if not todo.any():
                break
            idx = np.flatnonzero(todo)
            trial = P[idx].copy()
            trial[:, :2] = axis + s * (trial[:, :2] - axis)
            ok = self._measure(trial, Q[idx], branch) >= self.margin
            kept[idx[ok]] = s
            todo[idx[ok]] = False
        # a pose that no tried fraction brings within the margin (its branch does not reach it nearer the
        # axis either) is left where it is: moving it would not help the elbow
        pull = 1.0 - kept
        # the largest pull within _SPREAD poses, smoothed: the path eases in and out of it
        padded = np.pad(pull, _SPREAD, mode="edge")
        window = np.lib.stride_tricks.sliding_window_view(padded, 2 * _SPREAD + 1).max(axis=1)
        kernel = np.hanning(2 * _SPREAD + 3)[1:-1]
        eased = np.convolve(np.pad(window, _SPREAD, mode="edge"), kernel / kernel.sum(), mode="valid")
        pull = np.maximum(eased, pull)
        # where the task needs the tool (a nut over its peg, a can let go over its place) the pose is kept:
        # the pull eases out before it and back in after it
        need = len(P) - 1 if need is None else int(need)
        pull *= np.clip(np.abs(np.arange(len(P)) - need) / _SPREAD, 0.0, 1.0)
        out = P.copy()
        moved = pull > 0.0  # the others exactly as they were
        out[moved, :2] = axis + (1.0 - pull[moved])[:, None] * (P[moved, :2] - axis)
        return out
