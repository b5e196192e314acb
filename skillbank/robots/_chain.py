"""Any serial arm of revolute joints: forward kinematics from its frames, numerical inverse kinematics.

A :class:`KinematicChain` is the data a description file gives (read by
:func:`~skillbank.robots.load_description`): the link frames at zero joint
angles, the joint names and limits, the links' collision capsules and masses.
:class:`ChainModel` makes it a :class:`~skillbank.robots.RobotModel`.

**Frames.** Frame ``i - 1``'s z axis is joint ``i``'s axis, through frame
``i - 1``'s origin; turning joint ``i`` by ``q_i`` turns every frame after it
about that axis, so ``frame_i(q) = frame_{i-1}(q) Rz(q_i) F_i`` with
``F_i = frame_{i-1}(0)^-1 frame_i(0)`` fixed. Frame 0 is joint 1's frame
(fixed on the base), frame ``n`` the flange: the description's tool frame.
This is the convention the UR5e's DH frames follow too, so the simulator, the
clearance check and the planners treat every arm alike.

**Inverse kinematics** is damped least squares (Levenberg-Marquardt with the
damping of Sugihara 2011, ``lambda^2 = |e|^2 / 2 + 1e-6``, which converges
from far and quadratically near a solution) on all samples at once. A path
is solved coarse to fine: every ``stride``-th sample one after another, each
seeded by the one before (the path stays on the seed's branch), then the
samples in between all at once, seeded by their neighbours' solutions,
halving the stride each pass. Where the arm is redundant (7 joints), the
null space pulls the joints towards a reference (the seed, or recorded
joints) and away from their limits; it never moves the tool.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..core._rotations import matrix_to_quaternion
from ..core._validation import check_array, check_positive, numerical_errors
from ._base import KinematicsError, RobotModel, Singularity

__all__ = ["KinematicChain", "ChainModel", "rotation_error"]

#: Samples solved one after another before the coarse-to-fine passes: every ``_STRIDE``-th.
_STRIDE = 16
#: Joints' step per iteration, at most (radians): a Newton step from far can leap onto another branch.
_MAX_ITERATION_STEP = 0.3
#: Null-space gains: towards the reference posture, and away from a limit within ``_LIMIT_ZONE`` of it.
_POSTURE_GAIN = 0.5
_LIMIT_GAIN = 0.5
_LIMIT_ZONE = 0.1  # as a fraction of the joint's range
_POSTURE_SETTLED = 1e-4  # rad per iteration


class KinematicChain(NamedTuple):
    """A serial arm as read from its description.

    Attributes
    ----------
    name : str
    joint_names : tuple of str
    lower, upper : tuple of float
        Joint limits (radians); -inf / inf for an unlimited joint.
    frames : ndarray of shape (n_joints + 1, 4, 4)
        The link frames at zero joint angles, in the robot's base frame (the description's world),
        as the module docstring defines them.
    bodies : tuple of Capsule
        Collision capsules in those frames.
    masses : tuple of float
        Mass (kg) carried by each frame: the base, then each joint's link up to the flange.
    home : tuple of float
        A configuration inside the limits: the description's reference pose, moved into the limits.
    self_collision_skip : frozenset
        Pairs of body names never checked for self-collision (see :func:`self_collision_skip`).
    source : str
        Where the description came from (a path, a registered name).
    tool_frame : str
        The body or site of the description that is the flange.
    gripper : str or None
        The gripper mounted on the flange unless the model is told otherwise (a name in
        :data:`~skillbank.robots.GRIPPERS`; the registry sets the Panda's hand), or None.
    """

    name: str
    joint_names: tuple
    lower: tuple
    upper: tuple
    frames: np.ndarray
    bodies: tuple = ()
    masses: tuple = ()
    home: tuple = ()
    self_collision_skip: frozenset = frozenset()
    source: str = ""
    tool_frame: str = ""
    gripper: str | None = None


def _rz(q: np.ndarray) -> np.ndarray:
    c, s = np.cos(q), np.sin(q)
    R = np.zeros(q.shape + (4, 4))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1] = c, -s, s, c
    R[..., 2, 2] = R[..., 3, 3] = 1.0
    return R


def rotation_error(R_target: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The rotation vector ``(..., 3)`` (axis times angle, radians, world frame) from ``R`` to the target.

    Examples
    --------
    >>> Rz = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    >>> rotation_error(Rz, np.eye(3)).round(6).tolist()
    [0.0, 0.0, 1.570796]
    """
    q = matrix_to_quaternion(R_target @ np.swapaxes(R, -1, -2))  # scalar-last, w >= 0
    v, w = q[..., :3], q[..., 3]
    s = np.linalg.norm(v, axis=-1)
    angle = 2.0 * np.arctan2(s, w)
    # angle / s -> 2 as s -> 0 (the small-angle limit), without dividing by zero
    scale = np.where(s > 1e-12, angle / np.where(s > 1e-12, s, 1.0), 2.0)
    return v * scale[..., None]


class ChainModel(RobotModel):
    """A serial arm of revolute joints from its :class:`KinematicChain`: FK, Jacobian, numerical IK.

    Parameters
    ----------
    chain : KinematicChain
        Usually from :func:`~skillbank.robots.load_description` (``robot_model(path)`` does both).
    base, tool, singularity_thresholds, max_step
        As :class:`~skillbank.robots.RobotModel`.
    gripper : str or Gripper, default="default"
        As :class:`~skillbank.robots.RobotModel`; ``"default"`` is the chain's own ``gripper`` (the
        registered Panda's hand), none for a description file (its end effector, if any, lies beyond
        the tool frame). With a gripper, its capsules join the self-collision rule
        (:func:`self_collision_skip`) like the links'.
    tolerance : float, default=1e-6
        Position error (m) at which a pose counts as reached; the orientation's is
        ``tolerance / length_`` radians (Notes).
    max_iterations : int, default=100
        Damped-least-squares iterations per pass before a sample counts as unreachable.

    Notes
    -----
    The orientation's error is measured in radians and compared with ``tolerance / length``,
    ``length`` the arm's reach (:attr:`length_`): both say how far the tool's points within the
    arm's size are from the pose. The singularity measure (``jacobian``) is the smallest singular
    value of the Jacobian with its position rows divided by ``length``: 0 where the tool loses a
    direction; below the threshold (0.01) the joints race for a small tool motion.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank.robots import KinematicChain, ChainModel
    >>> F = np.tile(np.eye(4), (3, 1, 1))
    >>> F[1, :3, 3], F[2, :3, 3] = [0.3, 0, 0], [0.6, 0, 0]  # a planar arm: two 0.3 m links about z
    >>> arm = ChainModel(KinematicChain("two", ("a", "b"), (-3, -3), (3, 3), F, home=(0.1, 0.2)))
    >>> arm.fk([0.0, np.pi / 2])[0].round(3).tolist()
    [0.3, 0.3, 0.0]
    """

    branch_names = ("seeded",)
    SINGULARITIES = {"jacobian": Singularity("the smallest singular value of the Jacobian, position rows "
                                             "divided by the arm's reach", 0.01)}

    def __init__(self, chain: KinematicChain, *, base=None, tool=None, singularity_thresholds=None,
                 max_step=0.5, gripper="default", tolerance=1e-6, max_iterations=100):
        if not isinstance(chain, KinematicChain):
            raise ValueError(f"chain: expected a KinematicChain (robot_model(path) reads one from a "
                             f"description), got {type(chain).__name__}")
        self.chain = chain
        n = len(chain.joint_names)
        frames = check_array(chain.frames, name="chain.frames", ndim=3)
        if frames.shape != (n + 1, 4, 4):
            raise ValueError(f"chain.frames: expected {n + 1} frames of 4 x 4 for {n} joints, got shape "
                             f"{frames.shape}")
        # the per-instance description: what a built-in model sets as class attributes
        self.name = chain.name
        self.joint_names = tuple(chain.joint_names)
        self.lower, self.upper = tuple(map(float, chain.lower)), tuple(map(float, chain.upper))
        home = np.asarray(chain.home if len(chain.home) else np.zeros(n), float)
        self.home = tuple(np.clip(home, self.lower, self.upper))
        self.BODIES = tuple(chain.bodies)
        self.DEFAULT_GRIPPER = chain.gripper
        self.SELF_COLLISION_SKIP = frozenset(chain.self_collision_skip)
        self.link_masses = tuple(chain.masses[1:]) if len(chain.masses) == n + 1 else None
        self._origin = frames[0]
        self._F = np.linalg.inv(frames[:-1]) @ frames[1:]  # F_i, (n, 4, 4)
        # the reach: joint anchors to the flange, along the chain (scales the orientation's rows)
        self.length_ = max(float(np.linalg.norm(np.diff(frames[:, :3, 3], axis=0), axis=1).sum()), 1e-3)
        self.tolerance = check_positive(tolerance, name="tolerance")
        if isinstance(max_iterations, bool) or not isinstance(max_iterations, (int, np.integer)) \
                or max_iterations < 1:
            raise ValueError(f"max_iterations: expected a positive integer, got {max_iterations!r}")
        self.max_iterations = int(max_iterations)
        super().__init__(base=base, tool=tool, singularity_thresholds=singularity_thresholds,
                         max_step=max_step, gripper=gripper)
        if self.gripper_ is not None:  # the gripper's pairs by the links' rule, on the same samples
            self.SELF_COLLISION_SKIP = self.SELF_COLLISION_SKIP | _gripper_skip(
                self.bodies, self._frames, self.limits, self.gripper_.name)

    def __repr__(self) -> str:
        return f"ChainModel({self.name!r}, {self.n_joints} joints, tool frame {self.chain.tool_frame!r})"

    # ------------------------------------------------------------------ kinematics

    def _frames(self, q: np.ndarray) -> np.ndarray:
        out = np.empty((q.shape[0], self.n_joints + 1, 4, 4))
        out[:, 0] = self._origin
        for i in range(self.n_joints):
            out[:, i + 1] = out[:, i] @ _rz(q[:, i]) @ self._F[i]
        return out

    def _fk(self, q: np.ndarray) -> np.ndarray:
        T = np.broadcast_to(self._origin, (q.shape[0], 4, 4))
        for i in range(self.n_joints):
            T = T @ _rz(q[:, i]) @ self._F[i]
        return T

    def _jacobian(self, frames: np.ndarray) -> np.ndarray:
        """The flange's geometric Jacobian ``(n, 6, n_joints)``, base frame: linear rows, then angular."""
        z = frames[:, :-1, :3, 2]                       # joint i's axis is frame i-1's z
        o = frames[:, :-1, :3, 3]
        p = frames[:, -1, None, :3, 3]
        return np.concatenate([np.cross(z, p - o), z], axis=2).transpose(0, 2, 1)

    def jacobian(self, q) -> np.ndarray:
        """The tool's geometric Jacobian ``(n, 6, n_joints)`` in the world frame (linear rows, then angular).

        Examples
        --------
        >>> from skillbank.robots import robot_model
        >>> robot_model("panda").jacobian([0.0] * 7).shape
        (1, 6, 7)
        """
        q = self.check_joints(q)
        with numerical_errors(f"{self.name} Jacobian"):
            F = self.base @ self._frames(q)
            tool = F[:, -1] @ self.tool
            F = np.concatenate([F[:, :-1], tool[:, None]], axis=1)
            return self._jacobian(F)

    def _singularity(self, q: np.ndarray) -> dict[str, np.ndarray]:
        J = self._jacobian(self._frames(q) @ self._tool_at_end())
        J[:, :3] /= self.length_
        return {"jacobian": np.linalg.svd(J, compute_uv=False)[:, -1]}

    def _tool_at_end(self) -> np.ndarray:
        """A stack that multiplies only the last frame by the tool (the Jacobian is the tool point's)."""
        out = np.tile(np.eye(4), (self.n_joints + 1, 1, 1))
        out[-1] = self.tool
        return out

    # ------------------------------------------------------------------ numerical inverse kinematics

    def _solve(self, T: np.ndarray, q0: np.ndarray, q_ref: np.ndarray):
        """Damped least squares from ``q0`` towards flange poses ``T (m, 4, 4)``, all samples at once.

        Returns the joints ``(m, n)``, the position error (m) and the orientation error (rad) left.
        """
        q = q0.copy()
        lo, hi = np.asarray(self.lower), np.asarray(self.upper)
        span = np.where(np.isfinite(hi - lo), hi - lo, 2 * np.pi)
        zone = _LIMIT_ZONE * span
        n = self.n_joints
        L = self.length_
        tol_r = self.tolerance / L
        active = np.arange(q.shape[0])
        ep = np.full(q.shape[0], np.inf)
        er = np.full(q.shape[0], np.inf)
        tool_end = self._tool_at_end()
        target = T @ self.tool
        moving = np.ones(q.shape[0], bool)  # redundant arms: the posture still settling in the null space
        polish = max(self.max_iterations - 10, self.max_iterations // 2)  # the last ones: the pose only
        for it in range(self.max_iterations + 1):
            F = self._frames(q[active]) @ tool_end
            E = F[:, -1]
            e_p = target[active, :3, 3] - E[:, :3, 3]
            e_r = rotation_error(target[active, :3, :3], E[:, :3, :3])
            ep[active] = np.linalg.norm(e_p, axis=1)
            er[active] = np.linalg.norm(e_r, axis=1)
            keep = (ep[active] > self.tolerance) | (er[active] > tol_r) | moving
            active, F, e_p, e_r, moving = active[keep], F[keep], e_p[keep], e_r[keep], moving[keep]
            if not active.size or it == self.max_iterations:
                break
            J = self._jacobian(F)
            J[:, 3:] *= L  # rotation rows in metres at the arm's reach: one error norm for both
            e = np.concatenate([e_p, e_r * L], axis=1)
            damping = 0.5 * np.einsum("ij,ij->i", e, e) + 1e-6
            A = J @ J.transpose(0, 2, 1) + damping[:, None, None] * np.eye(6)
            X = np.linalg.solve(A, np.concatenate([e[:, :, None], J], axis=2))
            dq = np.einsum("kji,kj->ki", J, X[:, :, 0])
            settling = moving & (n > 6) & (it < polish)
            if settling.any():  # redundant: posture and limits in the null space (I - J+ J)
                qa = q[active]
                pull = _POSTURE_GAIN * (q_ref[active] - qa)
                pull += _LIMIT_GAIN * (np.clip(lo + zone - qa, 0, None) - np.clip(qa - (hi - zone), 0, None))
                N = np.eye(n) - J.transpose(0, 2, 1) @ X[:, :, 1:]
                dq += settling[:, None] * np.einsum("kij,kj->ki", N, pull)
            big = np.abs(dq).max(axis=1, keepdims=True)
            dq *= np.minimum(1.0, _MAX_ITERATION_STEP / np.maximum(big, 1e-300))
            before = q[active]
            q[active] = np.clip(before + dq, lo, hi)
            # settled when an iteration moves the joints by less than _POSTURE_SETTLED: the posture then
            # lies within about _POSTURE_SETTLED / _POSTURE_GAIN of where it tends. From then on the
            # sample takes pose-only steps: with the damping, the null-space pull leaks a little into the
            # task space and would hold the pose a few micrometres off
            moving = settling & (np.abs(q[active] - before).max(axis=1) > _POSTURE_SETTLED)
        return q, ep, er

    def _ik(self, T: np.ndarray) -> np.ndarray:
        """One solution per pose from :attr:`home` (a numerical solver's one "branch"); NaN if none."""
        seed = np.tile(np.asarray(self.home, float), (T.shape[0], 1))
        q, ep, er = self._solve(T, seed, seed)
        ok = (ep <= self.tolerance) & (er <= self.tolerance / self.length_)
        return np.where(ok[:, None], q, np.nan)[:, None, :]

    def ik(self, position, quaternion, *, branch=None, q_seed=None, q_reference=None) -> np.ndarray:
        """Joints along a pose path, continuous from the seed, within the limits.

        Samples are solved coarse to fine (module docstring): the path stays on the branch of
        ``q_seed``. On a redundant arm the null space keeps the joints near ``q_reference`` (the
        recorded joints, one row per sample) or else near ``q_seed``, and away from their limits.

        Parameters
        ----------
        position : array-like of shape (n, 3) or (3,)
        quaternion : array-like of shape (n, 4) or (4,)
            Scalar-last unit quaternions.
        branch : None, 0 or "seeded"
            A numerical solver has one branch: the seed's.
        q_seed : array-like of shape (n_joints,), optional
            Where to start (default :attr:`home`).
        q_reference : array-like of shape (n, n_joints), optional
            The joints to stay near, per sample (redundant arms).

        Returns
        -------
        ndarray of shape (n, n_joints) or (n_joints,)

        Raises
        ------
        KinematicsError
            Naming the first sample that fails and why: out of reach (by how much the solver's
            nearest pose falls short), held at a joint limit, near a singularity, or a jump of more
            than ``max_step`` between consecutive samples.
        """
        T, single = self._poses(position, quaternion)
        if branch is not None:
            self.branch_index(branch)
        seed = self._seed(q_seed)
        m = T.shape[0]
        if q_reference is None:
            ref = np.tile(seed, (m, 1))
        else:
            ref = self.check_joints(q_reference, name="q_reference")
            if ref.shape[0] != m:
                raise ValueError(f"q_reference: expected one row per pose ({m}), got {ref.shape[0]}")
        with numerical_errors(f"{self.name} inverse kinematics"):
            path, ep, er = self._path(T, seed, ref)
            self._check_path(path, ep, er)
        return path[0] if single else path

    def ik_loop(self, position, quaternion, *, q_seed=None) -> np.ndarray:
        """The same solver one pose at a time, each seeded by the one before (the benchmark's baseline)."""
        T, _ = self._poses(position, quaternion)
        q = np.asarray(self.home if q_seed is None else q_seed, float)[None].copy()
        ref = q.copy()
        out = np.empty((T.shape[0], self.n_joints))
        for k in range(T.shape[0]):
            q, _, _ = self._solve(T[k:k + 1], q, ref)
            out[k] = q[0]
        return out

    def _path(self, T: np.ndarray, seed: np.ndarray, ref: np.ndarray):
        m = T.shape[0]
        q = np.empty((m, self.n_joints))
        ep, er = np.empty(m), np.empty(m)
        stride = min(_STRIDE, max(1, m // 4))
        coarse = np.arange(0, m, stride)
        if coarse[-1] != m - 1:
            coarse = np.append(coarse, m - 1)
        previous = seed[None]
        for k in coarse:  # one after another: each seeded by the one before
            sol, ep[k:k + 1], er[k:k + 1] = self._solve(T[k:k + 1], previous, ref[k:k + 1])
            q[k] = sol[0]
            previous = sol
        done = np.zeros(m, bool)
        done[coarse] = True
        known = coarse
        while not done.all():
            # the samples midway between solved neighbours, seeded by their interpolation
            mids = ((known[:-1] + known[1:]) // 2)
            mids = mids[~done[mids]]
            left = known[np.searchsorted(known, mids) - 1]
            right = known[np.searchsorted(known, mids)]
            w = ((mids - left) / (right - left))[:, None]
            start = (1 - w) * q[left] + w * q[right]
            q[mids], ep[mids], er[mids] = self._solve(T[mids], start, ref[mids])
            done[mids] = True
            known = np.flatnonzero(done)
        return q, ep, er

    def _check_path(self, path: np.ndarray, ep: np.ndarray, er: np.ndarray) -> None:
        failures = []  # (index, priority, message, reason)
        tol_r = self.tolerance / self.length_
        missed = np.flatnonzero((ep > self.tolerance) | (er > tol_r))
        lo, hi = np.asarray(self.lower), np.asarray(self.upper)
        if missed.size:
            k = int(missed[0])
            at = np.flatnonzero((path[k] <= lo + 1e-9) | (path[k] >= hi - 1e-9))
            more = "" if missed.size == 1 else f"; {missed.size} such samples"
            short = f"{float(ep[k]):.3g} m and {np.degrees(float(er[k])):.3g} degrees"
            if at.size:
                j = int(at[0])
                message = (f"position: sample {k}: joint {self.joint_names[j]!r} is held at its limit "
                           f"[{lo[j]:.4g}, {hi[j]:.4g}] and the tool stays {short} from the pose{more}: "
                           "move the pose, or start from a seed on the limit's other side (q_seed)")
                failures.append((k, 0, message, "joint limit"))
            else:
                message = (f"position: sample {k} is out of the arm's reach by about {short} (the nearest "
                           f"pose the solver found in {self.max_iterations} iterations{more}): bring it "
                           "within reach, or give a seed nearer its joints (q_seed)")
                failures.append((k, 0, message, "unreachable"))
        if path.shape[0] > 1:
            measure = self._singularity(path)["jacobian"]
            threshold = self.singularity_thresholds["jacobian"]
            near = np.flatnonzero(measure < threshold)
            if near.size:
                k = int(near[0])
                failures.append((k, 1, f"position: sample {k} is near a singularity (the Jacobian's "
                                       f"smallest scaled singular value {float(measure[k]):.3g} < "
                                       f"{threshold:g}; {near.size} such samples): keep the path away "
                                       "from stretched or aligned joints", "singularity"))
            steps = np.abs(np.diff(path, axis=0))
            big = np.flatnonzero(steps.max(axis=1) > self.max_step)
            if big.size:
                k = int(big[0]) + 1
                j = int(np.argmax(steps[k - 1]))
                failures.append((k, 2, f"position: sample {k}: joint {self.joint_names[j]!r} would move by "
                                       f"{float(steps[k - 1, j]):.3g} rad in one sample (more than "
                                       f"max_step={self.max_step:g}; the pose path jumps, or crosses a "
                                       "singularity between samples): sample the path more finely",
                                 "jump"))
        if failures:
            k, _, message, reason = min(failures, key=lambda f: (f[0], f[1]))
            raise KinematicsError(message, index=k, reason=reason)

    def branch_of(self, q) -> np.ndarray:
        """Every configuration is on the one branch a numerical solver has (0)."""
        return np.zeros(self.check_joints(q).shape[0], dtype=int)


def _gripper_skip(bodies, frames_at, limits, gripper: str) -> frozenset:
    """:func:`self_collision_skip` over the links and the mounted gripper, remembered per arm and gripper.

    The same samples as the links' own rule; the pairs between links come out as the chain's.
    """
    key = (tuple(bodies), limits.tobytes(), gripper, frames_at(np.zeros((1, limits.shape[0]))).tobytes())
    if key not in _GRIPPER_SKIP:
        _GRIPPER_SKIP[key] = self_collision_skip(bodies, frames_at, limits)
    return _GRIPPER_SKIP[key]


_GRIPPER_SKIP: dict = {}


def self_collision_skip(bodies, frames_at, limits, *, samples=2000, random_state=0) -> frozenset:
    """Body pairs whose capsules overlap at every one of ``samples`` random configurations within the limits.

    Capsules enclose the links' meshes with some room; two links two joints apart whose envelopes
    overlap wherever the joints are (a wrist's short links) would be reported in collision on every
    path although their meshes need not touch. Measured, not guessed: pairs that overlap at *every*
    sampled configuration are never checked (docs/robots.md). ``frames_at(q)`` gives the link frames.
    """
    from ._clearance import segment_distance  # same layer module, numpy only

    bodies = tuple(bodies)
    n_frames = max((b.frame for b in bodies), default=0)
    pairs = [(a, b) for i, a in enumerate(bodies) for b in bodies[i + 1:] if abs(a.frame - b.frame) > 1]
    if not pairs or n_frames == 0:
        return frozenset()
    rng = np.random.default_rng(random_state)
    lo, hi = limits[:, 0], limits[:, 1]
    lo, hi = np.where(np.isfinite(lo), lo, -np.pi), np.where(np.isfinite(hi), hi, np.pi)
    q = rng.uniform(lo, hi, size=(samples, len(lo)))
    F = frames_at(q)

    def ends(c):
        T = F[:, c.frame]
        return (T[:, :3, :3] @ np.asarray(c.a, float) + T[:, :3, 3],
                T[:, :3, :3] @ np.asarray(c.b, float) + T[:, :3, 3])

    skip = set()
    for a, b in pairs:
        (a0, a1), (b0, b1) = ends(a), ends(b)
        if (segment_distance(a0, a1, b0, b1) < a.radius + b.radius).all():
            skip.add((a.name, b.name))
    return frozenset(skip)

