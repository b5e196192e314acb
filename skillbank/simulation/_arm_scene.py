"""A robosuite arm in a private copy of its scene's MuJoCo model: whole-arm collision checks, FK and IK.

:class:`ArmScene` copies the environment's MuJoCo model and data once: the arm's joints are set, an object
held in the hand is moved rigidly with it (as it sits in it when the copy is made), and MuJoCo's own
collision detection (``mj_collision`` on the geoms as they lie) says which of the moving geoms (every link
below the arm's first joint, the gripper, the held object) comes within :data:`MARGIN` of anything that
does not move with the hand (the arm's own fixed base and mount left out): the moving geoms' margin is
raised to it in the copy, so MuJoCo reports near misses as contacts with their distance. The robot
against itself (two of its links, a link and its base or mount, the held object and a link) is a
collision where they overlap, except the pairs that touch as it stands (fingers on what they hold). Inverse
kinematics is damped least squares on the same model, to the pose robosuite reports as
``robot0_eef_pos`` (the gripper's grip site) and ``robot0_eef_quat`` (the end-effector body). The
environment itself is never changed. :mod:`skillbank.simulation._transit` plans with it.
"""

from __future__ import annotations

import copy

import numpy as np

from ..core import matrix_to_quaternion, quaternion_to_matrix

__all__ = ["ArmScene", "MARGIN", "JOINT_STEP"]

#: Metres every moving body keeps from the scene in a planned move (the controller trails its commands
#: by a centimetre or two on a fast move; the check itself is exact at the checked states).
MARGIN = 0.01
#: Radians any joint may turn between two checked states of a motion (about 1.5 cm at the gripper's end).
JOINT_STEP = 0.02

def _rotvec(R):
    """The rotation vector of a rotation matrix."""
    c = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(c)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    s = np.linalg.norm(w)
    if s < 1e-9:
        if c > 0:
            return np.zeros(3)
        # half a turn: the axis is the column of R + I with the largest norm
        B = R + np.eye(3)
        axis = B[:, np.argmax(np.linalg.norm(B, axis=0))]
        return np.pi * axis / np.linalg.norm(axis)
    return angle * w / s


def _where(q):
    return "[" + ", ".join(f"{v:.3g}" for v in q) + "]"


