"""Replay a joint trajectory in the MuJoCo world of a scene and report what the physics did.

:func:`simulate` compiles the world (:func:`~skillbank.simulation.build_world`),
starts the robot at the trajectory's first sample, drives the joint servos
with the trajectory interpolated at every physics step (positions and their
velocities) and the gripper from its ``gripper`` stream, and records
tracking, contacts, buttons and objects (docs/simulation.md gives every rule).
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import Demonstration
from ..robots import RobotModel, robot_model
from ._bounds import check_frames, check_steps
from ._mujoco import import_mujoco
from ._video import Recorder, check_video_path, select_gl
from ._world import GRIP_FORCE, PRESS_FORCE, build_world

__all__ = ["simulate", "SimulationResult", "GRIPPER_RANGE"]

#: The ``gripper`` stream's values for open and closed: the three-button recording runs from 1 (open,
#: before the grasp) to 90 (closed, 7.7 s to 22.8 s), Robotiq's 0-100 % closing scale.
GRIPPER_RANGE = (0.0, 100.0)
#: Contacts of one pair closer in time than this are one event (a contact that chatters stays one).
MERGE_GAP = 0.05
#: An object is lifted when its centre rises more than this (m) above its start while it is held.
LIFT_HEIGHT = 0.01
#: Goal atoms of one object the simulation judges, and what decides them: ``(holding o)`` or
#: ``(held o)``, both fingers on it at the end; ``(lifted o)``, it rose LIFT_HEIGHT while held.
OBJECT_FACTS = {"holding": "held", "held": "held", "lifted": "lifted"}
#: Facts judged of a scene object that is only a point (a target pose, no shape): the tool came to it.
POINT_FACTS = ("visited", "reached", "at")
#: m: how near the simulated tool point must come to a point object for it to be visited (the plan ends
#: its steps on the point; the servos track the plan within a millimetre or so)
POINT_REACHED = 0.005


@dataclass
class SimulationResult:
    """What a simulation found (docs/simulation.md). :meth:`to_dict` is the JSON contract.

    Attributes
    ----------
    duration : float
        Seconds simulated (the trajectory's duration).
    real_time_factor : float
        Simulated seconds per second of wall-clock time.
    joint_max, tool_max : float
        Largest joint tracking error (rad) and tool-point error (m, the forward kinematics of the
        simulated joints against that of the commanded ones).
    contacts : list of dict
        ``{"robot_body", "other", "t", "force"}`` per contact event that no target explains.
    buttons : dict
        Name -> ``{"pressed", "peak_force", "t"}``.
    objects : dict
        Name -> ``{"displacement", "held", "lifted"}``.
    facts : dict
        ``"(pressed b1)"`` -> True, False, or None where the simulation cannot judge the atom.
    notes : list of str
    robot : str
        The arm driven (its model's name, e.g. ``"ur5e"``, ``"panda"``).
    t_, q_, q_ref_ : ndarray
        The physics steps' times ``(m,)``, simulated and commanded joints ``(m, n_joints)``.
    tool_, tool_ref_ : ndarray
        The simulated and commanded tool points ``(m, 3)``.
    button_force_, button_depth_ : dict
        Name -> ``(m,)`` robot force on the button (N) and its plunger's depth (m).
    contact_spans_ : list of tuple
        ``(robot_body, other, t_start, t_end, peak force)`` for every event in ``contacts``.
    contact_points_ : list of ndarray
        Where each event in ``contacts`` started (world, m).
    video_ : pathlib.Path or None
        The GIF written, when ``video`` was given.
    """

    duration: float
    real_time_factor: float
    joint_max: float
    tool_max: float
    contacts: list
    buttons: dict
    objects: dict
    facts: dict
    notes: list = field(default_factory=list)
    robot: str = ""
    t_: np.ndarray = None
    q_: np.ndarray = None
    q_ref_: np.ndarray = None
    tool_: np.ndarray = None
    tool_ref_: np.ndarray = None
    button_force_: dict = field(default_factory=dict)
    button_depth_: dict = field(default_factory=dict)
    contact_spans_: list = field(default_factory=list)
    contact_points_: list = field(default_factory=list)
    video_: Path | None = None

    @property
    def ok(self) -> bool:
        """Every goal fact the simulation can judge holds and no unintended contact happened."""
        return not self.contacts and all(v is not False for v in self.facts.values())

    @property
    def confirmed(self) -> bool:
        """Every goal fact was seen to hold and no unintended contact happened.

        Stricter than :attr:`ok`: a fact the simulation cannot judge is not confirmed (what a plan or a
        reuse claims is reported done only when the world showed it).
        """
        return not self.contacts and all(v is True for v in self.facts.values())

    def to_dict(self) -> dict:
        """The JSON contract (docs/simulation.md): plain floats, bools, strings and None."""
        return {
            "robot": self.robot,
            "duration": float(self.duration),
            "real_time_factor": float(self.real_time_factor),
            "tracking": {"joint_max": float(self.joint_max), "tool_max": float(self.tool_max)},
            "contacts": [dict(c) for c in self.contacts],
            "buttons": {k: dict(v) for k, v in self.buttons.items()},
            "objects": {k: dict(v) for k, v in self.objects.items()},
            "facts": dict(self.facts),
            "notes": list(self.notes),
            "ok": self.ok,
        }


def _trajectory(trajectory, n_joints: int):
    if isinstance(trajectory, (str, os.PathLike)):
        from ..io import load  # the readers, for a trajectory given as a file

        trajectory = load(Path(trajectory))
    if not isinstance(trajectory, Demonstration):
        raise ValueError(f"trajectory: expected a skillbank.core.Demonstration or a file skillbank reads, "
                         f"got {type(trajectory).__name__}")
    if "joints" not in trajectory:
        raise ValueError(f"trajectory: expected a 'joints' stream (n, {n_joints}) to simulate, got streams "
                         f"{trajectory.stream_names}; give a reuse's or plan's output written with a robot "
                         "(--robot) or a recording with joint positions")
    q = np.asarray(trajectory["joints"], dtype=float)
    if q.ndim != 2 or q.shape[1] != n_joints:
        raise ValueError(f"trajectory.joints: expected {n_joints} columns (one per joint, in the model's "
                         f"order), got shape {q.shape}")
    if not np.all(np.isfinite(q)):
        raise ValueError("trajectory.joints: expected finite joint angles, got NaN or infinity")
    t = np.asarray(trajectory.t, dtype=float)
    t = t - t[0]
    g = None
    if "gripper" in trajectory:
        g = np.asarray(trajectory["gripper"], dtype=float).reshape(len(t), -1)[:, 0]
        if not np.all(np.isfinite(g)):
            raise ValueError("trajectory.gripper: expected finite values, got NaN or infinity")
    return t, q, g


def _targets(targets, scene, duration):
    """``[(t0, t1, set of names)]``, checked; None: every button and object, always."""
    names = set(scene.objects)
    if targets is None:
        return [(-math.inf, math.inf, names)]
    out = []
    for k, window in enumerate(targets):
        try:
            t0, t1, which = window
            t0, t1 = float(t0), float(t1)
        except (TypeError, ValueError):
            raise ValueError(f"targets[{k}]: expected (t_start, t_end, names), got {window!r}") from None
        which = {which} if isinstance(which, str) else set(which)
        unknown = sorted(which - names)
        if unknown or not t0 <= t1:
            what = f"unknown object {unknown[0]!r} (scene objects: {sorted(names)})" if unknown else \
                f"t_start {t0} after t_end {t1}"
            raise ValueError(f"targets[{k}]: {what}")
        out.append((t0, t1, which))
    return out


def _opening(g, gripper_range, stroke):
    lo, hi = (float(v) for v in gripper_range)
    if not hi != lo:
        raise ValueError(f"gripper_range: expected the open and closed values to differ, got "
                         f"{gripper_range!r}")
    return np.clip(stroke * (hi - g) / (hi - lo), 0.0, stroke)


def simulate(trajectory, scene, *, robot="ur5e", targets=None, timestep: float = 0.002,
             press_fraction: float = 0.5, gripper_range=GRIPPER_RANGE, press_force: float = PRESS_FORCE,
             grip_force: float = GRIP_FORCE, kp=None, kv=None, settle: float = 0.2, progress=None,
             video=None, video_fps: float = 25.0, video_size=(480, 360)) -> SimulationResult:
    """Replay ``trajectory`` in the physics world of ``scene`` and report what happened.

    Parameters
    ----------
    trajectory : Demonstration or path
        With a ``joints`` stream ``(n, n_joints)`` in the model's joint order and optionally ``gripper``.
    scene : skillbank.planning.Scene
    robot : str or RobotModel, default="ur5e"
    targets : list of (t_start, t_end, names), optional
        Which buttons and objects the robot may touch when (default: every one, always).
    timestep : float
        Physics step (s).
    press_fraction : float
        A button is pressed once its plunger has gone this fraction of its travel down.
    gripper_range : (open, closed)
        The ``gripper`` stream's values for the fully open and the closed gripper.
    press_force, grip_force : float
        N a button takes at half its travel; largest force of each finger.
    kp, kv : sequence of float, optional
        Joint servo gains (defaults: ``SERVO_GAINS``).
    settle : float
        Seconds the first sample is held before the replay, so that objects come to rest.
    progress : callable or tqdm, optional
        ``progress(done, total)`` over physics steps, or a tqdm bar (its ``total`` is set).
    video : path, optional
        An animated GIF rendered off-screen (MUJOCO_GL=egl or osmesa), each frame written as it is rendered.

    Returns
    -------
    SimulationResult

    Raises
    ------
    ValueError
        A trajectory without joints or of the wrong width, a robot that starts inside an obstacle or the
        table, a table above the start tool point, bad parameters; more physics steps than
        ``SKILLBANK_MAX_SIMULATION_STEPS`` (2^21) or video frames than ``SKILLBANK_MAX_VIDEO_FRAMES``
        (2^14), counted before anything is allocated.
    ImportError
        Without MuJoCo: one line naming the extra.

    Examples
    --------
    >>> import numpy as np
    >>> from skillbank.core import Demonstration
    >>> from skillbank.planning import Scene
    >>> from skillbank.robots import robot_model
    >>> q = np.tile(robot_model("ur5e").home, (11, 1))
    >>> demo = Demonstration(np.linspace(0, 0.2, 11), {"joints": q})
    >>> result = simulate(demo, Scene(objects={}, obstacles={}, init=[], goal=[]))
    >>> result.contacts, result.tool_max < 1e-3
    ([], True)
    """
    model = robot if isinstance(robot, RobotModel) else robot_model(robot)
    t, q_cmd, g_cmd = _trajectory(trajectory, model.n_joints)
    for name, value, top in (("timestep", timestep, 0.1), ("press_fraction", press_fraction, 1.0)):
        if not (isinstance(value, (int, float)) and np.isfinite(value) and 0 < value <= top):
            raise ValueError(f"{name}: expected a number in (0, {top}], got {value!r}")
    if not (np.isfinite(settle) and settle >= 0):
        raise ValueError(f"settle: expected seconds >= 0, got {settle!r}")
    duration = float(t[-1])
    steps = check_steps(duration, float(timestep))  # before any array of the replay is allocated
    if video is not None:
        fps_ok = isinstance(video_fps, (int, float)) and np.isfinite(video_fps)
        if not (fps_ok and 0 < video_fps <= 1 / timestep):
            raise ValueError(f"video_fps: expected frames/s in (0, {1 / timestep:g}] (one per physics step "
                             f"at most), got {video_fps!r}")
        check_frames(steps, max(1, int(round(1 / (video_fps * timestep)))), float(video_fps))
    windows = _targets(targets, scene, duration)
    tool = np.eye(4) if model.gripper_ is None else model.gripper_.tool()
    start_tcp = (model.link_frames(q_cmd[0])[0, -1] @ tool)[:3, 3]
    table = getattr(scene, "table", None)
    if table is not None and float(np.asarray(table.upper)[2]) > start_tcp[2]:
        raise ValueError(f"scene.table: its top (z = {float(np.asarray(table.upper)[2]):.4g} m) is above the "
                         f"robot's start tool point (z = {start_tcp[2]:.4g} m); lower the table or start the "
                         "trajectory above it")
    renderer = None
    if video is not None:
        check_video_path(video)
        select_gl()
    mujoco = import_mujoco()
    world = build_world(scene, model, press_force=press_force, grip_force=grip_force, kp=kp, kv=kv,
                        timestep=timestep)
    M = mujoco.MjModel.from_xml_string(world.xml)
    d = mujoco.MjData(M)
    run = _Runner(mujoco, M, d, world, model, scene.goal,
                  points={o.name: o.position for o in scene.objects.values()
                          if o.shape is None and o.position is not None})
    opening = None if g_cmd is None or not world.fingers else _opening(g_cmd, gripper_range, world.stroke)
    run.hold(q_cmd[0], world.stroke if opening is None else opening[0])
    run.check_start()
    if video is not None:
        renderer = Recorder(mujoco, M, video, fps=video_fps, size=video_size)
    try:
        result = run.replay(t, q_cmd, opening, windows, settle=settle, press_fraction=press_fraction,
                            progress=progress, renderer=renderer, tool=tool)
        if renderer is not None:
            result.video_ = renderer.write()
        return result
    finally:
        if renderer is not None:
            renderer.close()


def _tool_points(model, q, tool, chunk: int = 16384):
    """The tool point ``(m, 3)`` at each row of ``q``, in chunks (all link frames at once: ~1 KB a step)."""
    out = np.empty((len(q), 3))
    for s in range(0, len(q), chunk):
        out[s:s + chunk] = (model.link_frames(q[s:s + chunk])[:, -1] @ tool)[:, :3, 3]
    return out


class _Runner:
    """One simulation: the compiled model, its data and the name tables."""

    def __init__(self, mujoco, M, d, world, model, goal, points=None):
        self.goal = list(goal)
        self.points = dict(points or {})  # name -> position of the scene's objects that are only points
        self.mj, self.M, self.d, self.world, self.model = mujoco, M, d, world, model
        self.qadr = np.array([M.jnt_qposadr[M.joint(j).id] for j in world.joints])
        self.dadr = np.array([M.jnt_dofadr[M.joint(j).id] for j in world.joints])
        self.servo = np.array([M.actuator(f"servo_{j}").id for j in world.joints])
        self.damper = np.array([M.actuator(f"damper_{j}").id for j in world.joints])
        self.fadr = np.array([M.jnt_qposadr[M.joint(j).id] for j in world.fingers], dtype=int)
        self.grip = np.array([M.actuator(f"grip_{s}").id for s in ("left", "right")[:len(world.fingers)]],
                             dtype=int)
        # geom id -> (kind, name)
        self.owner = [world.owner.get(M.geom(i).name, (None, None)) for i in range(M.ngeom)]
        self.robot = np.array([o[0] == "robot" for o in self.owner])

    def hold(self, q0, opening):
        d = self.d
        d.qpos[self.qadr] = q0
        d.qpos[self.fadr] = opening / 2
        d.qvel[:] = 0
        d.ctrl[self.servo] = q0
        d.ctrl[self.damper] = 0
        d.ctrl[self.grip] = opening / 2
        self.mj.mj_forward(self.M, d)

    def check_start(self):
        """Refuse a robot that starts inside an obstacle or the table."""
        for i in range(self.d.ncon):
            c = self.d.contact[i]
            pair = [self.owner[c.geom1], self.owner[c.geom2]]
            kinds = {p[0] for p in pair}
            if "robot" in kinds and kinds & {"obstacle", "table"} and c.dist < 0:
                link = next(p[1] for p in pair if p[0] == "robot")
                other = next(p for p in pair if p[0] != "robot")
                raise ValueError(f"trajectory: the robot starts inside {other[0]} {other[1]!r} ({link} "
                                 f"{-c.dist * 1000:.1f} mm deep at the first sample); start it clear of the "
                                 "scene")

    def replay(self, t, q_cmd, opening, windows, *, settle, press_fraction, progress, renderer, tool):
        mj, M, d, world = self.mj, self.M, self.d, self.world
        dt = M.opt.timestep
        for _ in range(int(round(settle / dt))):
            mj.mj_step(M, d)
        d.time = 0.0
        self.hold(q_cmd[0], (world.stroke if opening is None else opening[0]))
        n = int(math.floor(t[-1] / dt + 1e-9)) + 1
        times = np.arange(n) * dt
        q_ref = np.column_stack([np.interp(times, t, q_cmd[:, j]) for j in range(q_cmd.shape[1])])
        # The servos' velocity reference: the slope of the interpolated segment each step lies on.
        seg = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 2) if len(t) > 1 else None
        if seg is None:
            v_ref = np.zeros_like(q_ref)
        else:
            v_ref = (q_cmd[seg + 1] - q_cmd[seg]) / np.maximum(t[seg + 1] - t[seg], 1e-12)[:, None]
        g_ref = None if opening is None else np.interp(times, t, opening) / 2
        buttons = {b: (M.jnt_qposadr[M.joint(v["joint"]).id], v["travel"]) for b, v in world.buttons.items()}
        objects = {o: M.body(v["body"]).id for o, v in world.objects.items()}
        pos0 = {o: d.xpos[b].copy() for o, b in objects.items()}
        q_sim = np.empty_like(q_ref)
        force = {b: np.zeros(n) for b in buttons}
        depth = {b: np.zeros(n) for b in buttons}
        lifted = dict.fromkeys(objects, False)
        held = dict.fromkeys(objects, False)
        events, last = [], {}
        f6 = np.zeros(6)
        total = n
        if progress is not None and hasattr(progress, "update"):
            progress.total = total
        every = max(1, int(round(1 / (renderer.fps * dt)))) if renderer is not None else 0
        clock = time.perf_counter()
        for k in range(n):
            d.ctrl[self.servo] = q_ref[k]
            d.ctrl[self.damper] = v_ref[k]
            if g_ref is not None:
                d.ctrl[self.grip] = g_ref[k]
            mj.mj_step(M, d)
            tk = times[k]
            q_sim[k] = d.qpos[self.qadr]
            allowed = set().union(*(w[2] for w in windows if w[0] <= tk <= w[1]))
            now: dict = {}
            touching: dict = {}
            for i in range(d.ncon):
                c = d.contact[i]
                g1, g2 = c.geom1, c.geom2
                if not (self.robot[g1] or self.robot[g2]):
                    continue
                mj.mj_contactForce(M, d, i, f6)
                fn = abs(f6[0])
                a, b = self.owner[g1], self.owner[g2]
                if not self.robot[g1] or (self.robot[g2] and a[1] > b[1]):
                    a, b = b, a
                if b[0] == "button":
                    force[b[1]][k] += fn
                if b[0] == "object":
                    touching.setdefault(b[1], set()).add(a[1])
                if b[0] in ("button", "object") and b[1] in allowed:
                    continue
                key = (a[1], b[1])
                if key not in now or fn > now[key][0]:
                    now[key] = (fn, c.pos.copy())
            for key, (fn, where) in now.items():
                j = last.get(key)
                if j is not None and tk - events[j]["t_end"] <= MERGE_GAP:
                    events[j]["t_end"] = tk
                    events[j]["force"] = max(events[j]["force"], fn)
                else:
                    last[key] = len(events)
                    events.append({"robot_body": key[0], "other": key[1], "t": float(tk), "t_end": float(tk),
                                   "force": fn, "at": where})
            for b, (adr, _) in buttons.items():
                depth[b][k] = d.qpos[adr]
            for o, body in objects.items():
                fingers = touching.get(o, set())
                held[o] = {"finger_left", "finger_right"} <= fingers
                if held[o] and d.xpos[body][2] - pos0[o][2] > LIFT_HEIGHT:
                    lifted[o] = True
            if every and k % every == 0:
                renderer.add(d)
            if progress is not None and (k % 200 == 199 or k == n - 1):
                if hasattr(progress, "update"):
                    progress.update(k + 1 - progress.n)
                else:
                    progress(k + 1, total)
        wall = time.perf_counter() - clock
        return self._result(times, q_sim, q_ref, tool, force, depth, buttons, objects, pos0, held, lifted,
                            events, press_fraction, wall)

    def _result(self, times, q_sim, q_ref, tool, force, depth, buttons, objects, pos0, held, lifted, events,
                press_fraction, wall):
        model, d = self.model, self.d
        tcp, tcp_ref = _tool_points(model, q_sim, tool), _tool_points(model, q_ref, tool)
        out_buttons = {}
        for b, (_, travel) in buttons.items():
            pressed = np.flatnonzero(depth[b] >= press_fraction * travel)
            out_buttons[b] = {"pressed": bool(pressed.size), "peak_force": float(force[b].max(initial=0.0)),
                              "t": float(times[pressed[0]]) if pressed.size else None}
        out_objects = {o: {"displacement": float(np.linalg.norm(d.xpos[body] - pos0[o])),
                           "held": bool(held[o]), "lifted": bool(lifted[o])} for o, body in objects.items()}
        facts, notes = {}, []
        lower = {b.lower(): b for b in out_buttons}
        things = {o.lower(): o for o in out_objects}
        points = {o.lower(): np.asarray(p, float) for o, p in self.points.items()}
        for pred, args in self.goal:
            key = "(" + " ".join([pred, *args]) + ")"
            name = args[0].lower() if len(args) == 1 else None
            if pred.lower() == "pressed" and name in lower:
                facts[key] = out_buttons[lower[name]]["pressed"]
            elif pred.lower() in OBJECT_FACTS and name in things:
                facts[key] = out_objects[things[name]][OBJECT_FACTS[pred.lower()]]
            elif pred.lower() in POINT_FACTS and name in points:
                gap = np.linalg.norm(tcp - points[name], axis=1).min(initial=np.inf)
                facts[key] = bool(gap <= POINT_REACHED)
            else:
                facts[key] = None
                notes.append(f"{key}: the simulation cannot judge this fact (it judges (pressed BUTTON) for "
                             "buttons, (holding OBJECT), (held OBJECT), (lifted OBJECT) for objects with "
                             "a shape, and (visited POINT), (reached POINT), (at POINT) for the tool coming "
                             f"within {POINT_REACHED * 1000:g} mm of an object that is only a point)")
        duration = float(times[-1]) if len(times) else 0.0
        contacts = [{"robot_body": e["robot_body"], "other": e["other"], "t": e["t"],
                     "force": float(e["force"])} for e in events]
        spans = [(e["robot_body"], e["other"], e["t"], e["t_end"], float(e["force"])) for e in events]
        self_contacts = sum(1 for e in events if self._is_robot_name(e["other"]))
        if self_contacts:
            notes.append(f"{self_contacts} contact event(s) between the robot's own bodies")
        return SimulationResult(
            duration=duration, real_time_factor=duration / wall if wall > 0 else math.inf,
            joint_max=float(np.abs(q_sim - q_ref).max(initial=0.0)),
            tool_max=float(np.linalg.norm(tcp - tcp_ref, axis=1).max(initial=0.0)),
            contacts=contacts, buttons=out_buttons, objects=out_objects, facts=facts, notes=notes,
            robot=model.name, t_=times, q_=q_sim, q_ref_=q_ref, tool_=tcp, tool_ref_=tcp_ref,
            button_force_=force, button_depth_=depth, contact_spans_=spans,
            contact_points_=[e["at"] for e in events])

    def _is_robot_name(self, name) -> bool:
        return any(o == ("robot", name) for o in self.world.owner.values())
