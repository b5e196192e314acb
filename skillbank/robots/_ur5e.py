"""The Universal Robots UR5e: Denavit-Hartenberg forward kinematics and the analytic inverse, 8 branches.

Frames follow the manufacturer's published DH table (standard DH,
``T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``): frame 0 is UR's ``base``
frame (the one the controller and the ``base`` frame of the ROS driver
report poses in; ROS's ``base_link`` is it turned by pi about z) and frame 6
is the flange (ROS's ``tool0``).

Inverse kinematics, per pose (all poses at once, all branches by
broadcasting):

1. The wrist centre (frame 5's origin) is ``p5 = p - d6 z6``. It lies ``d4``
   off the plane of the base axis and the arm, which fixes the base angle
   up to the side: ``theta1 = atan2(p5y, p5x) +- acos(d4 / r) + pi / 2``
   with ``r`` the wrist centre's distance from the base axis (shoulder
   left / right; unreachable when ``r < d4``).
2. The shoulder axis ``z1 = (sin theta1, -cos theta1, 0)`` gives
   ``cos theta5 = z6 . z1`` (wrist up / down: the sign of ``theta5``), and
   ``z1 . x6 = sin theta5 cos theta6``, ``z1 . y6 = -sin theta5 sin theta6``
   give ``theta6``.
3. With those, ``theta2 + theta3 + theta4`` is the angle of
   ``sin theta6 x6 + cos theta6 y6`` in the arm's plane, which places
   wrist 1's centre; the planar two-link arm to it gives ``theta3`` (elbow up
   / down: its sign) and ``theta2``, and ``theta4`` is what is left.

The elbow's and the wrist's signs are taken relative to the shoulder's, so that each name keeps its
geometric meaning on both sides of the base (docs/robots.md).
"""

from __future__ import annotations

import numpy as np

from ._base import RobotModel, Singularity, wrap_angle
from ._bodies import Capsule

__all__ = ["UR5e", "UR5E_DH"]

#: The manufacturer's published UR5e DH parameters: d (m), a (m), alpha (rad), joints 1 to 6.
UR5E_DH = {
    "d": (0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996),
    "a": (0.0, -0.425, -0.3922, 0.0, 0.0, 0.0),
    "alpha": (np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0),
}

_D1, _, _, _D4, _D5, _D6 = UR5E_DH["d"]
_A2, _A3 = UR5E_DH["a"][1:3]

#: Signs of the formulas per branch. Shoulder: the sign in theta1 (left -1, right +1). The elbow's and
#: the wrist's signs are the shoulder's (up) or the other (down): sin(theta3) R < 0 is "elbow up" and
#: sin(theta5) R < 0 "wrist up" on either side, R = -sign * sqrt(r^2 - d4^2) (see docs/robots.md).
_SHOULDER = np.array([-1.0, 1.0])                      # left, right
_SAME_OPPOSITE = np.array([1.0, -1.0])                 # up: the shoulder's sign, down: the other
_BRANCHES = tuple(f"shoulder-{s}/elbow-{e}/wrist-{w}"
                  for s in ("left", "right") for e in ("up", "down") for w in ("up", "down"))


