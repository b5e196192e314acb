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

from ..core import Constraints, Demonstration, quaternion_angle
from ..core._validation import summarise
from ..robots import RobotModel, robot_model
from ..selection import reuse
from ..selection._execution import check_limits, peak_rates, robot_limits

__all__ = ["PlanStep", "PlanResult", "reproduce_plan", "EMPTY_PLAN"]

#: The note of a plan of no steps.
EMPTY_PLAN = "the goal already holds in the initial facts: the plan has no steps and nothing is reproduced"

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

    def to_dict(self) -> dict:
        """JSON-able: ``action``, ``args``, ``skill``, ``start``, ``stop``, ``used`` and the step's errors."""
        return {"action": self.action, "args": list(self.args), "skill": self.skill, "start": int(self.start),
                "stop": int(self.stop), "used": [int(i) for i in self.used], "goal": self.goal.tolist(),
                "goal_orientation": None if self.goal_orientation is None else self.goal_orientation.tolist(),
                "method": self.method, "constraint_error": float(self.constraint_error),
                "orientation_error": float(self.orientation_error), "collision": bool(self.collision),
                "notes": list(self.notes)}


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
        Whether the whole path touches any obstacle of the scene.
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
    if binding.goal is not None:
        name = args[[p for p, _ in params].index(binding.goal)]
        if name not in scene.objects or scene.objects[name].position is None:
            raise ValueError(f"{where}: its binding's goal {binding.goal} is {name!r}, which has no "
                             "position in the scene")
        return name
    posed = [a for a in args if a in scene.objects and scene.objects[a].position is not None]
    if not posed:
        raise ValueError(f"{where}: none of its arguments {list(args)} is an object with a position in "
                         "the scene, so the step has no goal (give the object a position, or the skill a "
                         "binding)")
    return posed[-1]


def _obstacles(scene, binding, where) -> list:
    if binding.obstacles == "all":
        return list(scene.obstacles)
    unknown = [n for n in binding.obstacles if n not in scene.obstacles]
    if unknown:
        raise ValueError(f"{where}: its binding names obstacle {unknown[0]!r}, which the scene does not have "
                         f"(obstacles {list(scene.obstacles)})")
    return list(binding.obstacles)


def _inside(scene, names, point, what, where) -> None:
    for n in names:
        if scene.obstacles[n].signed_distance(np.asarray(point, dtype=float)[None])[0] < 0.0:
            raise ValueError(f"{where}: cannot avoid obstacle {n} ({scene.specs[n]}): its {what} "
                             f"{np.round(point, 6).tolist()} is inside it")


def _hits(scene, names, Y) -> list:
    return [n for n in names if scene.obstacles[n].collides(Y)]


def _reuse(skill, constraints, scene, names, where, limits, random_state):
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
                blocking = _hits(scene, names, free.trajectory["position"])
            except ValueError:
                blocking = []
            if blocking:
                shown = ", ".join(f"{n} ({scene.specs[n]})" for n in blocking)
                raise ValueError(f"{where}: cannot avoid obstacle {shown}: skill {skill.label!r} has no "
                                 f"primitive that can be edited around it ({message})") from None
        raise ValueError(f"{where}: skill {skill.label!r} has no usable primitive: "
                         f"{message.removeprefix('no usable candidate: ')}") from None
    if res.collision:
        blocking = _hits(scene, names, res.trajectory["position"]) or names
        shown = ", ".join(f"{n} ({scene.specs[n]})" for n in blocking)
        raise ValueError(f"{where}: cannot avoid obstacle {shown}: the {b.method} reproduction of skill "
                         f"{skill.label!r} passes through it")
    return res


def _joints(model, traj, seed, where, branch=None) -> np.ndarray:
    if "orientation" not in traj.streams:
        raise ValueError(f"{where}: robot {model.name} needs an orientation, and the skill's primitives "
                         "have none")
    try:
        return model.ik(traj["position"], traj["orientation"], q_seed=seed, branch=branch)
    except ValueError as exc:
        raise ValueError(f"{where}: robot {model.name}: {' '.join(str(exc).split())}") from None


def _joint_scale(J, t, limits) -> float:
    """The uniform time stretch that keeps every joint within the joint limits (1.0: none needed)."""
    scale = 1.0
    if len(t) < 3:
        return scale
    dt = np.diff(t)
    v = np.diff(J, axis=0) / dt[:, None]
    a = np.diff(v, axis=0) / (0.5 * (dt[1:] + dt[:-1]))[:, None]
    if "joint_velocity" in limits:
        scale = max(scale, float((np.abs(v) / limits["joint_velocity"]).max()) * (1 + 1e-12))
    if "joint_acceleration" in limits:
        scale = max(scale, float(np.sqrt((np.abs(a) / limits["joint_acceleration"]).max())) * (1 + 1e-12))
    return scale


