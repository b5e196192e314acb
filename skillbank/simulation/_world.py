"""The MuJoCo world of a scene: table, obstacles, buttons, movable objects and the robot with its gripper.

:func:`build_world` writes one MJCF document (docs/simulation.md describes every
element and where its numbers come from). The arm is built from the robot
model itself, so the simulated link frames are the model's
:meth:`~skillbank.robots.RobotModel.link_frames` exactly: body ``link{i}``
turns about its own z axis (joint ``i``) and carries frame ``i`` at the fixed
transform ``F_i`` (for the UR5e ``Tz(d_i) Tx(a_i) Rx(alpha_i)``, the DH
transform at a zero joint angle); body ``link{i+1}`` sits at ``F_i`` in it.
The collision geometry is the model's capsules (:attr:`RobotModel.bodies`),
each in its link frame: the same geometry the geometric checks use.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from xml.sax.saxutils import quoteattr

import numpy as np

from ..core import Box, Sphere
from ..core._rotations import matrix_to_quaternion, quaternion_to_matrix
from ._servo import joint_inertia, servo_gains

__all__ = ["World", "build_world", "LINK_MASSES", "GRIPPER_MASSES", "PRESS_FORCE", "GRIP_FORCE"]

#: Link masses (kg) of each arm's moving links, joint 1 to the flange: UR's published physical
#: parameters (ur_description, config/ur5e/physical_parameters.yaml, BSD-3-Clause).
LINK_MASSES = {"ur5e": (3.761, 8.058, 2.846, 1.37, 1.3, 0.365)}
#: Gripper masses (kg), of which each simulated finger 0.05 kg: Robotiq's 2F-85 specification (0.925 kg);
#: the Franka hand's bodies in robosuite 1.5.2's ``panda_gripper.xml`` (hand 0.3, each finger 0.1 and its
#: pad 0.01: 0.52 kg).
GRIPPER_MASSES = {"robotiq_2f85": 0.925, "panda_hand": 0.52}
_FINGER_MASS = 0.05
#: Force (N) a button takes at half its travel, where it counts as pressed (a push button's 5-10 N).
PRESS_FORCE = 7.0
#: Largest force (N) of each finger's actuator: within the 2F-85's 20-235 N grip force.
GRIP_FORCE = 100.0
_CAP_MASS = 0.02        # kg: a button's cap and plunger
_CAP_CLEARANCE = 0.004  # m: the cap stands this far above its housing when pressed all the way
_HOUSING_HEIGHT = 0.02  # m
_PAD = (0.004, 0.011, 0.0175)  # m: half thickness (across the jaw), half width, half length of a finger pad
_FRICTION = "1 0.005 0.0001"   # MuJoCo's default sliding, torsional and rolling friction


@dataclass
class World:
    """An MJCF document and what its names mean.

    Attributes
    ----------
    xml : str
        The MJCF document.
    robot : str
        The robot's name (``"ur5e"``).
    owner : dict
        Geom name -> ``(kind, name)``: kind ``"robot"`` (name: the robot body, a capsule's name or
        ``"finger_left"`` / ``"finger_right"``), ``"table"``, ``"obstacle"``, ``"button"`` or ``"object"``
        (name: the scene's name).
    joints, fingers : tuple of str
        The arm's hinge joints (the model's order) and the fingers' slide joints.
    buttons : dict
        Button name -> ``{"joint", "travel", "geoms"}``.
    objects : dict
        Object name -> ``{"body", "movable", "geoms"}``.
    frames : tuple of str
        The site at each of the model's link frames (0 the base, last the flange).
    tcp : str
        The site at the tool centre point (the flange when no gripper is mounted).
    stroke : float
        The gripper's largest opening (0 without a gripper).
    """

    xml: str
    robot: str
    owner: dict = field(default_factory=dict)
    joints: tuple = ()
    fingers: tuple = ()
    buttons: dict = field(default_factory=dict)
    objects: dict = field(default_factory=dict)
    frames: tuple = ()
    tcp: str = ""
    stroke: float = 0.0


def _f(x) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(x))


def _quat(R: np.ndarray) -> np.ndarray:
    """A rotation matrix as MuJoCo's scalar-first unit quaternion."""
    x, y, z, w = matrix_to_quaternion(R[None])[0]
    return np.array([w, x, y, z])


