"""The robot-model interface: forward kinematics, all inverse-kinematics branches, following one along a path.

A subclass describes one arm in its own base frame and flange frame through
three methods, :meth:`RobotModel._fk`, :meth:`RobotModel._ik` and
:meth:`RobotModel._singularity`, and a few class attributes; this class
does the rest: validation, the user's base and tool frames, choosing a
branch, keeping it along a path, joint limits and the errors that name the
sample and the reason.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import ClassVar, NamedTuple

import numpy as np

from ..core._rotations import check_quaternions, matrix_to_quaternion, quaternion_to_matrix
from ..core._validation import check_array, check_positive, numerical_errors, summarise
from ._bodies import GRIPPERS, Gripper

__all__ = ["RobotModel", "KinematicsError", "Singularity", "wrap_angle"]

TWO_PI = 2.0 * np.pi

#: Largest deviation from a rigid transform accepted in ``base`` and ``tool`` (orthonormality of the
#: rotation, the last row): tighter than any printed matrix needs, looser than round-off.
_RIGID_TOLERANCE = 1e-6


class Singularity(NamedTuple):
    """One kind of singularity: the measure :meth:`RobotModel._singularity` returns and its threshold."""

    measure: str
    threshold: float


class KinematicsError(ValueError):
    """A pose path the robot cannot follow.

    Attributes
    ----------
    index : int
        The first sample that fails.
    reason : str
        ``"unreachable"``, ``"singularity"``, ``"branch flip"``, ``"jump"`` or ``"joint limit"``.
    """

    def __init__(self, message: str, *, index: int, reason: str):
        super().__init__(message)
        self.index = index
        self.reason = reason


def wrap_angle(a):
    """Angles wrapped into [-pi, pi).

    Examples
    --------
    >>> wrap_angle(np.array([3 * np.pi / 2, -np.pi])).round(6).tolist()
    [-1.570796, -3.141593]
    """
    return (np.asarray(a, dtype=float) + np.pi) % TWO_PI - np.pi


def _check_rigid(value, name: str) -> np.ndarray:
    if value is None:
        return np.eye(4)
    T = check_array(value, name=name, ndim=2)
    if T.shape != (4, 4):
        raise ValueError(f"{name}: expected a 4 x 4 homogeneous transform, got shape {T.shape}")
    R = T[:3, :3]
    if (np.abs(R.T @ R - np.eye(3)).max() > _RIGID_TOLERANCE or abs(np.linalg.det(R) - 1) > _RIGID_TOLERANCE
            or np.abs(T[3] - [0, 0, 0, 1]).max() > _RIGID_TOLERANCE):
        raise ValueError(f"{name}: expected a rigid transform (a rotation matrix and a translation, last row "
                         f"0 0 0 1), got {np.array2string(T, precision=4, separator=',')}")
    return T


def _check_gripper(value, default):
    if isinstance(value, Gripper):
        return value
    if value == "default":
        value = default
    if value is None or value == "none":
        return None
    if not isinstance(value, str) or value not in GRIPPERS:
        raise ValueError(f"gripper: expected 'default', 'none' or one of {list(GRIPPERS)}, got {value!r}")
    return GRIPPERS[value]


def _check_tool(value, gripper):
    """The tool transform: a 4 x 4 rigid transform, ``"flange"``, ``"tcp"`` (the mounted gripper's) or a
    gripper's name (its TCP)."""
    if value is None:  # the default: where the mounted gripper works, else the flange
        return np.eye(4) if gripper is None else gripper.tool()
    if not isinstance(value, str):
        return _check_rigid(value, "tool")
    if value == "flange":
        return np.eye(4)
    if value == "tcp":
        if gripper is None:
            raise ValueError("tool: 'tcp' is the mounted gripper's tool centre point, but no gripper is "
                             "mounted (gripper='none'); give the gripper or a 4 x 4 tool transform")
        return gripper.tool()
    if value in GRIPPERS:
        return GRIPPERS[value].tool()
    raise ValueError(f"tool: expected a 4 x 4 transform, 'flange', 'tcp' or a gripper's name among "
                     f"{list(GRIPPERS)}, got {value!r}")


def _inverse_rigid(T: np.ndarray) -> np.ndarray:
    inv = np.eye(4)
    inv[:3, :3] = T[:3, :3].T
    inv[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return inv


class RobotModel(ABC):
    """A serial arm: forward kinematics, analytic inverse kinematics with all its branches, joint limits.

    Poses are the tool's position (metres) and orientation (unit quaternion,
    scalar-last) in the world frame; the world frame is the robot's base frame
    moved by ``base``, the tool is the flange moved by ``tool``.

    Parameters
    ----------
    base : array-like of shape (4, 4), optional
        The robot's base frame in the world frame (default: they coincide).
    tool : array-like of shape (4, 4) or str, optional
        The tool frame in the flange frame. Default: the mounted gripper's tool centre point
        (``gripper_.tool()``; the Robotiq 2F-85's on the UR5e, 0.163 m along the flange's z, where
        the closed fingertips meet), or the flange when no gripper is mounted. ``"tcp"`` says the
        same explicitly, a gripper's name (``"robotiq_2f85"``) gives that gripper's TCP, ``"flange"``
        the flange (ROS's ``tool0``: what a UR controller records as its pose unless a TCP is set,
        as in the three-button recording).
    gripper : str or Gripper, default="default"
        The gripper mounted on the flange (its capsules join :attr:`bodies`): ``"default"`` the
        robot's ``DEFAULT_GRIPPER``, ``"none"``, a name in ``GRIPPERS`` or a :class:`Gripper`.
    singularity_thresholds : mapping of str to float, optional
        Thresholds replacing the class's (``SINGULARITIES``), by kind.
    max_step : float, default=0.5
        Largest change of any joint (radians) between consecutive samples of
        a path; a bigger one is a branch flip or a jump (see :meth:`ik`).

    Notes
    -----
    A subclass sets ``name``, ``joint_names``, ``lower`` and ``upper``
    (limits, radians), ``branch_names``, ``home`` (the configuration whose
    branch :meth:`ik` takes when given neither a branch nor a seed) and
    ``SINGULARITIES``, and implements :meth:`_fk`, :meth:`_ik` and
    :meth:`_singularity`. It may set ``max_velocity`` and ``max_acceleration``
    (per joint, rad/s and rad/s^2: the robot's own limits, which every
    executable trajectory for it meets) and implement :meth:`_out_of_reach`
    (how far a pose is outside the workspace, for the error message).
    """

    name: ClassVar[str]
    joint_names: ClassVar[tuple[str, ...]]
    lower: ClassVar[tuple[float, ...]]
    upper: ClassVar[tuple[float, ...]]
    branch_names: ClassVar[tuple[str, ...]]
    home: ClassVar[tuple[float, ...]]
    SINGULARITIES: ClassVar[dict[str, Singularity]]
    #: The robot's own joint velocity (rad/s) and acceleration (rad/s^2) limits, per joint; None: none known.
    max_velocity: ClassVar[tuple[float, ...] | None] = None
    max_acceleration: ClassVar[tuple[float, ...] | None] = None
    #: Mass (kg) of each moving link, joint 1 to the flange; None: the simulator's own table
    #: (``skillbank.simulation.LINK_MASSES``). A model read from a description carries its own.
    link_masses: ClassVar[tuple[float, ...] | None] = None
    #: The links' collision capsules (:class:`~skillbank.robots.Capsule`), frames as in :meth:`link_frames`.
    BODIES: ClassVar[tuple] = ()
    #: The gripper mounted unless ``gripper`` says otherwise (a name in ``GRIPPERS``), or None.
    DEFAULT_GRIPPER: ClassVar[str | None] = None
    #: Body name pairs never checked for self-collision besides those on the same or consecutive frames
    #: (bodies whose envelopes touch at every configuration, or cannot reach each other).
    SELF_COLLISION_SKIP: ClassVar[frozenset] = frozenset()

    def __init__(self, *, base=None, tool=None, singularity_thresholds=None, max_step=0.5,
                 gripper="default"):
        self.gripper = gripper
        self.gripper_ = _check_gripper(gripper, self.DEFAULT_GRIPPER)
        self.base = _check_rigid(base, "base")
        self.tool = _check_tool(tool, self.gripper_)
        self._base_inv, self._tool_inv = _inverse_rigid(self.base), _inverse_rigid(self.tool)
        if singularity_thresholds is not None and not isinstance(singularity_thresholds, Mapping):
            raise ValueError("singularity_thresholds: expected a mapping of kind to threshold, got "
                             f"{singularity_thresholds!r}")
        given = dict(singularity_thresholds or {})
        unknown = sorted(set(given) - set(self.SINGULARITIES))
        if unknown:
            raise ValueError(f"singularity_thresholds: expected kinds among {list(self.SINGULARITIES)}, "
                             f"got {summarise(map(repr, unknown))}")
        self.singularity_thresholds = {
            kind: check_positive(given.get(kind, s.threshold), name=f"singularity_thresholds[{kind!r}]",
                                 allow_zero=True)
            for kind, s in self.SINGULARITIES.items()}
        self.max_step = check_positive(max_step, name="max_step")

    def __repr__(self) -> str:
        changed = [name for name, same in (
            ("base", np.array_equal(self.base, np.eye(4))),
            ("tool", np.array_equal(self.tool, _check_tool(None, self.gripper_))),
            ("singularity_thresholds", all(self.singularity_thresholds[k] == s.threshold
                                           for k, s in self.SINGULARITIES.items())),
            ("max_step", self.max_step == 0.5)) if not same]
        return f"{type(self).__name__}({', '.join(f'{name}=...' for name in changed)})"

    # ------------------------------------------------------------------ to implement

    @abstractmethod
    def _fk(self, q: np.ndarray) -> np.ndarray:
        """Flange poses ``(n, 4, 4)`` in the robot's base frame for joints ``q (n, n_joints)``."""

    @abstractmethod
    def _ik(self, T: np.ndarray) -> np.ndarray:
        """Every branch's joints ``(n, n_branches, n_joints)`` in [-pi, pi) for flange poses ``T (n, 4, 4)``.

        NaN where a branch has no solution.
        """

    @abstractmethod
    def _singularity(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """Per kind of ``SINGULARITIES``, its measure ``(n,)`` at joints ``q``: 0 at the singularity."""

    def _frames(self, q: np.ndarray) -> np.ndarray:
        """Every link frame ``(n, n_joints + 1, 4, 4)`` in the robot's base frame: the base, then after
        each joint (the last is the flange). A model without bodies need not implement it."""
        raise NotImplementedError(f"robot {self.name} describes no link frames")

    def link_frames(self, q) -> np.ndarray:
        """The link frames ``(n, n_joints + 1, 4, 4)`` in the world frame for joints ``q`` ``(n, n_joints)``.

        Frame 0 is the robot's base, frame ``i`` the link that joint ``i`` moves; the last one is the
        flange (the tool frame is ``link_frames(q)[:, -1] @ tool``).
        """
        q = self.check_joints(q)
        with numerical_errors(f"{self.name} forward kinematics"):
            return self.base @ self._frames(q)

    @property
    def bodies(self) -> tuple:
        """Every collision capsule: the arm's (``BODIES``) and the mounted gripper's (in the flange frame)."""
        out = tuple(self.BODIES)
        if self.gripper_ is not None:
            flange = self.n_joints
            out += tuple(c._replace(frame=flange) for c in self.gripper_.capsules)
        return out

    def self_collision_pairs(self) -> tuple:
        """The body pairs checked for self-collision, ``((name, name), ...)``.

        Every pair of :attr:`bodies` except those on the same or consecutive frames (joined by one joint,
        they touch where the joint is) and those in ``SELF_COLLISION_SKIP``.
        """
        bodies = self.bodies
        skip = {frozenset(pair) for pair in self.SELF_COLLISION_SKIP}
        return tuple((a.name, b.name) for i, a in enumerate(bodies) for b in bodies[i + 1:]
                     if abs(a.frame - b.frame) > 1 and frozenset((a.name, b.name)) not in skip)

    def _out_of_reach(self, T: np.ndarray) -> np.ndarray:
        """How far (m) each flange pose ``T (n, 4, 4)`` is outside the workspace; NaN: not known.

        Only called for poses that no branch reaches; the default knows no distance.
        """
        return np.full(T.shape[0], np.nan)

    # ------------------------------------------------------------------ the interface

    @property
    def n_joints(self) -> int:
        """Number of joints."""
        return len(self.joint_names)

    @property
    def limits(self) -> np.ndarray:
        """Joint limits ``(n_joints, 2)``: lower and upper, radians."""
        return np.column_stack([self.lower, self.upper]).astype(float)

    @property
    def rate_limits(self) -> dict:
        """The robot's own limits as ``{"joint_velocity": (n_joints,), "joint_acceleration": (n_joints,)}``.

        Only the kinds the model declares (``max_velocity``, ``max_acceleration``).
        """
        given = {"joint_velocity": self.max_velocity, "joint_acceleration": self.max_acceleration}
        return {key: np.asarray(value, dtype=float) for key, value in given.items() if value is not None}

    def check_joints(self, q, *, name: str = "q") -> np.ndarray:
        """Joints as a float array ``(n, n_joints)`` (one configuration becomes one row), else ValueError."""
        arr = check_array(q, name=name, ndim=(1, 2))
        if arr.shape[-1] != self.n_joints:
            raise ValueError(f"{name}: expected {self.n_joints} joint values per sample "
                             f"({', '.join(self.joint_names)}), got shape {arr.shape}")
        return np.atleast_2d(arr)

    def _poses(self, position, quaternion) -> tuple[np.ndarray, bool]:
        """Validated world poses as flange transforms in the base frame, and whether one pose was given."""
        p = check_array(position, name="position", ndim=(1, 2))
        q = check_quaternions(quaternion, name="quaternion")
        if p.shape[-1] != 3:
            raise ValueError(f"position: expected 3 coordinates per sample, got shape {p.shape}")
        if p.ndim != q.ndim or np.atleast_2d(p).shape[0] != np.atleast_2d(q).shape[0]:
            raise ValueError(f"quaternion: expected one per position (shape {p.shape[:-1] + (4,)}), got "
                             f"shape {q.shape}")
        single = p.ndim == 1
        p, q = np.atleast_2d(p), np.atleast_2d(q)
        T = np.zeros((p.shape[0], 4, 4))
        T[:, :3, :3] = quaternion_to_matrix(q)
        T[:, :3, 3] = p
        T[:, 3, 3] = 1.0
        return self._base_inv @ T @ self._tool_inv, single

    def fk(self, q):
        """The tool pose for joints ``q``.

        Parameters
        ----------
        q : array-like of shape (n, n_joints) or (n_joints,)
            Joint angles, radians, in :attr:`joint_names` order.

        Returns
        -------
        position : ndarray of shape (n, 3) or (3,)
        quaternion : ndarray of shape (n, 4) or (4,)
            Scalar-last, ``w >= 0``.
        """
        single = np.ndim(q) == 1
        q = self.check_joints(q)
        with numerical_errors(f"{self.name} forward kinematics"):
            T = self.base @ self._fk(q) @ self.tool
            position, quaternion = T[:, :3, 3], matrix_to_quaternion(T[:, :3, :3])
        return (position[0], quaternion[0]) if single else (position, quaternion)

    def ik_all(self, position, quaternion) -> np.ndarray:
        """Every branch's joints for each pose, NaN where a branch cannot reach it.

        Parameters
        ----------
        position : array-like of shape (n, 3) or (3,)
        quaternion : array-like of shape (n, 4) or (4,)
            Scalar-last unit quaternions.

        Returns
        -------
        ndarray of shape (n, n_branches, n_joints) or (n_branches, n_joints)
            Angles in [-pi, pi), branches in :attr:`branch_names` order.
        """
        T, single = self._poses(position, quaternion)
        with numerical_errors(f"{self.name} inverse kinematics"):
            sols = self._ik(T)
        return sols[0] if single else sols

    def branch_index(self, branch) -> int:
        """The index of ``branch``, given as an index or one of :attr:`branch_names`."""
        if isinstance(branch, (int, np.integer)) and not isinstance(branch, bool) \
                and 0 <= branch < len(self.branch_names):
            return int(branch)
        if isinstance(branch, str) and branch in self.branch_names:
            return self.branch_names.index(branch)
        raise ValueError(f"branch: expected one of {list(self.branch_names)} or an index below "
                         f"{len(self.branch_names)}, got {branch!r}")

    def branch_of(self, q) -> np.ndarray:
        """The branch of each configuration ``q``: the branch whose solution of ``fk(q)`` is nearest ``q``.

        Returns
        -------
        ndarray of int, shape (n,)
        """
        q = self.check_joints(q)
        with numerical_errors(f"{self.name} branch"):
            sols = self._ik(self._fk(q))
            return _nearest_branch(sols, q)

    def singularity(self, q) -> dict[str, np.ndarray]:
        """Each kind of singularity's measure at joints ``q`` (``(n,)``; it is 0 at the singularity)."""
        q = self.check_joints(q)
        with numerical_errors(f"{self.name} singularity"):
            return self._singularity(q)

    def ik(self, position, quaternion, *, branch=None, q_seed=None) -> np.ndarray:
        """Joints along a pose path, on one branch, continuous and within the limits.

        The branch is ``branch`` if given; else the one whose solution at the
        first pose is nearest ``q_seed`` (default :attr:`home`). It is kept
        along the whole path. Each joint is continuous: the solutions are
        unwrapped (each sample moved by a multiple of 2 pi to be nearest the
        previous one), and the whole joint path is then moved by the multiple
        of 2 pi that starts it nearest the seed while staying within the
        limits.

        Parameters
        ----------
        position : array-like of shape (n, 3) or (3,)
        quaternion : array-like of shape (n, 4) or (4,)
            Scalar-last unit quaternions.
        branch : int or str, optional
            An index or a name in :attr:`branch_names`.
        q_seed : array-like of shape (n_joints,), optional
            A configuration to start near (e.g. the robot's current one).

        Returns
        -------
        ndarray of shape (n, n_joints) or (n_joints,)

        Raises
        ------
        KinematicsError
            A ``ValueError`` naming the first sample that fails and why: the
            pose is out of the branch's reach, the path comes within a
            singularity's threshold, a joint would move by more than
            ``max_step`` in one sample (onto another branch: a branch flip;
            onto none: a jump in the path), or a joint would leave its limits.
        """
        T, single = self._poses(position, quaternion)
        seed = self._seed(q_seed)
        b = None if branch is None else self.branch_index(branch)
        with numerical_errors(f"{self.name} inverse kinematics"):
            sols = self._ik(T)
            self._check_reach(sols, T)
            b = self._choose_branch(sols, seed, b)
            path = self._follow(sols, b, seed)
        return path[0] if single else path

    def _seed(self, q_seed) -> np.ndarray:
        """``q_seed`` checked as one configuration ``(n_joints,)``; :attr:`home` when None."""
        seed = self.check_joints(self.home if q_seed is None else q_seed, name="q_seed")
        if seed.shape[0] != 1:
            raise ValueError(f"q_seed: expected one configuration of {self.n_joints} joints, got shape "
                             f"{np.shape(q_seed)}")
        return seed[0]

    # ------------------------------------------------------------------ following a path

    def _check_reach(self, sols: np.ndarray, T: np.ndarray) -> None:
        """Samples no branch reaches are the first thing to fix: reported before singularities on the way.

        A path towards a goal beyond the arm's reach stretches the arm first, so the samples before
        the goal come near the elbow singularity; the goal's distance is what the user must change.
        """
        none = np.isnan(sols).any(axis=2).all(axis=1)
        if not none.any():
            return
        bad = np.flatnonzero(none)
        k = int(bad[0])
        excess = self._out_of_reach(T[bad])
        more = "" if bad.size == 1 else f"; {bad.size} such samples"
        if np.isnan(excess).all():
            message = f"position: sample {k} is out of the arm's reach (no solution on any branch{more})"
        elif bad.size == 1:
            message = (f"position: sample {k} is out of the arm's reach by {float(excess[0]):.3g} m (no "
                       "solution on any branch): bring it within reach")
        else:
            worst = int(np.nanargmax(excess))
            message = (f"position: sample {k} is out of the arm's reach (no solution on any branch{more}, "
                       f"out by up to {float(excess[worst]):.3g} m at sample {int(bad[worst])}): bring the "
                       "path within reach")
        raise KinematicsError(message, index=k, reason="unreachable")

    def _choose_branch(self, sols: np.ndarray, seed: np.ndarray, branch) -> int:
        if branch is not None:
            return branch
        return int(_nearest_branch(sols[0][None], seed[None])[0])

    def _follow(self, sols: np.ndarray, b: int, seed: np.ndarray) -> np.ndarray:
        name = self.branch_names[b]
        path = sols[:, b]
        missing = np.flatnonzero(np.isnan(path).any(axis=1))
        m = int(missing[0]) if missing.size else path.shape[0]
        path = np.unwrap(path[:m], axis=0)
        failures = []  # (index, priority, message, reason): the earliest sample wins, ties by priority
        if m < sols.shape[0]:
            # every sample is reachable on some branch (_check_reach): name those that reach them all
            whole = np.flatnonzero(~np.isnan(sols).any(axis=2).any(axis=0))
            if whole.size:
                names = ", ".join(repr(self.branch_names[k]) for k in whole)
                message = (f"position: sample {m} is out on branch {name!r}; the whole path is reachable on "
                           f"{names}: choose one with branch=... (--branch on the command line)")
            else:
                here = summarise(repr(self.branch_names[k])
                                 for k in np.flatnonzero(~np.isnan(sols[m]).any(axis=1)))
                message = (f"position: sample {m} is out on branch {name!r} (reachable on {here}); no one "
                           "branch reaches the whole path: change the path")
            failures.append((m, 0, message, "unreachable"))
        one = sols.shape[0] == 1
        for kind, measure in self._singularity(path).items():
            # along a path, near a singularity the joints race: the threshold refuses it; one pose has no
            # motion to race, so only an exactly singular pose (whose solution is not unique) is refused
            threshold = 0.0 if one else self.singularity_thresholds[kind]
            near = np.flatnonzero(measure <= 0.0 if one else measure < threshold)
            if near.size:
                k = int(near[0])
                if one:
                    message = (f"position: the pose is exactly at the {kind} singularity "
                               f"({self.SINGULARITIES[kind].measure} = 0): its joints are not unique; move "
                               "it off the singularity")
                else:
                    message = (f"position: sample {k} is near the {kind} singularity "
                               f"({self.SINGULARITIES[kind].measure} = {float(measure[k]):.3g} < "
                               f"{threshold:g}; {near.size} such samples)")
                failures.append((k, 1, message, "singularity"))
        failures.extend(self._jumps(sols, path, b))
        path, outside = self._fit_limits(path, seed, name)
        failures.extend(outside)
        if failures:
            k, _, message, reason = min(failures, key=lambda f: (f[0], f[1]))
            raise KinematicsError(message, index=k, reason=reason)
        return path

    def _jumps(self, sols: np.ndarray, path: np.ndarray, b: int) -> list:
        steps = np.abs(np.diff(path, axis=0)).max(axis=1)
        big = np.flatnonzero(steps > self.max_step)
        if not big.size:
            return []
        k = int(big[0]) + 1
        j = int(np.argmax(np.abs(path[k] - path[k - 1])))
        moved = f"joint {self.joint_names[j]!r} would move by {float(steps[k - 1]):.3g} rad in one sample"
        near = np.abs(wrap_angle(sols[k] - path[k - 1])).max(axis=1)
        near[b] = np.inf
        near = np.where(np.isnan(near), np.inf, near)
        if near.min() <= self.max_step:
            other = self.branch_names[int(np.argmin(near))]
            message = (f"position: sample {k} would flip the branch from {self.branch_names[b]!r} to "
                       f"{other!r} ({moved}, more than max_step={self.max_step:g}; the path crosses a "
                       "singularity between samples)")
            return [(k, 2, message, "branch flip")]
        message = (f"position: sample {k}: {moved} on every branch (more than max_step={self.max_step:g}; "
                   "the pose path jumps)")
        return [(k, 2, message, "jump")]

    def _fit_limits(self, path: np.ndarray, seed: np.ndarray, name: str):
        """``path`` moved by the multiple of 2 pi per joint that starts nearest ``seed`` within the limits.

        Returns the moved path and the failure (a list of at most one) when no multiple keeps a joint
        within its limits along the whole path.
        """
        if not path.shape[0]:
            return path, []
        lo, hi = self.limits.T
        first = np.ceil((lo - path.min(axis=0)) / TWO_PI - 1e-12)  # fewest turns keeping the minimum in
        last = np.floor((hi - path.max(axis=0)) / TWO_PI + 1e-12)  # most turns keeping the maximum in
        preferred = np.round((seed - path[0]) / TWO_PI)
        bad = np.flatnonzero(first > last)
        if not bad.size:
            return path + TWO_PI * np.clip(preferred, first, last), []
        # No multiple fits: start within the limits nearest the seed and report where the joint leaves them.
        j = int(bad[0])
        turns = np.clip(preferred[j], np.ceil((lo[j] - path[0, j]) / TWO_PI - 1e-12),
                        np.floor((hi[j] - path[0, j]) / TWO_PI + 1e-12))
        shifted = path[:, j] + TWO_PI * turns
        k = int(np.flatnonzero((shifted < lo[j]) | (shifted > hi[j]))[0])
        message = (f"position: sample {k}: joint {self.joint_names[j]!r} would leave its limits "
                   f"[{lo[j]:.4g}, {hi[j]:.4g}] on branch {name!r} (the path turns it through "
                   f"{float(np.ptp(path[:, j])):.4g} rad)")
        return path, [(k, 3, message, "joint limit")]


def _nearest_branch(sols: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Per sample, the branch whose solution (equal angles modulo 2 pi) is nearest ``q``."""
    distance = np.linalg.norm(wrap_angle(sols - q[:, None, :]), axis=2)
    return np.argmin(np.where(np.isnan(distance), np.inf, distance), axis=1)
