"""Chained reproduction: each plan step a reuse of its skill, starting exactly where the last one ended.

Each step is :func:`skillbank.selection.reuse` of its skill's primitives
under the constraints its binding gives (goal pose from the scene, start at
the previous step's end pose, zero velocity at both ends unless the binding
says ``"velocity": "free"``, the scene's obstacles). With a robot, each
step's joints come from inverse kinematics seeded with the previous step's
last joints, so the joint path is continuous. The steps are then joined on
one time base: a step's first sample is the previous step's last, kept once.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import (
    Box,
    Constraints,
    Demonstration,
    Sphere,
    ViaPoint,
    quaternion_angle,
    quaternion_to_matrix,
    slerp,
)
from ..core._validation import check_positive, numerical_errors, summarise
from ..robots import CLEARANCE, RobotModel, clearance, clearing_move, rate_ratio, robot_model, tool_point
from ..selection import reuse, shift_near
from ..selection._execution import check_limits, peak_rates, robot_limits
from ..selection._timing import _JOINT_KEYS, _MARGIN, _plain, _scale_needed, timed_to_limits
from ._start import clear_starts
from ._transit import PLANNERS, planned_end, planned_transit

__all__ = ["PlanStep", "PlanResult", "reproduce_plan", "EMPTY_PLAN", "CLEARANCE", "arm_clearance"]

#: How far a press pushes a button in, as a fraction of its travel: to the bottom, where a real button clicks
#: (the simulator counts half as pressed; the servo and the spring leave it short of the bottom).
PRESS_DEPTH = 1.0
#: Times a step is reproduced again, keeping the tool further from what a body of the robot came near.
MAX_REPAIRS = 6
#: Times a step is reproduced again with one more via point keeping a body off what it came near.
MAX_VIA_POINTS = 12
#: Earlier repair via points nearer than this phase to a new one move with it (the contact moved a little).
_SAME_PLACE = 0.04
#: The note of a plan of no steps.
EMPTY_PLAN = "the goal already holds in the initial facts: the plan has no steps and nothing is reproduced"

#: A limit counts as met up to this ratio (round-off of a timing fitted to it exactly: a time law's).
_ROUND_OFF = 1.0 + 1e-9

_TASK_LIMITS = ("velocity", "acceleration", "angular_velocity", "angular_acceleration")


@dataclass
class PlanStep:
    """One step of a reproduced plan.

    Attributes
    ----------
    action : str
    args : tuple of str
    skill : str
        The label whose primitives carried it out.
    start, stop : int
        Its samples in the plan's trajectory, ``start:stop``; a step's first
        sample is the previous step's last (``start`` = previous ``stop - 1``).
    used : list
        Primitive ids the reuse learned from.
    goal : ndarray of shape (3,)
    goal_orientation : ndarray of shape (4,) or None
    method : str
    constraint_error, orientation_error : float
    collision : bool
    notes : list of str
    """

    action: str
    args: tuple
    skill: str
    start: int
    stop: int
    used: list
    goal: np.ndarray
    goal_orientation: np.ndarray | None
    method: str
    constraint_error: float
    orientation_error: float
    collision: bool
    notes: list = field(default_factory=list)
    #: The step's pieces in order, ``{"kind", "start", "stop"}`` in the plan's samples (a piece starts
    #: on the last one's end sample): ``"transit"``, ``"primitive"``, ``"approach"``, ``"retreat"``.
    segments: list = field(default_factory=list)
    #: With a robot: the whole robot's smallest distance over the step (``Clearance.summary``), else None.
    clearance: dict | None = None
    #: Objects besides its arguments the step may touch: those the robot rests on at the plan's start.
    touches: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-able: ``action``, ``args``, ``skill``, ``start``, ``stop``, ``used``, the step's errors,
        ``segments`` and, with a robot, ``clearance`` (``min_distance`` m, ``body``, ``other``, ``time``)."""
        return {"action": self.action, "args": list(self.args), "skill": self.skill, "start": int(self.start),
                "stop": int(self.stop), "used": [int(i) for i in self.used], "goal": self.goal.tolist(),
                "goal_orientation": None if self.goal_orientation is None else self.goal_orientation.tolist(),
                "method": self.method, "constraint_error": float(self.constraint_error),
                "orientation_error": float(self.orientation_error), "collision": bool(self.collision),
                "notes": list(self.notes), "segments": [dict(s) for s in self.segments],
                "clearance": None if self.clearance is None else dict(self.clearance),
                "touches": list(self.touches)}


@dataclass
class PlanResult:
    """A plan and its chained reproduction.

    Attributes
    ----------
    plan : list of (str, tuple)
        The planner's actions with their arguments.
    steps : list of PlanStep
    trajectory : Demonstration or None
        One time base from 0; ``position``, and where every step has them
        ``orientation``, ``gripper`` (carried across steps), other recorded
        streams; ``joints`` with a robot. None when the plan has no steps
        (the goal already holds in the initial facts: an empty plan is the
        answer, and there is nothing to reproduce).
    collision : bool
        Whether the path touches any obstacle of the scene, the table or the workspace bounds: with a
        robot, any of its bodies (links, gripper), else the tool point.
    clearance : float or None
        With a robot: the whole robot's smallest distance (m) to the obstacles, the table, the workspace
        bounds and itself over the plan (each step's limiting pair is in its ``clearance``).
    constraint_error : float
        Largest of the steps' constraint errors and the position gaps at the joins.
    join_error : dict
        Largest gap at a join: ``position`` (units), ``orientation`` (rad), ``joints`` (rad, with a robot).
    domain, problem : str
        The PDDL text solved.
    notes : list of str
    """

    plan: list
    steps: list
    trajectory: Demonstration
    collision: bool
    constraint_error: float
    join_error: dict
    domain: str = ""
    problem: str = ""
    notes: list = field(default_factory=list)
    clearance: float | None = None

    def targets(self) -> list:
        """``[(t_start, t_end, objects)]``: when each step may touch the objects it acts on (its arguments).

        From the step's first sample to the end of the next step's first piece: a step leaves its object
        (lifts off a pressed button, lets go of a placed box) at the start of the next one. The windows a
        simulation takes as its ``targets``; outside them a touch is an unintended contact.
        """
        if self.trajectory is None:
            return []
        t = self.trajectory.t
        out = []
        for k, step in enumerate(self.steps):
            end = step.stop - 1
            if k + 1 < len(self.steps):
                after = self.steps[k + 1]
                end = after.segments[0]["stop"] - 1 if after.segments else after.stop - 1
            out.append((float(t[step.start]), float(t[end]), [*step.args, *step.touches]))
        return out

    def to_dict(self) -> dict:
        """The ``skillbank plan --json`` document.

        ``{"plan": [{"action", "args"}], "steps": [{"action", "args", "skill",
        "start", "stop", "used", ...}], "t", "streams", "collision",
        "constraint_error", "join_error", "joint_names" (with joints), "notes"}``.
        """
        traj = self.trajectory
        doc = {"plan": [{"action": a, "args": list(args)} for a, args in self.plan],
               "steps": [s.to_dict() for s in self.steps], "t": [] if traj is None else traj.t.tolist(),
               "streams": {} if traj is None else {k: v.tolist() for k, v in traj.streams.items()},
               "collision": bool(self.collision),
               "clearance": None if self.clearance is None else float(self.clearance),
               "constraint_error": float(self.constraint_error),
               "join_error": {k: float(v) for k, v in self.join_error.items()}, "notes": list(self.notes)}
        if traj is not None and "joints" in traj.streams:
            doc["joint_names"] = list(traj.metadata.get("joint_names", []))
        return doc