def _pose(T: np.ndarray) -> str:
    return f'pos="{_f(T[:3, 3])}" quat="{_f(_quat(T[:3, :3]))}"'


def _z_to(n: np.ndarray) -> np.ndarray:
    """A rotation taking the z axis to the unit vector ``n``."""
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(z, n), float(z @ n)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + K + K @ K / (1 + c)


def _capsule_volume(a, b, r) -> float:
    return np.pi * r * r * float(np.linalg.norm(np.subtract(b, a))) + 4 / 3 * np.pi * r ** 3


def _capsule_geom(name, cap, T: np.ndarray, mass: float, rgba: str) -> str:
    """A capsule (or a sphere, for equal ends) of the model, moved by ``T`` into its MuJoCo body."""
    a = T[:3, :3] @ np.asarray(cap.a, float) + T[:3, 3]
    b = T[:3, :3] @ np.asarray(cap.b, float) + T[:3, 3]
    common = f'name={quoteattr(name)} mass="{mass!r}" rgba="{rgba}"'
    if np.linalg.norm(b - a) < 1e-9:
        return f'<geom {common} type="sphere" size="{cap.radius!r}" pos="{_f(a)}"/>'
    return f'<geom {common} type="capsule" size="{cap.radius!r}" fromto="{_f(np.concatenate([a, b]))}"/>'


def _fixed_transforms(model) -> list[np.ndarray]:
    """``F_i`` per joint: the link frames at zero joint angles give ``F_i = frame_{i-1}^-1 frame_i``.

    The model's own chain ``frame_i = frame_{i-1} Rz(q_i) F_i`` (revolute joints about the previous
    frame's z axis) is checked in the tests against :meth:`link_frames` at random angles.
    """
    frames = model.link_frames(np.zeros(model.n_joints))[0]
    base_inv = np.linalg.inv(frames[0])
    local = [base_inv @ f for f in frames]
    return [np.linalg.inv(local[i - 1]) @ local[i] for i in range(1, len(local))]


def build_world(scene, model, *, press_force: float = PRESS_FORCE, grip_force: float = GRIP_FORCE,
                kp=None, kv=None, timestep: float = 0.002) -> World:
    """The MJCF world of ``scene`` with ``model`` (a :class:`~skillbank.robots.RobotModel`).

    Parameters
    ----------
    scene : skillbank.planning.Scene
    model : skillbank.robots.RobotModel
    press_force : float
        Newtons a button takes at half its travel (its spring is linear, half that at rest).
    grip_force : float
        Largest force of each finger's actuator (N).
    kp, kv : sequence of float, optional
        The joint servos' stiffness (N m / rad) and damping (N m s / rad); defaults in
        :data:`skillbank.simulation.SERVO_GAINS`.
    timestep : float

    Returns
    -------
    World

    Examples
    --------
    >>> from skillbank.planning import Scene
    >>> from skillbank.robots import robot_model
    >>> world = build_world(Scene(objects={}, obstacles={}, init=[], goal=[]), robot_model("ur5e"))
    >>> world.joints[0], world.frames[-1]
    ('shoulder_pan_joint', 'frame6')
    """
    # a model read from a description carries its links' masses; a built-in one's are listed here
    masses = model.link_masses or LINK_MASSES.get(model.name)
    if masses is None:
        raise ValueError(f"robot: the simulation knows the link masses of {list(LINK_MASSES)}, got "
                         f"{model.name!r}; add its masses to skillbank.simulation.LINK_MASSES")
    kp, kv = servo_gains(model.name, kp, kv, inertia=joint_inertia(model, masses))
    world = World(xml="", robot=model.name)
    body = []
    body += _static(scene, world)
    body += _buttons(scene, world, press_force)
    body += _objects(scene, world)
    arm, actuators, excludes = _arm(model, world, masses, grip_force, kp, kv)
    body += arm
    world.xml = "\n".join([
        '<mujoco model="skillbank">',
        '  <compiler angle="radian" autolimits="true"/>',
        f'  <option timestep="{timestep!r}" integrator="implicitfast" gravity="0 0 -9.81"/>',
        '  <visual><global offwidth="1280" offheight="960"/><quality shadowsize="2048"/></visual>',
        f'  <default><geom friction="{_FRICTION}" condim="4"/></default>',
        '  <worldbody>',
        '    <light pos="0 0 3" dir="0 0 -1" directional="true"/>',
        '    <geom name="floor_visual" type="plane" size="2 2 0.01" pos="0 0 -0.75" rgba="0.9 0.9 0.9 1" '
        'contype="0" conaffinity="0"/>',
        *("    " + line for line in body),
        '  </worldbody>',
        '  <actuator>', *("    " + line for line in actuators), '  </actuator>',
        '  <contact>', *("    " + line for line in excludes), '  </contact>',
        '</mujoco>',
    ])
    return world