class ArmScene:
    """The arm of a robosuite environment in a private copy of its MuJoCo model: collisions, FK and IK.

    Parameters
    ----------
    env : robosuite environment
        A one-arm scene; its state now (objects, fingers) is the scene the arm moves in.
    held : str, optional
        The name of a robosuite object (``env.model.mujoco_objects``) held in the hand: it moves rigidly
        with the hand, as it sits in it now, and is checked like a body of the arm.
    margin : float, default=MARGIN
        Metres the arm, gripper and held object keep from everything else.
    slack : float, default=0.0
        Metres the held object may move in the hand while it is carried (a can creeping down between the
        fingers): it keeps ``margin + slack`` from everything else, as it sits in the hand now.

    Examples
    --------
    >>> scene = ArmScene(env)  # doctest: +SKIP
    >>> scene.blocking(env.sim.data.qpos[:6]) is None  # the arm where it stands is clear  # doctest: +SKIP
    True
    """

    def __init__(self, env, *, held=None, margin=MARGIN, slack=0.0):
        import mujoco  # extra 'sim': imported when a robosuite scene is planned in

        self._mj = mujoco
        self.margin = float(margin)
        slack = float(slack)
        if not np.isfinite(slack) or slack < 0:
            raise ValueError(f"slack: expected a non-negative number of metres, got {slack!r}")
        self.model = copy.deepcopy(env.sim.model._model)
        m = self.model
        src = env.sim.data._data
        self.data = mujoco.MjData(m)
        self.data.qpos[:] = src.qpos
        self.data.mocap_pos[:], self.data.mocap_quat[:] = src.mocap_pos, src.mocap_quat
        robot = env.robots[0]
        ids = np.array([m.joint(name).id for name in robot.robot_joints])
        self.qadr, self.dadr = m.jnt_qposadr[ids], m.jnt_dofadr[ids]
        limited = m.jnt_limited[ids].astype(bool)
        self.limits = np.where(limited[:, None], m.jnt_range[ids], [-2 * np.pi, 2 * np.pi])
        gripper = robot.gripper["right"] if isinstance(robot.gripper, dict) else robot.gripper
        self.site = m.site(gripper.important_sites["grip_site"]).id
        eef = robot.robot_model.eef_name
        self.body = m.body(eef["right"] if isinstance(eef, dict) else eef).id
        moving = self._subtree(m.jnt_bodyid[ids[0]])
        self.held = None
        if held is not None:
            obj = next((o for o in env.model.mujoco_objects if o.name == held), None)
            if obj is None:
                raise ValueError(f"held: the scene has no object {held!r}")
            root = m.body(obj.root_body).id
            if m.body_jntnum[root] < 1 or m.jnt_type[m.body_jntadr[root]] != mujoco.mjtJoint.mjJNT_FREE:
                raise ValueError(f"held: object {held!r} is fixed in the scene, not held")
            mujoco.mj_kinematics(m, self.data)
            # the object as it sits in the hand now, in the hand body's frame
            Rh, ph = self.data.xmat[self.body].reshape(3, 3), self.data.xpos[self.body]
            Ro, po = self.data.xmat[root].reshape(3, 3), self.data.xpos[root]
            self.held = (m.jnt_qposadr[m.body_jntadr[root]], Rh.T @ Ro, Rh.T @ (po - ph))
            moving |= self._subtree(root)
            held_geoms = self._subtree(root)[m.geom_bodyid]
        self.moving = moving[m.geom_bodyid]
        # what each moving geom keeps from the scene: the held object also what it may move in the hand
        self.margins = np.where(self.moving, self.margin, 0.0)
        if self.held is not None:
            self.margins[held_geoms] += slack
        # the arm's own fixed base and mount are its self-collision, which its joint limits keep
        top = m.jnt_bodyid[ids[0]]
        while m.body_parentid[top] != 0:
            top = m.body_parentid[top]
        self.own = self._subtree(top)[m.geom_bodyid] & ~self.moving
        # collidable moving geoms report what comes within the margin as a contact (MuJoCo takes the
        # larger margin of a pair); the scene's own geoms keep theirs
        m.geom_margin[self.moving] = np.maximum(m.geom_margin[self.moving], self.margins[self.moving])
        # a geom without a name (robosuite's bins' walls) goes by its body's and its number
        self.names = [m.geom(i).name or f"{m.body(m.geom_bodyid[i]).name} (geom {i})" for i in range(m.ngeom)]
        self.allowed = set()
        self.checks = 0
        # the robot against itself: pairs that touch as it stands (fingers on what they hold, a pad on a
        # pad) always do; any other pair of its own geoms that overlaps is a collision
        mujoco.mj_kinematics(m, self.data)
        mujoco.mj_collision(m, self.data)
        self.touching = {(a, b) for _, a, b in self._self_overlaps()}

    def _subtree(self, root):
        m = self.model
        inside = np.zeros(m.nbody, bool)
        inside[root] = True
        for b in range(root + 1, m.nbody):  # MuJoCo numbers a body after its parent
            inside[b] = inside[m.body_parentid[b]]
        return inside

    @property
    def joints(self):
        """The arm's joints in the copy now."""
        return np.array(self.data.qpos[self.qadr], float)

    def set(self, q):
        """Put the arm at ``q`` (and the held object in the hand) and compute the kinematics."""
        mj, m, d = self._mj, self.model, self.data
        d.qpos[self.qadr] = q
        mj.mj_kinematics(m, d)
        if self.held is not None:
            adr, R, p = self.held
            Rh, ph = d.xmat[self.body].reshape(3, 3), d.xpos[self.body]
            d.qpos[adr:adr + 3] = ph + Rh @ p
            xyzw = matrix_to_quaternion(Rh @ R)
            d.qpos[adr + 3:adr + 7] = np.r_[xyzw[3], xyzw[:3]]  # MuJoCo's (w, x, y, z)
            mj.mj_kinematics(m, d)

    def near(self, q):
        """``(distance, moving geom, other geom)`` of every pair within the margin at ``q``, nearest first."""
        self.checks += 1
        self.set(q)
        mj, m, d = self._mj, self.model, self.data
        mj.mj_collision(m, d)
        n = d.ncon
        if n == 0:
            return []
        g1, g2, dist = d.contact.geom1[:n], d.contact.geom2[:n], d.contact.dist[:n]
        mv1, mv2 = self.moving[g1], self.moving[g2]
        hit = (mv1 != mv2) & (dist < np.where(mv1, self.margins[g1], self.margins[g2])) & ~self.own[g1] & \
            ~self.own[g2]
        out = [(float(dist[k]), int(g1[k]), int(g2[k])) if mv1[k] else
               (float(dist[k]), int(g2[k]), int(g1[k])) for k in np.flatnonzero(hit)]
        out = [c for c in out if (c[1], c[2]) not in self.allowed]
        out += [c for c in self._self_overlaps() if (c[1], c[2]) not in self.touching]
        return sorted(out)

    def _self_overlaps(self):
        """``(distance, geom, geom)`` of the robot's own pairs that overlap in the contacts MuJoCo found
        (a moving geom and another moving one, or the arm's base or mount), the lower geom id first."""
        d = self.data
        n = d.ncon
        g1, g2, dist = d.contact.geom1[:n], d.contact.geom2[:n], d.contact.dist[:n]
        mv1, mv2 = self.moving[g1], self.moving[g2]
        mine = (mv1 & mv2) | (mv1 & self.own[g2]) | (mv2 & self.own[g1])
        return [(float(dist[k]), int(min(g1[k], g2[k])), int(max(g1[k], g2[k])))
                for k in np.flatnonzero(mine & (dist < 0))]

    def blocking(self, q):
        """The nearest ``(distance, moving geom, other geom)`` within the margin at ``q``, or None."""
        near = self.near(q)
        return near[0] if near else None

    def allow(self, q):
        """Let the pairs within the margin at ``q`` be (a hand that starts at what it just let go of)."""
        self.allowed |= {(a, b) for _, a, b in self.near(q)}

    def describe(self, contact) -> str:
        d, a, b = contact
        depth = f"{-d * 1000:.3g} mm into" if d < 0 else f"within {d * 1000:.3g} mm of"
        # a held object keeps its slack in the hand too: say so, or 25 mm reads as clear of a 10 mm margin
        kept = self.margins[a]
        extra = f" (held: it keeps {kept * 1000:.3g} mm, the margin and its slack in the hand)" \
            if kept > self.margin else ""
        return f"{self.names[a]} comes {depth} {self.names[b]}{extra}"

    def tool(self, q):
        """The tool pose robosuite reports at ``q``: (position, quaternion (x, y, z, w))."""
        self.set(q)
        d = self.data
        return (np.array(d.site_xpos[self.site], float),
                matrix_to_quaternion(d.xmat[self.body].reshape(3, 3).copy()))

    def ik(self, position, quat, q0, *, iters=200, tol=(1e-4, 1e-3), near=(5e-3, 5e-2), damping=0.05):
        """Joints near ``q0`` that put the tool at ``position``, ``quat`` (x, y, z, w), within the limits;
        None if damped least squares does not come within ``near`` (m, rad; the controller tracks to a
        centimetre) of it (a joint held at its limit can stall it short of ``tol``)."""
        mj, m, d = self._mj, self.model, self.data
        target = quaternion_to_matrix(np.asarray(quat, float))
        q = np.array(q0, float)
        jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        for _ in range(iters):
            self.set(q)
            mj.mj_comPos(m, d)  # the Jacobians use the bodies' frames relative to their subtree's centre
            ep = np.asarray(position, float) - d.site_xpos[self.site]
            er = _rotvec(target @ d.xmat[self.body].reshape(3, 3).T)
            if np.linalg.norm(ep) < tol[0] and np.linalg.norm(er) < tol[1]:
                return q
            mj.mj_jacSite(m, d, jp, None, self.site)
            mj.mj_jacBody(m, d, None, jr, self.body)
            J = np.vstack([jp[:, self.dadr], jr[:, self.dadr]])
            e = np.r_[ep, er]
            dq = J.T @ np.linalg.solve(J @ J.T + damping ** 2 * np.eye(6), e)
            q = np.clip(q + dq, self.limits[:, 0], self.limits[:, 1])
        return q if np.linalg.norm(ep) < near[0] and np.linalg.norm(er) < near[1] else None

    def motion_clear(self, a, b):
        """Whether every state of the straight joint motion from ``a`` to ``b`` is clear (densified)."""
        return self.motion_blocking(a, b) is None

    def motion_blocking(self, a, b):
        n = max(1, int(np.ceil(np.abs(b - a).max() / JOINT_STEP)))
        for s in np.linspace(0.0, 1.0, n + 1)[1:]:
            hit = self.blocking(a + s * (b - a))
            if hit is not None:
                return hit
        return None