def _wrist_geometry(T: np.ndarray):
    """Steps 1 to 3 of the inverse (module docstring) up to the planar arm's target.

    Returns whether the base reaches (``r >= d4``, ``(n,)``), theta1 ``(n, 2)``, theta5, theta6 and
    theta2 + theta3 + theta4 ``(n, 2, 2)`` (shoulder x wrist), and wrist 1's centre in the arm's plane,
    ``px, py (n, 2, 2)``, from the shoulder.
    """
    x, y, z, p = T[:, :3, 0], T[:, :3, 1], T[:, :3, 2], T[:, :3, 3]
    p5 = p - _D6 * z
    # 1. base angle, (n, 2) over the shoulder branches
    r = np.hypot(p5[:, 0], p5[:, 1])
    reach_base = r >= _D4 * (1 - 1e-12)
    phi = np.arccos(np.minimum(_D4 / np.where(reach_base, r, _D4), 1.0))
    t1 = np.arctan2(p5[:, 1], p5[:, 0])[:, None] + _SHOULDER * phi[:, None] + np.pi / 2
    s1, c1 = np.sin(t1), np.cos(t1)

    def along_z1(v):  # (n, 2): v . z1 per shoulder branch
        return v[:, 0, None] * s1 - v[:, 1, None] * c1

    def along_x1(v):  # v . x1, x1 = (cos theta1, sin theta1, 0) the arm plane's horizontal
        return v[..., 0] * c1[..., None] + v[..., 1] * s1[..., None]

    # 2. wrist angles, (n, 2, 2) over shoulder x wrist
    wrist_sign = _SHOULDER[:, None] * _SAME_OPPOSITE[None, :]
    t5 = wrist_sign * np.arccos(np.clip(along_z1(z), -1.0, 1.0))[:, :, None]
    sign5 = np.sign(np.sin(t5))  # 0 exactly at the singularity: theta6 is then free and taken as 0
    t6 = np.arctan2(-sign5 * along_z1(y)[:, :, None], sign5 * along_z1(x)[:, :, None])
    # 3. theta2 + theta3 + theta4 and wrist 1's centre in the arm's plane
    u = np.sin(t6)[..., None] * x[:, None, None, :] + np.cos(t6)[..., None] * y[:, None, None, :]
    t234 = np.arctan2(-along_x1(u), u[..., 2])
    px = along_x1(np.broadcast_to(p5[:, None, None, :], u.shape)) - _D5 * np.sin(t234)
    py = p5[:, 2, None, None] - _D1 + _D5 * np.cos(t234)
    return reach_base, t1, t5, t6, t234, px, py


def _dh(theta: np.ndarray, i: int) -> np.ndarray:
    """The DH transforms ``(n, 4, 4)`` of joint ``i`` at angles ``theta (n,)``."""
    d, a, alpha = UR5E_DH["d"][i], UR5E_DH["a"][i], UR5E_DH["alpha"][i]
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    T = np.zeros(theta.shape + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 2], T[..., 0, 3] = ct, -st * ca, st * sa, a * ct
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st, ct * ca, -ct * sa, a * st
    T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = sa, ca, d
    T[..., 3, 3] = 1.0
    return T