def _static(scene, world: World) -> list[str]:
    out = []
    table = getattr(scene, "table", None)
    if table is not None:
        if not isinstance(table, Box) or np.size(table.lower) != 3:
            raise ValueError(f"table: expected a 3-D skillbank.core.Box, got {type(table).__name__}")
        lo, hi = np.asarray(table.lower, float), np.asarray(table.upper, float)
        out += ['<body name="table">',
                f'  <geom name="table" type="box" pos="{_f((lo + hi) / 2)}" size="{_f((hi - lo) / 2)}" '
                'rgba="0.6 0.45 0.3 1"/>', '</body>']
        world.owner["table"] = ("table", "table")
    for k, (name, obstacle) in enumerate(scene.obstacles.items()):
        geom = f"obstacle_{k}"
        if isinstance(obstacle, Sphere) and np.size(obstacle.center) == 3:
            shape = f'type="sphere" pos="{_f(obstacle.center)}" size="{float(obstacle.radius)!r}"'
        elif isinstance(obstacle, Box) and np.size(obstacle.lower) == 3:
            lo, hi = np.asarray(obstacle.lower, float), np.asarray(obstacle.upper, float)
            shape = f'type="box" pos="{_f((lo + hi) / 2)}" size="{_f((hi - lo) / 2)}"'
        else:
            raise ValueError(f"obstacles: {name!r} is a {obstacle.n_dims}-D {type(obstacle).__name__}; the "
                             "simulation takes 3-D spheres and boxes")
        out.append(f'<geom name="{geom}" {shape} rgba="0.8 0.2 0.2 0.6"/>')
        world.owner[geom] = ("obstacle", name)
    return out


def _size(obj, n: int, what: str) -> np.ndarray:
    size = None if obj.size is None else np.asarray(obj.size, float).ravel()
    if size is None or size.shape != (n,) or not np.all(np.isfinite(size)) or np.any(size <= 0):
        raise ValueError(f"objects.{obj.name}.size: expected {what} (positive metres), got "
                         f"{None if size is None else size.tolist()}")
    return size


def _position(obj) -> np.ndarray:
    p = None if obj.position is None else np.asarray(obj.position, float).ravel()
    if p is None or p.shape != (3,):
        raise ValueError(f"objects.{obj.name}.position: a {obj.shape} needs a 3-D position, got "
                         f"{None if p is None else p.tolist()}")
    return p