@dataclass
class _Skill:
    label: str
    parameters: list
    binding: object
    primitives: list


def _angle(value: float) -> str:
    """An angle limit as a multiple of pi when it is one (``2π``), else in radians."""
    turns = value / np.pi
    if abs(turns - round(turns)) < 1e-12 and round(turns) != 0:
        k = abs(round(turns))
        return f"{'-' if value < 0 else ''}{'' if k == 1 else k}π"
    return f"{value:.6g}"


def _start_joints(model, joints) -> np.ndarray:
    """The scene's start joints, refused outside the robot's limits rather than shifted by 2π to fit."""
    q = model.check_joints(joints, name="start.joints")[0]
    lo, hi = model.limits.T
    bad = np.flatnonzero((q < lo) | (q > hi))
    if bad.size:
        j = int(bad[0])
        raise ValueError(f"start.joints: expected joint angles within the limits of robot {model.name}, "
                         f"got {model.joint_names[j]} = {q[j]:.6g} rad, outside [{_angle(lo[j])}, "
                         f"{_angle(hi[j])}] ({bad.size} joint(s) outside); wrap it by a multiple of 2π into "
                         "the limits if that is the configuration meant")
    return q


def _goal_object(scene, args, params, binding, where):
    """The object whose pose is the step's goal: the binding's ``goal``, else the one positioned argument."""
    names = [p for p, _ in params] + [f"argument {k + 1}" for k in range(len(params), len(args))]
    if binding.goal is not None:
        name = args[names.index(binding.goal)]
        if name not in scene.objects or scene.objects[name].position is None:
            raise ValueError(f"{where}: its binding's goal {binding.goal} is {name!r}, which has no "
                             "position in the scene")
        return name
    posed = [(p, a) for p, a in zip(names, args, strict=False)
             if a in scene.objects and scene.objects[a].position is not None]
    if not posed:
        raise ValueError(f"{where}: none of its arguments {list(args)} is an object with a position in "
                         "the scene, so the step has no goal (give the object a position, or the skill a "
                         "binding)")
    if len({a for _, a in posed}) > 1:  # no guess: the wrong button pressed and reported reached is worse
        action = where.split("(", 1)[1].split()[0]
        shown = ", ".join(f"{p} = {a}" for p, a in posed)
        raise ValueError(f"{where}: action {action} has {len(posed)} parameters that are objects with a "
                         f"position ({shown}) and its binding names no goal; give one, e.g. skillbank "
                         f"library describe DB {action} --action FILE.pddl --binding "
                         f"'{{\"goal\": \"{posed[0][0]}\"}}'")
    return posed[0][1]


def _press_depth(obj, goal_q) -> np.ndarray:
    """How far past a button's top face its press goes: :data:`PRESS_DEPTH` of its travel, along the tool.

    A button's position is its top face; a press that stops there moves nothing. The tool pushes along
    its z axis (its orientation at the button), straight down without one. Zero for anything else.
    """
    if getattr(obj, "shape", None) != "button" or not getattr(obj, "travel", None):
        return np.zeros(3)
    axis = np.array([0.0, 0.0, -1.0]) if goal_q is None else quaternion_to_matrix(
        np.asarray(goal_q, dtype=float)[None])[0][:, 2]
    return PRESS_DEPTH * float(obj.travel) * axis


def _obstacles(scene, binding, where) -> list:
    if binding.obstacles == "all":
        return list(scene.obstacles)
    unknown = [n for n in binding.obstacles if n not in scene.obstacles]
    if unknown:
        raise ValueError(f"{where}: its binding names obstacle {unknown[0]!r}, which the scene does not have "
                         f"(obstacles {list(scene.obstacles)})")
    return list(binding.obstacles)


def _world(scene, names) -> list:
    """``[(label, Obstacle)]`` the step's tool point stays out of: its obstacles, the table, the workspace."""
    world = getattr(scene, "world", None)
    if world is None:  # a scene built by hand without the world's fields
        return [(f"obstacle {n} ({scene.specs[n]})", scene.obstacles[n]) for n in names]
    return world(names)


def _inside(world, point, what, where) -> None:
    for label, ob in world:
        if ob.signed_distance(np.asarray(point, dtype=float)[None])[0] < 0.0:
            raise ValueError(f"{where}: cannot avoid {label}: its {what} {np.round(point, 6).tolist()} is "
                             "inside it")


def _hits(world, Y) -> list:
    return [label for label, ob in world if ob.collides(Y)]


def _reuse(skill, constraints, world, where, limits, random_state):
    b = skill.binding
    prims = skill.primitives
    kwargs = dict(method=b.method, k=b.k, ids=[p.id for p in prims], random_state=random_state,
                  duration=b.duration, limits=limits)
    try:
        res = reuse([p.demo for p in prims], constraints, **kwargs)
    except ValueError as exc:
        message = " ".join(str(exc).split())
        if message.startswith("no usable candidate") and constraints.obstacles:
            try:  # the same step with no obstacle: if it works, the obstacles are what stops it
                free = reuse([p.demo for p in prims], constraints.replace(obstacles=()), **kwargs)
                blocking = _hits(world, free.trajectory["position"])
            except ValueError:
                blocking = []
            if blocking:
                raise ValueError(f"{where}: cannot avoid {', '.join(blocking)}: skill {skill.label!r} has no "
                                 f"primitive that can be edited around it ({message})") from None
        raise ValueError(f"{where}: skill {skill.label!r} has no usable primitive: "
                         f"{message.removeprefix('no usable candidate: ')}") from None
    if res.collision:
        blocking = _hits(world, res.trajectory["position"]) or [label for label, _ in world]
        raise ValueError(f"{where}: cannot avoid {', '.join(blocking)}: the {b.method} reproduction of skill "
                         f"{skill.label!r} passes through it")
    return res