class UR5e(RobotModel):
    """The UR5e arm: forward kinematics, 8 inverse-kinematics branches, limits and singularities.

    Joints in kinematic-chain order (``joint_names``), radians; limits
    +-2 pi, the elbow +-pi. See :class:`~skillbank.robots.RobotModel` for the
    parameters (``base``, ``tool``, ``singularity_thresholds``,
    ``max_step``) and the methods.

    A pose has up to 8 inverse-kinematics solutions, ``branch_names``
    ``shoulder-{left,right}/elbow-{up,down}/wrist-{up,down}`` (docs/robots.md
    gives their geometry). Poses are of the tool (by default the mounted 2F-85's TCP) in UR's ``base`` frame
    unless ``base`` and ``tool`` say otherwise.

    The three singularities are the factors of the Jacobian's determinant
    (``a2 a3 sin(theta3) sin(theta5) R``); each measure is compared with its
    threshold:

    - ``shoulder``: ``|R|`` (m), ``R = a2 cos theta2 + a3 cos(theta2 + theta3)
      + d5 sin(theta2 + theta3 + theta4)``, the wrist centre's distance from
      the plane through the base axis parallel to the shoulder axis;
      threshold 0.05 m;
    - ``elbow``: ``|sin theta3|``, the arm stretched or folded; threshold
      0.05 (2.9 degrees);
    - ``wrist``: ``|sin theta5|``, the wrist 1 and wrist 3 axes parallel;
      threshold 0.05.

    Examples
    --------
    >>> robot = UR5e()  # the tool is the Robotiq 2F-85's TCP, 0.163 m beyond the flange
    >>> position, quaternion = robot.fk(robot.home)
    >>> position.round(4).tolist()
    [-0.4919, -0.1333, 0.3249]
    >>> UR5e(tool="flange").fk(robot.home)[0].round(4).tolist()
    [-0.4919, -0.1333, 0.4879]
    >>> robot.branch_names[robot.branch_of(robot.home)[0]]
    'shoulder-right/elbow-up/wrist-down'
    >>> bool(np.allclose(robot.ik(position, quaternion), robot.home))
    True
    """

    name = "ur5e"
    joint_names = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                   "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
    lower = (-2 * np.pi, -2 * np.pi, -np.pi, -2 * np.pi, -2 * np.pi, -2 * np.pi)
    upper = (2 * np.pi, 2 * np.pi, np.pi, 2 * np.pi, 2 * np.pi, 2 * np.pi)
    branch_names = _BRANCHES
    #: The usual ready pose: upper arm up, forearm level, tool pointing down.
    home = (0.0, -np.pi / 2, np.pi / 2, -np.pi / 2, -np.pi / 2, 0.0)
    #: 180 degrees/s on every joint: the UR5e's technical specification (docs/robots.md).
    max_velocity = (np.pi,) * 6
    #: 180 degrees/s^2: UR publishes no joint acceleration; this is the figure its own ROS 2 description
    #: (ur_description, config/ur5e/joint_limits.yaml) gives for trajectory generation (docs/robots.md).
    max_acceleration = (np.pi,) * 6
    SINGULARITIES = {
        "shoulder": Singularity("|R|, the wrist centre's distance (m) from the base-shoulder plane", 0.05),
        "elbow": Singularity("|sin(elbow)|", 0.05),
        "wrist": Singularity("|sin(wrist_2)|", 0.05),
    }

    DEFAULT_GRIPPER = "robotiq_2f85"
    #: One capsule per link in its DH frame: the smallest-volume capsule containing the convex hull of
    #: robosuite 1.5.2's collision mesh of that link (robots/ur5e/meshes/*.stl, MIT; its bodies are our
    #: frames up to fixed rotations, its base_link turned by pi about z), rounded to the millimetre and
    #: grown by 1.5 to 2 mm for robosuite's kinematic constants (up to 1.5 mm from the DH table).
    #: tests/robots/test_bodies.py checks that every vertex lies inside at random configurations.
    BODIES = (
        Capsule("base", 0, (0.0, 0.0, 0.028), (0.0, 0.0, 0.043), 0.082),          # base.stl
        Capsule("shoulder", 1, (0.0, 0.0, 0.015), (0.0, -0.006, 0.002), 0.085),   # shoulder.stl
        Capsule("upper_arm", 2, (0.4125, 0.0, 0.129), (0.0, 0.0, 0.129), 0.092),  # upperarm.stl
        Capsule("forearm", 3, (0.393, 0.0, 0.028), (0.005, 0.0, 0.009), 0.068),   # forearm.stl
        Capsule("wrist_1", 4, (0.0, -0.021, -0.001), (0.0, 0.0, 0.001), 0.067),   # wrist1.stl
        Capsule("wrist_2", 5, (0.0, 0.002, 0.011), (0.0, 0.004, -0.007), 0.060),  # wrist2.stl
        Capsule("wrist_3", 6, (0.0, 0.001, -0.027), (0.0, -0.002, -0.029), 0.045),  # wrist3.stl
    )

    #: Pairs not checked for self-collision besides those on the same or consecutive frames, measured on
    #: 200,000 random configurations (docs/robots.md). Envelopes within a few centimetres of each other at
    #: every configuration while the links cannot meet, a joint's offset keeping them apart: the base and
    #: the upper arm (the shoulder's 138 mm offset; always within 11 mm), the forearm and wrist 2 (wrist
    #: 1's 133 mm; within 32 mm), wrist 1 and wrist 3 (within 10 mm). Pairs that never come close: wrist 1
    #: and the gripper's body (never nearer than 32 mm) and fingers (56 mm).
    SELF_COLLISION_SKIP = frozenset({
        ("base", "upper_arm"), ("forearm", "wrist_2"), ("wrist_1", "wrist_3"),
        ("wrist_1", "gripper_body"), ("wrist_1", "finger_left"), ("wrist_1", "finger_right"),
    })

    def _frames(self, q: np.ndarray) -> np.ndarray:
        out = np.empty((q.shape[0], 7, 4, 4))
        out[:, 0] = np.eye(4)
        for i in range(6):
            out[:, i + 1] = out[:, i] @ _dh(q[:, i], i)
        return out

    def _fk(self, q: np.ndarray) -> np.ndarray:
        T = _dh(q[:, 0], 0)
        for i in range(1, 6):
            T = T @ _dh(q[:, i], i)
        return T

    def _singularity(self, q: np.ndarray) -> dict[str, np.ndarray]:
        t2, t23, t234 = q[:, 1], q[:, 1] + q[:, 2], q[:, 1] + q[:, 2] + q[:, 3]
        reach = _A2 * np.cos(t2) + _A3 * np.cos(t23) + _D5 * np.sin(t234)
        return {"shoulder": np.abs(reach), "elbow": np.abs(np.sin(q[:, 2])), "wrist": np.abs(np.sin(q[:, 4]))}

    def _ik(self, T: np.ndarray) -> np.ndarray:
        n = T.shape[0]
        reach_base, t1, t5, t6, t234, px, py = _wrist_geometry(T)
        c3 = (px**2 + py**2 - _A2**2 - _A3**2) / (2 * _A2 * _A3)
        reach_arm = np.abs(c3) <= 1 + 1e-12
        # (n, 2, 2, 2) over shoulder x elbow x wrist
        elbow_sign = (_SHOULDER[:, None] * _SAME_OPPOSITE[None, :])[None, :, :, None]
        t3 = elbow_sign * np.arccos(np.clip(c3, -1.0, 1.0))[:, :, None, :]
        px, py, t234 = px[:, :, None, :], py[:, :, None, :], t234[:, :, None, :]
        t2 = np.arctan2(py, px) - np.arctan2(_A3 * np.sin(t3), _A2 + _A3 * np.cos(t3))
        t4 = t234 - t2 - t3
        shape = (n, 2, 2, 2)
        t1, t5, t6 = t1[:, :, None, None], t5[:, :, None, :], t6[:, :, None, :]
        sols = np.stack([np.broadcast_to(a, shape) for a in (t1, t2, t3, t4, t5, t6)], axis=-1)
        sols = wrap_angle(sols)
        ok = reach_base[:, None, None, None] & reach_arm[:, :, None, :]
        return np.where(ok[..., None], sols, np.nan).reshape(n, 8, 6)

    def _out_of_reach(self, T: np.ndarray) -> np.ndarray:
        """Metres wrist 1's centre would have to move to come within the upper arm and forearm's reach.

        Per pose the smallest over the shoulder and wrist branches of how far the shoulder-to-wrist-1
        distance lies outside ``[|a2| - |a3|, |a2| + |a3|]`` (the arm stretched or folded); a wrist
        centre nearer the base axis than ``d4`` adds what it lacks. A pose moved straight out along the
        stretched arm is out by exactly the distance moved.
        """
        reach_base, _, _, _, _, px, py = _wrist_geometry(T)
        distance = np.hypot(px, py)
        lo, hi = abs(abs(_A2) - abs(_A3)), abs(_A2) + abs(_A3)
        arm = np.maximum(np.maximum(distance - hi, lo - distance), 0.0).min(axis=(1, 2))
        p5 = T[:, :3, 3] - _D6 * T[:, :3, 2]
        base = np.maximum(_D4 - np.hypot(p5[:, 0], p5[:, 1]), 0.0)
        return np.where(reach_base, arm, base + arm)