def _buttons(scene, world: World, press_force: float) -> list[str]:
    if not (np.isfinite(press_force) and press_force > 0):
        raise ValueError(f"press_force: expected a positive force in newtons, got {press_force!r}")
    out = []
    buttons = [o for o in scene.objects.values() if o.shape == "button"]
    for k, obj in enumerate(buttons):
        radius = _size(obj, 1, "(radius,)")[0]
        travel = obj.travel
        if travel is None or not np.isfinite(travel) or travel <= 0:
            raise ValueError(f"objects.{obj.name}.travel: expected a positive distance (m), got {travel!r}")
        p = _position(obj)
        # The button's axis: the world's z, or against the tool's z at it (the tool presses along its z).
        n = np.array([0.0, 0.0, 1.0])
        if obj.orientation is not None:
            n = -quaternion_to_matrix(np.asarray(obj.orientation, float)[None])[0][:, 2]
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = _z_to(n), p
        stiffness = press_force / travel  # linear: F/2 at rest, F at half travel, 1.5 F at the end
        damping = 2 * np.sqrt(stiffness * _CAP_MASS)   # critically damped
        cap_height = travel + _CAP_CLEARANCE
        cap, housing, joint = f"button_{k}_cap", f"button_{k}_housing", f"button_{k}_plunger"
        out += [f'<body name="button_{k}" {_pose(T)}>',
                f'  <geom name="{housing}" type="cylinder" size="{radius * 1.25!r} {_HOUSING_HEIGHT / 2!r}" '
                f'pos="0 0 {-cap_height - _HOUSING_HEIGHT / 2!r}" rgba="0.2 0.2 0.2 1"/>',
                f'  <body name="{cap}">',
                f'    <joint name="{joint}" type="slide" axis="0 0 -1" range="0 {travel!r}" '
                f'stiffness="{stiffness!r}" springref="{-travel / 2!r}" damping="{damping!r}"/>',
                f'    <geom name="{cap}" type="cylinder" size="{radius!r} {cap_height / 2!r}" '
                f'pos="0 0 {-cap_height / 2!r}" mass="{_CAP_MASS!r}" rgba="0.9 0.1 0.1 1"/>',
                '  </body>', '</body>']
        world.owner[cap] = world.owner[housing] = ("button", obj.name)
        world.buttons[obj.name] = {"joint": joint, "travel": float(travel), "geoms": (cap, housing),
                                   "cap": cap, "body": f"button_{k}"}
    return out


_SHAPES = {"box": (3, "full extents (x, y, z)"), "cylinder": (2, "(radius, height)"),
           "sphere": (1, "(radius,)")}


def _objects(scene, world: World) -> list[str]:
    out = []
    for k, obj in enumerate(o for o in scene.objects.values() if o.shape in _SHAPES):
        n, what = _SHAPES[obj.shape]
        size = _size(obj, n, what)
        p = _position(obj)
        half = {"box": lambda s: s / 2, "cylinder": lambda s: np.array([s[0], s[1] / 2]),
                "sphere": lambda s: s}[obj.shape](size)
        body, geom = f"object_{k}", f"object_{k}_geom"
        movable = obj.mass is not None
        if movable and not (np.isfinite(obj.mass) and obj.mass > 0):
            raise ValueError(f"objects.{obj.name}.mass: expected a positive mass (kg), got {obj.mass!r}")
        shape = f'name="{geom}" type="{obj.shape}" size="{_f(half)}" rgba="0.2 0.4 0.9 1"'
        if movable:
            out += [f'<body name="{body}" pos="{_f(p)}">', '  <freejoint/>',
                    f'  <geom {shape} mass="{float(obj.mass)!r}"/>', '</body>']
        else:  # no mass: a fixed body (a shelf, a fixture)
            out += [f'<body name="{body}" pos="{_f(p)}">', f'  <geom {shape}/>', '</body>']
        world.owner[geom] = ("object", obj.name)
        world.objects[obj.name] = {"body": body, "movable": movable, "geoms": (geom,)}
    for obj in scene.objects.values():
        if obj.shape is not None and obj.shape != "button" and obj.shape not in _SHAPES:
            raise ValueError(f"objects.{obj.name}.shape: expected one of ['button', *{list(_SHAPES)}] or "
                             f"none, got {obj.shape!r}")
    return out