def _gripper(traj, binding, carried, n):
    """The step's gripper stream (or None), and a note when it switches at the join."""
    recorded = traj["gripper"][:, 0] if "gripper" in traj.streams else None
    if binding.gripper_start is None and binding.gripper_end is None:
        if recorded is not None:
            note = None
            if carried is not None and recorded[0] != carried:
                note = (f"gripper switches from {carried:g} to the skill's recorded {recorded[0]:g} at "
                        "the join")
            return recorded.copy(), note
        return (None if carried is None else np.full(n, carried)), None
    first = next(v for v in (binding.gripper_start, carried, None if recorded is None else recorded[0],
                             binding.gripper_end) if v is not None)
    G = np.full(n, float(first))
    if binding.gripper_end is not None:
        G[-1] = binding.gripper_end
    return G, None


def reproduce_plan(scene, plan, skills, *, robot=None, limits=None, random_state=None, progress=None):
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

    Returns
    -------
    PlanResult
    """
    limits = check_limits(limits)
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
    pieces, steps, notes = [], [], []
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
        names = _obstacles(scene, b, where)
        _inside(scene, names, goal, f"goal (the pose of {target})", where)
        if position is not None:
            _inside(scene, names, position, "start", where)
        with_q = all("orientation" in p.demo.streams for p in skill.primitives)
        zero = np.zeros(3) if b.velocity == "zero" else None
        constraints = Constraints(start=position, goal=goal, start_velocity=zero, end_velocity=zero,
                                  obstacles=[scene.obstacles[n] for n in names],
                                  start_orientation=orientation if with_q else None,
                                  goal_orientation=goal_q if with_q else None)
        res = _reuse(skill, constraints, scene, names, where, task_limits, random_state)
        traj = res.trajectory
        n = traj.n_steps
        streams = {name: traj[name] for name in traj.stream_names if name != "joints"}
        step_notes = []
        if goal_q is not None and not with_q:
            step_notes.append(f"{where}: the goal orientation was left free: skill {skill.label!r} has none")
        t = traj.t - traj.t[0]
        if model is not None:
            seed = joints
            if seed is None:
                best = next(p for p in skill.primitives if p.id == res.used[0]).demo
                if "joints" in best.streams and best["joints"].shape[1] == model.n_joints:
                    seed = best["joints"][0]
            streams["joints"] = _joints(model, traj, seed, where, branch)
            scale = _joint_scale(streams["joints"], t, limits)
            if scale > 1.0:
                t = t * scale
                step_notes.append(f"{where}: time stretched by {scale:.4g} to meet the joint limits: "
                                  f"{t[-1] / scale:.6g} s -> {t[-1]:.6g} s")
        G, note = _gripper(traj, b, gripper, n)
        if G is not None:
            streams["gripper"] = G[:, None]
        if note:
            step_notes.append(f"{where}: {note}")
        if pieces:
            prev = pieces[-1]
            errors["position"] = max(errors["position"],
                                     float(np.linalg.norm(streams["position"][0] - prev["position"][-1])))
            if "orientation" in streams and "orientation" in prev:
                errors["orientation"] = max(errors["orientation"], float(quaternion_angle(
                    streams["orientation"][0], prev["orientation"][-1])))
            if model is not None:
                errors["joints"] = max(errors["joints"],
                                       float(np.abs(streams["joints"][0] - prev["joints"][-1]).max()))
        first = 0 if not steps else steps[-1].stop - 1
        streams["t"] = t
        pieces.append(streams)
        steps.append(PlanStep(action, tuple(args), skill.label, first, first + n, list(res.used), goal,
                              goal_q, b.method, float(res.constraint_error), float(res.orientation_error),
                              bool(res.collision), step_notes + [
                                  f"{where}: {x}" for x in res.notes
                                  # with a robot the chain computes the joints itself: reuse's note that
                                  # it dropped the recorded joints does not apply
                                  if not (model is not None and x.startswith("joints"))]))
        notes += step_notes
        position, orientation = streams["position"][-1], streams.get("orientation", [None])[-1]
        joints = streams["joints"][-1] if model is not None else None
        gripper = float(G[-1]) if G is not None else gripper
        if progress is not None:
            progress(i, len(plan))
    trajectory = _join(pieces, model, notes)
    collision = scene.constraints().collides(trajectory["position"]) if scene.obstacles else False
    error = max([s.constraint_error for s in steps] + [errors["position"]])
    return PlanResult(plan=list(plan), steps=steps, trajectory=trajectory, collision=bool(collision),
                      constraint_error=error, join_error=errors, notes=notes)


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
        metadata.update(joint_names=list(model.joint_names), robot=model.name)
    demo = Demonstration(np.concatenate(times), streams, metadata)
    demo.metadata["peaks"] = peak_rates(demo)
    return demo