# -- the pieces of a step: transit, the primitive, approach, retreat --------------------------------------

#: Peak speed (m/s) of the straight pieces: approach and retreat come onto a goal and leave it gently;
#: a transit moves faster. Each piece also meets the task's velocity and acceleration limits.
APPROACH_SPEED = 0.05
TRANSIT_SPEED = 0.25
#: Shortest duration (s) of a straight piece, and its sample spacing (s).
MIN_PIECE_DURATION = 0.5
PIECE_DT = 0.01
#: A recorded gripper toggles when it moves by more than this fraction of its largest magnitude
#: (the three-button recording's closing goes 45 -> 89; sensor noise stays far below 5 %).
TOGGLE = 0.05


def _duration(length, speed, limits) -> float:
    """Seconds of a minimum-jerk move of ``length``: its peak speed is ``1.875 L / T``, its peak
    acceleration ``5.774 L / T^2``."""
    T = max(MIN_PIECE_DURATION, 1.875 * length / speed)
    if "velocity" in limits:
        T = max(T, 1.875 * length / limits["velocity"])
    if "acceleration" in limits:
        T = max(T, float(np.sqrt(10.0 / np.sqrt(3.0) * length / limits["acceleration"])))
    return T


def _line(a, b, q_a, q_b, speed, limits) -> dict:
    """A straight minimum-jerk move from ``a`` to ``b`` (at rest at both ends); orientation slerped (held
    when ``q_a`` is ``q_b``), None when the step has no orientation."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    T = _duration(float(np.linalg.norm(b - a)), speed, limits)
    n = max(11, int(np.ceil(T / PIECE_DT)) + 1)
    tau = np.linspace(0.0, 1.0, n)
    s = tau ** 3 * (10.0 - 15.0 * tau + 6.0 * tau ** 2)
    piece = {"t": tau * T, "position": a + s[:, None] * (b - a)}
    piece["position"][-1] = b  # exactly, not to round-off: the next piece starts here
    if q_a is not None:
        same = q_b is None or float(quaternion_angle(q_a, q_b)) < 1e-12
        piece["orientation"] = np.tile(q_a, (n, 1)) if same else slerp([0.0, 1.0], np.stack([q_a, q_b]), s)
    return piece


def _offset_point(goal, goal_q, value, key, where):
    """The approach or retreat point: ``goal - d * z_tool`` for a distance, ``goal + offset`` for one."""
    if value is None:
        return None
    if isinstance(value, np.ndarray):
        return goal + value
    if goal_q is None:
        raise ValueError(f"{where}: its binding's {key} is a distance along the tool axis, which needs the "
                         "goal's orientation (the object's, or the binding's 'orientation'); give an offset "
                         "[dx, dy, dz] instead")
    return goal - value * quaternion_to_matrix(goal_q)[:, 2]


def _transit_height(scene, binding):
    if binding.transit == "none":
        return None
    return binding.transit if binding.transit is not None else getattr(scene, "transit", None)


def _transit(a, b, q_a, q_b, height, limits) -> list:
    """Up from ``a`` to ``height``, across, and down to ``b``: three pieces, each from rest to rest."""
    up, over = np.array([a[0], a[1], height]), np.array([b[0], b[1], height])
    q_mid = q_b if q_b is not None else q_a
    return [("transit", _line(a, up, q_a, q_a, TRANSIT_SPEED, limits)),
            ("transit", _line(up, over, q_a, q_mid, TRANSIT_SPEED, limits)),
            ("transit", _line(over, b, q_mid, q_mid, TRANSIT_SPEED, limits))]


def _held(row, n) -> np.ndarray:
    return np.repeat(np.asarray(row)[None], n, axis=0)


def _assemble(pieces, traj) -> tuple:
    """The step's streams from its pieces ``[(kind, piece)]`` on one time base, each join sample kept once,
    and its segments ``[(kind, start, stop)]`` (local samples; a piece starts on the last one's end).

    The primitive's own streams fill its piece; around it, recorded streams other than the pose are held
    at the primitive's first (transit) or last (approach, retreat) sample.
    """
    names = [k for k in traj.stream_names if k not in ("joints", "gripper")]
    streams = {k: [] for k in ["t", *names]}
    segments, offset, count = [], 0.0, 0
    for j, (kind, piece) in enumerate(pieces):
        if kind == "primitive":
            piece = {"t": traj.t - traj.t[0], **{k: traj[k] for k in names}}
        n = len(piece["t"])
        for k in names:
            if k not in piece:
                piece[k] = _held(traj[k][0 if kind == "transit" else -1], n)
        skip = 0 if j == 0 else 1
        streams["t"].append(piece["t"][skip:] + offset)
        for k in names:
            streams[k].append(piece[k][skip:])
        offset += float(piece["t"][-1])
        start = 0 if j == 0 else count - 1
        count = start + n
        segments.append((kind, start, count))
    return {k: np.concatenate(v) for k, v in streams.items()}, segments


def _recorded_gripper(traj, segments):
    """The primitive's recorded gripper laid on the step: held before and after its piece; with no primitive
    piece (a transit carried the move), its first value until the goal and its last from there on."""
    if "gripper" not in traj.streams:
        return None
    rec = traj["gripper"][:, 0]
    n = segments[-1][2]
    prim = [(a, b) for kind, a, b in segments if kind == "primitive"]
    if prim:
        a, b = prim[0]
        return np.concatenate([np.full(a, rec[0]), rec, np.full(n - b, rec[-1])])
    goal = max([b for kind, _, b in segments if kind == "transit"], default=1) - 1
    return np.concatenate([np.full(goal, rec[0]), np.full(n - goal, rec[-1])])


def _gripper(recorded, binding, carried, n):
    """The step's gripper stream (or None) and a note: the carried value is held until the step's own
    recorded toggle (the recorded profile from there on); the binding's ``start``/``end`` override."""
    if binding.gripper_start is None and binding.gripper_end is None:
        if recorded is None:
            return (None if carried is None else np.full(n, carried)), None
        if carried is None:
            return recorded.copy(), None
        scale = max(float(np.abs(recorded).max()), abs(carried), 1e-300)
        moved = np.flatnonzero(np.abs(recorded - recorded[0]) > TOGGLE * scale)
        G = np.full(n, float(carried))
        if moved.size:
            G[moved[0]:] = recorded[moved[0]:]
            return G, None
        note = None
        if recorded[0] != carried:
            note = (f"gripper held at the carried {carried:g}: the skill's recorded {recorded[0]:g} does not "
                    "toggle in this step")
        return G, note
    first = next(v for v in (binding.gripper_start, carried, None if recorded is None else recorded[0],
                             binding.gripper_end) if v is not None)
    G = np.full(n, float(first))
    if binding.gripper_end is not None:
        G[-1] = binding.gripper_end
    return G, None


def check_step(world, streams, segments, where, model=None, *, scene=None, names=(), margin=CLEARANCE,
               first=False, objects=()):
    """Refuse a step whose path touches the world; with a robot, the whole robot's clearance summary.

    The tool path of every piece is checked against ``world`` (the step's obstacles, the table, the
    workspace), naming the piece, what it touches and the time. With ``model``, every sample of
    ``streams["joints"]`` is checked for every body of the robot (links and gripper,
    :func:`skillbank.robots.clearance`) against the obstacles ``names`` of ``scene``, the solid
    ``objects`` (the scene's objects the step does not act on), its table, its workspace and the robot
    itself, with ``margin`` metres to spare; a step that comes closer is
    refused naming the body, what it comes near and the time. The one place a step's path is checked.
    """
    P, t = streams["position"], streams["t"]
    for kind, a, b in segments:
        for label, ob in world:
            i = ob.first_contact(P[a:b])
            if i >= 0:
                raise ValueError(f"{where}: its {kind} passes through {label} at t = {t[a + i]:.4g} s (tool "
                                 f"point {np.round(P[a + i], 4).tolist()})")
    if model is None or scene is None:
        return None
    res = arm_clearance(model, scene, names, streams["joints"], t, objects=objects)
    hit = res.first_contact(margin)
    if hit is not None:
        i, body, other = hit
        d = float(res.distance[i])
        what = _other_label(scene, other)
        if first and i == 0 and d < 0:
            raise ValueError(f"{where}: the robot starts inside {what}: its {body} is {-d * 1000:.3g} mm "
                             "deep at the start; start it clear of the scene")
        depth = f"{-d * 1000:.3g} mm into" if d < 0 else f"within {d * 1000:.3g} mm of"
        # what a repair must add to the obstacle for the tool path: up to the tool point, then what the
        # body lacks (and half the margin again, so the next attempt is not on the edge)
        shape = scene.table if other == "table" else scene.obstacles.get(other)
        reach = 0.0 if shape is None else max(float(shape.signed_distance(P[i][None])[0]), 0.0)
        raise _ArmContact(f"{where}: the robot's {body} comes {depth} {what} at t = {t[i]:.4g} s (clearance "
                          f"margin {margin * 1000:g} mm; --clearance sets it)", other=other,
                          lack=reach + margin - d + 0.5 * margin, body=body, segments=segments, index=i,
                          q=streams["joints"][i], point=P[i], body_lack=3 * margin - d)
    return res.summary()


class _ArmContact(ValueError):
    """A body of the robot too near ``other`` at the step's sample ``index``.

    ``lack``: metres the tool path must keep further from ``other`` to clear it, with some to spare;
    ``q``, ``point``: the joints and the tool point there; ``body_lack``: metres the body itself lacks
    for a via-point repair, and twice the margin again (the first-order move falls short where the arm
    bends, and the contact's neighbours move less than the via point does). Via points at the start,
    the deepest sample and the end of the run of too-near samples were tried too: on the wall-and-post
    benchmark they repaired fewer plans (2 of 8 against 3).
    """

    def __init__(self, message, *, other, lack, body=None, segments=(), index=None, q=None, point=None,
                 body_lack=None):
        super().__init__(message)
        self.other, self.lack, self.body, self.segments = other, lack, body, segments
        self.index, self.q, self.point, self.body_lack = index, q, point, body_lack

    def primitive_phase(self):
        """Where the contact is in the step's primitive piece (a phase strictly inside), or None."""
        for kind, a, b in self.segments:
            if kind == "primitive" and a < self.index < b - 1:
                return (self.index - a) / (b - 1 - a)
        return None


def _plannable(exc, planner, model, position, where) -> bool:
    """Whether a step's failure is one the motion planner may solve: the robot or its tool path not
    clear of the world, with a robot and a known start (not a start or a goal inside an obstacle)."""
    if planner != "ompl" or model is None or position is None:
        return False
    message = str(exc)
    if message.startswith("start:") or "starts inside" in message or (
            message.startswith(f"{where}: cannot avoid") and message.endswith("is inside it")):
        return False
    return isinstance(exc, _ArmContact) or any(k in message for k in (
        "cannot avoid", "cannot keep the robot clear", "passes through", "comes within", "mm into",
        "did not clear"))


def _planned_step(failure, *, model, scene, skill, where, position, orientation, joints, goal, goal_q,
                  gripper, steps, args, margin, task_limits, limits, random_state, time_limit):
    """The step with its move planned by the motion planner (:mod:`._transit`), checked as every step is.

    Returns ``(res, streams, segments, G, arm, resting, notes, law)`` as the step's own reproduction gives
    them (``law``: how the step was timed, :func:`_timed_step`);
    raises ``failure`` with the planner's reason appended when the planner finds no clear move either.
    """
    b = skill.binding
    names = _obstacles(scene, b, where)
    with_q = all("orientation" in p.demo.streams for p in skill.primitives)
    step_q = goal_q if with_q else None
    near = _offset_point(goal, step_q, b.approach, "approach", where)
    away = _offset_point(goal, step_q, b.retreat, "retreat", where)
    zero = np.zeros(3)
    free = Constraints(start=position, goal=goal if near is None else near, start_velocity=zero,
                       end_velocity=zero, start_orientation=orientation if with_q else None,
                       goal_orientation=step_q)
    try:
        # the primitive without the obstacles: the step's orientation at its ends, gripper and other streams
        res = _reuse(skill, free, [], where, task_limits, random_state)
    except ValueError:
        raise failure from None
    traj = res.trajectory
    if "orientation" not in traj.streams:
        raise failure
    q_a = orientation if orientation is not None else traj["orientation"][0]
    q_b = traj["orientation"][-1]

    def label(other):
        return _other_label(scene, other)

    try:
        starts = [joints]
        if joints is None:  # the first step from a pose: the clear starts, nearest the recorded joints first
            best = next(p for p in skill.primitives if p.id == res.used[0]).demo
            seed = best["joints"][0] if "joints" in best.streams and \
                best["joints"].shape[1] == model.n_joints else None
            starts = clear_starts(model, scene, position, q_a, reference=seed, names=names, margin=margin,
                                  label=label)
        # the objects the robot rests on at its start may be left (as in the step's own reproduction)
        resting = set(steps[-1].args) if steps else set().union(
            *(_resting(model, scene, q[None], margin) for q in starts))
        others = [n for n in scene.objects if n not in set(args) | resting]
        end = planned_end(goal, q_b, near)
        piece, motion = planned_transit(
            model, scene, where=where, starts=starts, end=end, end_q=q_b, names=names, objects=others,
            margin=margin, duration=lambda length: _duration(length, TRANSIT_SPEED, task_limits),
            limits=limits, random_state=random_state, time_limit=time_limit, label=label,
            first=joints is None)
        J = piece.pop("joints")
        pieces = [("transit", piece)]
        if np.linalg.norm(end - goal) > 0.0:  # the binding's approach, or the planned one
            pieces.append(("approach", _line(end, goal, q_b, q_b, APPROACH_SPEED, task_limits)))
        if away is not None:
            pieces.append(("retreat", _line(goal, away, q_b, q_b, APPROACH_SPEED, task_limits)))
        streams, segments = _assemble(pieces, traj)
        t = streams.pop("t")
        k = len(J)
        rest = {"position": streams["position"][k - 1:], "orientation": streams["orientation"][k - 1:]}
        if len(rest["position"]) > 1:  # the straight lines by inverse kinematics from the planned end
            J = np.concatenate([J, _joints(model, rest, J[-1], where)[1:]])
        streams["joints"] = J
        notes = [f"{where}: the motion planner (OMPL {motion.planner}) carried the move in "
                 f"{motion.planning_time:.3g} s ({len(motion.joints)} waypoints, the whole robot "
                 f"{motion.clearance.min_distance * 1000:.3g} mm clear): the skill's own move was refused "
                 f"({' '.join(str(failure).split())})"]
        t, note, law = _timed_step(streams, t, limits, model, where)
        if note:
            notes.append(note)
        law = "toppra" if law == "as given" else law  # the transit itself is timed by the time law
        G, note = _gripper(_recorded_gripper(traj, segments), b, gripper, len(t))
        if G is not None:
            streams["gripper"] = G[:, None]
        if note:
            notes.append(f"{where}: {note}")
        streams["t"] = t
        arm = check_step(_world(scene, names), streams, segments, where, model, scene=scene, names=names,
                         margin=margin, first=not steps, objects=others)
    except ValueError as exc:
        why = " ".join(str(exc).split()).removeprefix(f"{where}: ")
        raise ValueError(f"{failure}; the motion planner found no clear move either ({why})") from None
    return res, streams, segments, G, arm, resting, notes, law


def _shape(scene, other):
    """The solid shape of ``other`` (an obstacle, the table or an object of the scene), or None (itself)."""
    if other == "table":
        return scene.table
    if other in scene.obstacles:
        return scene.obstacles[other]
    return scene.solid(other) if other in scene.objects else None


def _grown(world, scene, grow) -> list:
    """``world`` with the obstacles (and the table) named in ``grow`` grown by that many metres."""
    if not grow:
        return world
    out = []
    for label, ob in world:
        name = "table" if ob is scene.table else next(
            (n for n in scene.obstacles if scene.obstacles[n] is ob), None)
        g = grow.get(name, 0.0)
        if g > 0.0 and isinstance(ob, Box):
            ob = Box(ob.lower - g, ob.upper + g)
        elif g > 0.0 and isinstance(ob, Sphere):
            ob = Sphere(ob.center, ob.radius + g)
        out.append((label, ob))
    return out


def arm_clearance(model, scene, names, joints, t=None, *, objects=None):
    """The whole robot's :class:`~skillbank.robots.Clearance` along ``joints`` in ``scene``'s world.

    ``names``: the obstacles that apply; ``objects``: the scene's objects with a shape that the robot
    must not touch either (those its step acts on left out), as their solid shapes (:meth:`Scene.solid`).
    """
    obstacles = {n: scene.obstacles[n] for n in names}
    for n in objects or ():
        shape = scene.solid(n)
        if shape is not None:
            obstacles[n] = shape
    return clearance(model, joints, obstacles, table=scene.table, workspace=scene.workspace, t=t)


def _resting(model, scene, q0, margin) -> set:
    """The scene's solid objects the robot touches (within ``margin``) at its start ``q0`` ``(1, n)``."""
    out = set()
    for n in scene.objects:
        shape = scene.solid(n)
        if shape is not None and clearance(model, q0, {n: shape}, self_collision=False).min_distance < margin:
            out.add(n)
    return out


def _other_label(scene, other: str) -> str:
    if other in scene.obstacles:
        return f"obstacle {other} ({scene.specs.get(other, scene.obstacles[other].spec())})"
    if other in scene.objects:
        return f"object {other} (a {scene.objects[other].shape} the step does not act on)"
    if other == "table":
        return f"the table (top at z = {float(scene.table.upper[2]):.6g} m)"
    if other == "workspace":
        return "the workspace's bounds"
    return f"its own {other} (self-collision)"


def _joints(model, streams, seed, where, branch=None) -> np.ndarray:
    if "orientation" not in streams:
        raise ValueError(f"{where}: robot {model.name} needs an orientation, and the skill's primitives "
                         "have none")
    try:
        return model.ik(streams["position"], streams["orientation"], q_seed=seed, branch=branch)
    except ValueError as exc:
        raise ValueError(f"{where}: robot {model.name}: {' '.join(str(exc).split())}") from None


def _first_joints(model, scene, streams, reference, where, names, margin, args) -> np.ndarray:
    """The first step's joints from a start given as a pose.

    The start configurations clear of the robot and the scene (:func:`clear_starts`, nearest
    ``reference`` first) are tried in turn: the first whose branch the step's whole path follows and
    keeps clear (as :func:`check_step` would check it) is taken; else the first the path follows (the
    step's repairs then work on it); else the first one's error.
    """
    if "orientation" not in streams:
        return _joints(model, streams, reference, where)  # refused there, naming the missing orientation
    starts = clear_starts(model, scene, streams["position"][0], streams["orientation"][0],
                          reference=reference, names=names, margin=margin,
                          label=lambda other: _other_label(scene, other))
    followed, first = None, None
    for q0 in starts:
        try:
            J = _joints(model, streams, q0, where)
        except ValueError as exc:
            first = exc if first is None else first
            continue
        if len(starts) == 1:
            return J
        acted = set(args) | _resting(model, scene, J[:1], margin)
        others = [n for n in scene.objects if n not in acted]
        if not arm_clearance(model, scene, names, J, objects=others).collides(margin):
            return J
        followed = J if followed is None else followed
    if followed is not None:
        return followed
    raise first


def _timed_step(streams, t, limits, model, where, ends="rest"):
    """The step's time base, re-timed where it breaks the plan's limits, as reuse re-times a reproduction.

    Kept when it meets every limit; else the one choice :func:`timed_to_limits` makes for
    ``make_executable`` too: the step's joint path timed by the time law (TOPP-RA, the samples kept, never
    faster than the step's own time base), any task-space limit it then breaks met by a uniform stretch
    of that timing, or the uniform stretch where that is shorter. The joint limits are measured as every
    export carries them (:func:`skillbank.robots.rate_ratio`: a bag's ``numpy.gradient`` rates too).

    ``ends``: ``"rest"`` for a step that starts and ends at rest (zero velocity at its ends), so that
    the law's steps join at rest too; ``"given"`` (``"velocity": "free"``) at the speed of its time base.

    Returns ``(t, note, law)``: the note (None when kept) and ``"as given"``, ``"toppra"`` or ``"uniform"``.
    """
    if len(t) < 2 or not limits:
        return t, None, "as given"
    demo = Demonstration(t, {k: streams[k] for k in ("position", "orientation", "joints") if k in streams})
    with numerical_errors(f"{where} (timing)"):
        scale, key = _scale_needed(demo, limits)
        for k in _JOINT_KEYS:
            if k in limits and "joints" in streams:
                need = rate_ratio(t, streams["joints"], **{k.removeprefix("joint_"): limits[k]}) * _MARGIN
                if need > scale:
                    scale, key = need, k
    # a planned transit is timed to its limits exactly: met, to round-off
    if scale <= _ROUND_OFF:
        return t, None, "as given"
    timed, _, law, note = timed_to_limits(demo, limits, scale, key, model, "toppra", ends=ends)
    return timed.t, f"{where}: {note}", law


def reproduce_plan(scene, plan, skills, *, robot=None, limits=None, random_state=None, progress=None,
                   clearance_margin=None, planner="ompl", motion_time_limit=None):
    """Reproduce every step of ``plan`` in ``scene`` and join them (see the module docstring).

    Parameters
    ----------
    scene : Scene
    plan : list of (str, tuple)
    skills : callable
        ``skills(action, where) -> _Skill`` (label, parameters, binding, primitives), raising
        a ValueError naming ``where`` when the action has no skill.
    robot : str or RobotModel, optional
    limits : dict, optional
        Keys of :data:`skillbank.selection.LIMITS`.
    random_state : int, optional
    progress : callable, optional
        ``progress(done, total)`` after each step.
    clearance_margin : float, optional
        With a robot: metres every body keeps from the obstacles, the table, the workspace bounds and
        itself (default :data:`CLEARANCE`); a step that comes closer is refused.
    planner : {"ompl", "none"}, default="ompl"
        With a robot: a step whose skill (and hand-written transit) cannot keep the robot clear has its
        move planned in joint space by OMPL (:mod:`skillbank.planning._transit`); ``"none"`` refuses it.
    motion_time_limit : float, optional
        Seconds the motion planner may search per transit (default
        :data:`skillbank.robots.MOTION_TIME_LIMIT`).

    Returns
    -------
    PlanResult
    """
    clearance_margin = CLEARANCE if clearance_margin is None else check_positive(
        clearance_margin, name="clearance", allow_zero=True)
    limits = check_limits(limits)
    if planner not in PLANNERS:
        raise ValueError(f"planner: expected one of {list(PLANNERS)}, got {planner!r}")
    task_limits = {k: v for k, v in limits.items() if k in _TASK_LIMITS}
    model = None if robot is None else robot if isinstance(robot, RobotModel) else robot_model(robot)
    if model is None and any(k.startswith("joint_") for k in limits):
        raise ValueError("limits: joint limits need joints: give a robot too")
    start = scene.start or {}
    position, orientation = start.get("position"), start.get("orientation")
    joints, gripper = start.get("joints"), start.get("gripper")
    if joints is not None:
        if model is None:
            raise ValueError("start.joints: a start given as joints needs a robot (robot='ur5e', "
                             "--robot ur5e)")
        joints = _start_joints(model, joints)
        position, orientation = model.fk(joints)
    if not plan:  # the goal holds already: the empty plan is the answer, with nothing to reproduce
        return PlanResult(plan=[], steps=[], trajectory=None, collision=False, constraint_error=0.0,
                          join_error={}, notes=[EMPTY_PLAN])
    pieces_all, steps, notes, laws = [], [], [], []
    branch = getattr(scene, "branch", None)
    if model is not None:
        limits, more = robot_limits(model, limits)  # the robot's own joint limits always apply
        notes += more
        if branch is not None:
            model.branch_index(branch)  # an unknown name fails before the first step, listing the names
    elif branch is not None:
        raise ValueError(f"branch: the scene's branch {branch!r} needs a robot (robot='ur5e', --robot ur5e)")
    errors = {"position": 0.0, "orientation": 0.0}
    if model is not None:
        errors["joints"] = 0.0
    for i, (action, args) in enumerate(plan, 1):
        where = f"step {i} ({' '.join([action, *args])})"
        skill = skills(action, where)
        b = skill.binding
        target = _goal_object(scene, args, skill.parameters, b, where)
        obj = scene.objects[target]
        goal = obj.position + (0.0 if b.offset is None else b.offset)
        goal_q = {"object": obj.orientation, "none": None}.get(b.orientation, b.orientation) \
            if isinstance(b.orientation, str) else b.orientation
        if b.offset is None:
            goal = goal + _press_depth(obj, goal_q)
        # two repairs of a body that comes too near: first the tool path keeps further from the obstacle
        # (right for the gripper and the wrist, near the tool); if that fails, via points in the primitive
        # move the body itself away (right for the forearm and the upper arm, and for objects, which are
        # never grown)
        strategies = ("grow", "via") if model is not None else ("grow",)
        grow, repaired, via, failed, failing = {}, [], [], None, None
        tries = {"grow": MAX_REPAIRS, "via": MAX_VIA_POINTS}
        try:
            for strategy, attempt in [(s, k) for s in strategies for k in range(tries[s] + 1)]:
                if failed is not None and strategy == "grow":
                    continue  # the growth failed: on to the via points
                if failed is not None and attempt == 0:
                    # the growths that worked stay; what growing could not clear gets via points instead
                    grow = {n: g for n, g in grow.items() if n != failing}
                    repaired, via = list(grow), []
                try:
                    world = _grown(_world(scene, _obstacles(scene, b, where)), scene, grow)
                    with_q = all("orientation" in p.demo.streams for p in skill.primitives)
                    step_q = goal_q if with_q else None
                    near = _offset_point(goal, step_q, b.approach, "approach", where)
                    away = _offset_point(goal, step_q, b.retreat, "retreat", where)
                    _inside(world, goal, f"goal (the pose of {target})", where)
                    for point, what in ((near, "approach point"), (away, "retreat point"),
                                        (position, "start")):
                        if point is not None:
                            _inside(world, point, what, where)
                    height = _transit_height(scene, b)
                    extra = near is not None or away is not None or height is not None
                    zero = np.zeros(3) if b.velocity == "zero" or extra else None  # pieces join at rest
                    constraints = Constraints(start=position, goal=goal if near is None else near,
                                              via=[v for v, _ in via], start_velocity=zero, end_velocity=zero,
                                              obstacles=[ob for _, ob in world],
                                              start_orientation=orientation if with_q else None,
                                              goal_orientation=step_q)
                    step_notes = []
                    try:
                        res = _reuse(skill, constraints, world, where, task_limits, random_state)
                        failure = None
                    except ValueError as exc:
                        if height is None or position is None:
                            raise
                        res, failure = None, exc
                    traj = None if res is None else res.trajectory
                    end = constraints.goal
                    if height is not None and position is not None and (
                            traj is None or float(traj["position"][:, 2].max()) < height):
                        if traj is None:  # the primitive cannot make the move: a transit may
                            try:
                                res = _reuse(skill, constraints.replace(obstacles=()), [], where, task_limits,
                                             random_state)
                            except ValueError:
                                raise failure from None
                            traj = res.trajectory
                        rotated = "orientation" in traj.streams
                        q_a = (orientation if orientation is not None else traj["orientation"][0]) \
                            if rotated else None
                        q_b = traj["orientation"][-1] if rotated else None
                        pieces = _transit(position, end, q_a, q_b, height, task_limits)
                        reached = "cannot avoid the obstacles on its own" if failure is not None else \
                            f"reaches z = {float(traj['position'][:, 2].max()):.6g} m"
                        step_notes.append(f"{where}: a transit at z = {height:.6g} m carries the move (the "
                                          f"primitive {reached})")
                    else:
                        pieces = [("primitive", None)]
                    q_goal = traj["orientation"][-1] if "orientation" in traj.streams else None
                    for kind, a_, b_ in (("approach", near, goal), ("retreat", goal, away)):
                        if (near, away)[kind == "retreat"] is not None:
                            pieces.append((kind, _line(a_, b_, q_goal, q_goal, APPROACH_SPEED, task_limits)))
                    streams, segments = _assemble(pieces, traj)
                    n = len(streams["t"])
                    t = streams.pop("t")
                    if goal_q is not None and not with_q:
                        step_notes.append(f"{where}: the goal orientation was left free: skill "
                                          f"{skill.label!r} has none")
                    law = "as given"
                    if model is not None:
                        seed = joints
                        if seed is None:
                            best = next(p for p in skill.primitives if p.id == res.used[0]).demo
                            if "joints" in best.streams and best["joints"].shape[1] == model.n_joints:
                                seed = best["joints"][0]
                        # the start is a pose: a configuration clear of all
                        if joints is None and branch is None:
                            streams["joints"] = _first_joints(model, scene, streams, seed, where,
                                                              _obstacles(scene, b, where), clearance_margin,
                                                              args)
                        else:
                            streams["joints"] = _joints(model, streams, seed, where, branch)
                        t, note, law = _timed_step(streams, t, limits, model, where,
                                                   "rest" if zero is not None else "given")
                        if note:
                            step_notes.append(note)
                    G, note = _gripper(_recorded_gripper(traj, segments), b, gripper, n)
                    if G is not None:
                        streams["gripper"] = G[:, None]
                    if note:
                        step_notes.append(f"{where}: {note}")
                    streams["t"] = t
                    # objects the step and the one before act on may be touched (pressed, left); others not
                    if steps:
                        resting = set(steps[-1].args)
                    elif model is not None:  # where the robot starts: objects it rests on it may leave
                        resting = _resting(model, scene, streams["joints"][:1], clearance_margin)
                    else:
                        resting = set()
                    acted = set(args) | resting
                    others = [n for n in scene.objects if n not in acted]
                    arm = check_step(world, streams, segments, where, model, scene=scene,
                                     names=_obstacles(scene, b, where), margin=clearance_margin,
                                     first=not steps, objects=others)
                    break
                except _ArmContact as contact:
                    if strategy == "via" and contact.other not in grow:
                        # a via point in the primitive that moves the body away
                        # (skillbank.robots.clearing_move, through the robot's kinematics, so links far from
                        # the tool are repaired too)
                        if not via and attempt == MAX_VIA_POINTS:
                            raise failed from None  # no via point could be tried: the growth's reason
                        shape, phase, move = _shape(scene, contact.other), contact.primitive_phase(), None
                        if phase is None:
                            why = "it is not in the primitive"
                        elif shape is None:
                            why = "its body is itself"
                        elif attempt == MAX_VIA_POINTS:
                            why = f"after {len(via)} via point(s)"
                        else:
                            why = "moving the tool cannot clear it"
                            move = clearing_move(model, contact.q, contact.body, shape, contact.body_lack)
                        if move is None:
                            what = str(contact).split(": ", 1)[-1].split(" (clearance margin")[0]
                            raise ValueError(f"{failed}; via points in the primitive did not clear it "
                                             f"either: {what} ({why})") from None
                        mm = np.linalg.norm(move) * 1000
                        via = shift_near(via, phase, move, _SAME_PLACE) + [
                            (ViaPoint(contact.point + move, phase=phase),
                             f"{contact.body} off {contact.other} (tool moved {mm:.3g} mm)")]
                        repaired.append(contact.other)
                        continue
                    # the tool path keeps further from what the body came near, by what it lacked
                    growable = contact.other in scene.obstacles or contact.other == "table"
                    if not growable or attempt == MAX_REPAIRS:
                        grown = ", ".join(f"{n} by {g * 1000:.3g} mm" for n, g in grow.items())
                        failed = ValueError(f"{contact} (after {len(repaired)} repair(s) growing {grown} "
                                            "for the tool path)" if repaired else str(contact))
                        # what growing failed on: this obstacle, or (a body or an object, never grown) the
                        # last one grown, whose growth brought the arm here
                        failing = contact.other if growable else (repaired[-1] if repaired else None)
                        if strategy == strategies[-1]:
                            raise failed from None
                        continue
                    grow[contact.other] = grow.get(contact.other, 0.0) + contact.lack
                    repaired.append(contact.other)
                except ValueError as exc:
                    if not repaired:
                        raise
                    if failed is not None:  # the via points left no path: the growth's reason, and why
                        raise ValueError(f"{failed}; via points in the primitive left no path either "
                                         f"({' '.join(str(exc).split())})") from None
                    failing = repaired[-1]
                    failed = ValueError(f"{where}: cannot keep the robot clear of {repaired[-1]}: growing it "
                                        f"for the tool path by {grow[repaired[-1]] * 1000:.3g} mm leaves no "
                                        f"path ({' '.join(str(exc).split())})")
                    if strategy == strategies[-1]:
                        raise failed from None
        except ValueError as exc:
            if not _plannable(exc, planner, model, position, where):
                raise
            # the skill (and the hand-written transit) cannot keep the robot clear: the motion planner
            # finds the move in joint space (OMPL), and a straight approach brings the tool onto the goal
            res, streams, segments, G, arm, resting, step_notes, law = _planned_step(
                exc, model=model, scene=scene, skill=skill, where=where, position=position,
                orientation=orientation, joints=joints, goal=goal, goal_q=goal_q, gripper=gripper,
                steps=steps, args=args, margin=clearance_margin, task_limits=task_limits, limits=limits,
                random_state=random_state, time_limit=motion_time_limit)
            grow, via, n = {}, [], len(streams["t"])
        if grow:
            step_notes.append(f"{where}: kept the whole robot clear by keeping the tool further from "
                              + ", ".join(f"{n} (by {g * 1000:.3g} mm)" for n, g in grow.items()))
        for v, what in via:
            step_notes.append(f"{where}: repair: via point at phase {v.phase:.3f} of the primitive keeps the "
                              f"robot's {what}")
        if pieces_all:
            prev = pieces_all[-1]
            errors["position"] = max(errors["position"],
                                     float(np.linalg.norm(streams["position"][0] - prev["position"][-1])))
            if "orientation" in streams and "orientation" in prev:
                errors["orientation"] = max(errors["orientation"], float(quaternion_angle(
                    streams["orientation"][0], prev["orientation"][-1])))
            if model is not None:
                errors["joints"] = max(errors["joints"],
                                       float(np.abs(streams["joints"][0] - prev["joints"][-1]).max()))
        first = 0 if not steps else steps[-1].stop - 1
        pieces_all.append(streams)
        moved = any(k == "primitive" for k, _, _ in segments)  # else a transit met the end points exactly
        step = PlanStep(action, tuple(args), skill.label, first, first + n, list(res.used), goal, goal_q,
                        b.method, float(res.constraint_error) if moved else 0.0, float(res.orientation_error),
                        bool(res.collision), step_notes + [
                            f"{where}: {x}" for x in res.notes
                            # with a robot the chain computes the joints itself: reuse's note that
                            # it dropped the recorded joints does not apply
                            if not (model is not None and x.startswith("joints"))],
                        segments=[{"kind": k, "start": first + a, "stop": first + z} for k, a, z in segments],
                        clearance=arm, touches=sorted(resting - set(args)) if not steps else [])
        steps.append(step)
        laws.append(law if model is not None else "as given")
        notes += step_notes
        position, orientation = streams["position"][-1], streams.get("orientation", [None])[-1]
        joints = streams["joints"][-1] if model is not None else None
        gripper = float(G[-1]) if G is not None else gripper
        if progress is not None:
            progress(i, len(plan))
    trajectory = _join(pieces_all, model, notes)
    if model is not None:
        trajectory = _timed_joins(trajectory, limits, notes)
        # what every export states: the law and the limits the joints were timed for, and each step's law
        trajectory.metadata["timing"] = {
            "law": next((k for k in ("toppra", "uniform") if k in laws), "as given"), "steps": laws,
            "limits": {k: _plain(v) for k, v in limits.items()}}
        stretched = trajectory.metadata.pop("joins_stretched_by", None)
        if stretched is not None:  # and the stretch after them, should a join need it
            trajectory.metadata["timing"]["joins_stretched_by"] = stretched
    everything = _world(scene, list(scene.obstacles))
    collision = any(ob.collides(trajectory["position"]) for _, ob in everything)
    whole = None
    if model is not None:  # the whole robot over the joined path, every obstacle of the scene
        whole = float(arm_clearance(model, scene, list(scene.obstacles), trajectory["joints"]).min_distance)
        collision = collision or whole < 0.0
    error = max([s.constraint_error for s in steps] + [errors["position"]])
    return PlanResult(plan=list(plan), steps=steps, trajectory=trajectory, collision=bool(collision),
                      constraint_error=error, join_error=errors, notes=notes, clearance=whole)


def _timed_joins(trajectory, limits, notes) -> Demonstration:
    """The joined trajectory, stretched uniformly where the joins of its steps break the joint limits.

    Each step is timed on its own (:func:`_timed_step`); steps that join at rest meet the limits across
    their join too (measured: the four-button plan's joins reach the acceleration limit, not beyond).
    A step bound with ``"velocity": "free"`` keeps its own speed at its ends, which the next step's need
    not match: then the whole chain is stretched by the factor that meets the limits, with a note.
    """
    keys = {k.removeprefix("joint_"): limits[k] for k in _JOINT_KEYS if k in limits}
    if not keys or trajectory.n_steps < 3:
        return trajectory
    with numerical_errors("plan (timing the joins)"):
        need = rate_ratio(trajectory.t, trajectory["joints"], **keys)
    if need <= _ROUND_OFF:
        return trajectory
    scale = need * _MARGIN
    t = trajectory.t * scale
    notes.append(f"time stretched by {scale:.4g} to meet the joint limits across the joins of the steps "
                 f"(each step is timed on its own): {trajectory.t[-1]:.6g} s -> {t[-1]:.6g} s")
    out = Demonstration(t, trajectory.streams, dict(trajectory.metadata, joins_stretched_by=scale))
    out.metadata["peaks"] = peak_rates(out)
    return out


def _join(pieces, model, notes) -> Demonstration:
    """The pieces on one time base, each join sample kept once; streams every piece has (gripper filled)."""
    names = [k for k in pieces[0] if k != "t" and all(k in p for p in pieces)]
    dropped = sorted({k for p in pieces for k in p if k != "t" and k not in names})
    if dropped:
        notes.append(f"streams {summarise(dropped)} left out: not every step's skill recorded them")
    times, offset = [], 0.0
    for k, p in enumerate(pieces):
        t = p["t"] + offset
        times.append(t if k == 0 else t[1:])
        offset = t[-1]
    streams = {name: np.concatenate([p[name] if k == 0 else p[name][1:] for k, p in enumerate(pieces)])
               for name in names}
    metadata = {"steps": len(pieces)}
    if model is not None:
        metadata.update(joint_names=list(model.joint_names), robot=model.name, pose_of=tool_point(model))
    demo = Demonstration(np.concatenate(times), streams, metadata)
    demo.metadata["peaks"] = peak_rates(demo)
    return demo