def _arm(model, world: World, masses, grip_force: float, kp, kv):
    """The arm's bodies (nested), its actuators and its contact exclusions."""
    if not (np.isfinite(grip_force) and grip_force > 0):
        raise ValueError(f"grip_force: expected a positive force in newtons, got {grip_force!r}")
    F = _fixed_transforms(model)
    n = model.n_joints
    caps_by_frame: dict[int, list] = {}
    gripper = model.gripper_
    gripper_names = {c.name for c in gripper.capsules} if gripper is not None else set()
    for cap in model.bodies:
        if cap.name in gripper_names and "finger" in cap.name:
            continue  # the fingers are simulated as two jaws on slide joints (docs/simulation.md)
        caps_by_frame.setdefault(cap.frame, []).append(cap)
    seen: dict[str, int] = {}

    def geom_name(name):
        seen[name] = seen.get(name, 0) + 1
        return name if seen[name] == 1 else f"{name}_{seen[name]}"

    def geoms(frame, T, mass, rgba):
        caps = caps_by_frame.get(frame, [])
        volumes = [_capsule_volume(c.a, c.b, c.radius) for c in caps]
        lines = []
        for cap, v in zip(caps, volumes, strict=True):
            name = geom_name(cap.name)
            lines.append(_capsule_geom(name, cap, T, mass * v / sum(volumes), rgba))
            world.owner[name] = ("robot", cap.name)
        return lines, bool(caps)

    base = model.link_frames(np.zeros(n))[0, 0]
    lines = [f'<body name="link0" {_pose(base)}>', '  <site name="frame0" size="0.01"/>']
    world.frames = ("frame0",) + tuple(f"frame{i}" for i in range(1, n + 1))
    g, _ = geoms(0, np.eye(4), 4.0, "0.5 0.5 0.55 1")
    lines += ["  " + x for x in g]
    depth = 1
    for i in range(1, n + 1):
        pad = "  " * depth
        T = F[i - 1]
        at = np.eye(4) if i == 1 else F[i - 2]  # link i sits at F_{i-1} in link i-1
        lines.append(f'{pad}<body name="link{i}" {_pose(at)} gravcomp="1">')
        lines.append(f'{pad}  <joint name="{model.joint_names[i - 1]}" type="hinge" axis="0 0 1" '
                     f'range="{model.lower[i - 1]!r} {model.upper[i - 1]!r}"/>')
        lines.append(f'{pad}  <site name="frame{i}" {_pose(T)} size="0.01"/>')
        mass = masses[i - 1] + (GRIPPER_MASSES.get(gripper.name, 0.9) - 2 * _FINGER_MASS
                                if i == n and gripper is not None else 0.0)
        g, any_geom = geoms(i, T, mass, "0.3 0.5 0.8 1" if i < n else "0.25 0.25 0.25 1")
        lines += [pad + "  " + x for x in g]
        if not any_geom:  # a link the model gives no capsule: its mass at the frame's origin
            r = 0.05
            lines.append(f'{pad}  <inertial pos="{_f(T[:3, 3])}" mass="{mass!r}" '
                         f'diaginertia="{_f([0.4 * mass * r * r] * 3)}"/>')
        depth += 1
    pad = "  " * depth
    flange = F[n - 1]
    tool = np.eye(4) if gripper is None else gripper.tool()
    lines.append(f'{pad}<site name="tcp" {_pose(flange @ tool)} size="0.008" rgba="0 1 0 1"/>')
    world.tcp = "tcp"
    actuators = []
    for j, name in enumerate(model.joint_names):
        actuators.append(f'<position name="servo_{name}" joint="{name}" kp="{kp[j]!r}"/>')
        actuators.append(f'<velocity name="damper_{name}" joint="{name}" kv="{kv[j]!r}"/>')
    # A body welded to the world (the base, a button's housing) is not filtered from its child by MuJoCo's
    # parent rule: exclude those pairs by name.
    excludes = ['<exclude body1="link0" body2="link1"/>']
    excludes += [f'<exclude body1="{b["body"]}" body2="{b["cap"]}"/>' for b in world.buttons.values()]
    if "table" in world.owner:
        # The base stands on the table and the shoulder turns just above it (docs/simulation.md).
        excludes += ['<exclude body1="table" body2="link0"/>', '<exclude body1="table" body2="link1"/>']
    if gripper is not None:
        lines += _fingers(pad, flange, gripper, caps_by_frame, world, model, grip_force)
        # Stiff enough to reach its force limit 5 mm from the target: the jaws squeeze at grip_force.
        actuators += [f'<position name="grip_{side}" joint="finger_{side}_joint" '
                      f'kp="{grip_force / 0.005!r}" kv="{grip_force / 5!r}" '
                      f'forcerange="{-grip_force!r} {grip_force!r}" ctrlrange="0 {gripper.stroke / 2!r}"/>'
                      for side in ("left", "right")]
        excludes += ['<exclude body1="finger_left" body2="finger_right"/>',
                     f'<exclude body1="finger_left" body2="link{n - 1}"/>',
                     f'<exclude body1="finger_right" body2="link{n - 1}"/>']
        world.fingers = ("finger_left_joint", "finger_right_joint")
        world.stroke = float(gripper.stroke)
    excludes += _self_collision_excludes(model, excludes)
    for d in range(depth - 1, -1, -1):
        lines.append("  " * d + "</body>")
    world.joints = tuple(model.joint_names)
    return lines, actuators, excludes


def _self_collision_excludes(model, already) -> list[str]:
    """Exclude every pair of the robot's bodies that the geometric check never compares.

    The model's :meth:`~skillbank.robots.RobotModel.self_collision_pairs` is the one rule of which of its
    bodies may touch (those on consecutive frames, and its ``SELF_COLLISION_SKIP``, always do, by
    construction): the simulation reports a self-contact exactly where the check would.
    """
    def owner(cap):
        return cap.name if "finger" in cap.name and cap.frame == model.n_joints else f"link{cap.frame}"

    checked = {frozenset(p) for p in model.self_collision_pairs()}
    groups = {}
    for cap in model.bodies:
        groups.setdefault(owner(cap), []).append(cap.name)
    names = sorted(groups)
    out = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            line = f'<exclude body1="{a}" body2="{b}"/>'
            if line in already or f'<exclude body1="{b}" body2="{a}"/>' in already:
                continue
            if not any(frozenset((x, y)) in checked for x in groups[a] for y in groups[b]):
                out.append(line)
    return out


def _jaw_axes(gripper) -> np.ndarray:
    """The jaws' frame in the flange frame: x the gripper's ``axis`` (checked), z the flange's z."""
    axis = np.asarray(gripper.axis, float)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or abs(np.linalg.norm(axis) - 1) > 1e-6 \
            or abs(axis[2]) > 1e-6:
        raise ValueError(f"gripper {gripper.name}: axis: expected a unit vector perpendicular to the "
                         f"flange's z (the jaws slide across the approach), got "
                         f"{np.ravel(gripper.axis).tolist()}")
    return np.column_stack([axis, np.cross([0.0, 0.0, 1.0], axis), [0.0, 0.0, 1.0]])


def _fingers(pad, flange, gripper, caps_by_frame, world, model, grip_force) -> list[str]:
    """Two jaws in the flange frame that slide along the gripper's ``axis``; their pads end at the TCP.

    ``finger_left`` opens towards ``+axis``, ``finger_right`` towards ``-axis``; each pad is thin along the
    axis.
    """
    tcp = np.asarray(gripper.tcp, float)
    R = _jaw_axes(gripper)
    turn = f' quat="{_f(_quat(R))}"'
    out = []
    for side, sign in (("left", 1.0), ("right", -1.0)):
        T = flange.copy()
        centre = tcp + R @ [sign * _PAD[0], 0.0, -_PAD[2]]
        slide = _f(sign * R[:, 0])
        out += [f'{pad}<body name="finger_{side}" {_pose(T)} gravcomp="1">',
                f'{pad}  <joint name="finger_{side}_joint" type="slide" axis="{slide}" '
                f'range="0 {gripper.stroke / 2!r}" damping="5"/>',
                f'{pad}  <geom name="finger_{side}" type="box" size="{_f(_PAD)}" '
                f'pos="{_f(centre)}"{turn} mass="{_FINGER_MASS!r}" '
                'rgba="0.15 0.15 0.15 1"/>',
                f'{pad}</body>']
        world.owner[f"finger_{side}"] = ("robot", f"finger_{side}")
    return out
