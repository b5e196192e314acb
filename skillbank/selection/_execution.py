"""From a reproduced path to something a robot executes: pose, gripper, timing and joints.

A representation reproduces positions. :func:`make_executable` completes
them with what the primitives it learned from recorded:

- **orientation**: each source's orientation stream, mapped onto the
  reproduction by phase with SLERP, averaged in the tangent space of the best
  source (several sources), then turned to the orientation constraints by
  :func:`skillbank.editing.edit_orientation` (a correction field that keeps the
  rotation profile);
- **gripper** (and any stream with whole-number values, or named in
  :data:`DISCRETE_STREAMS`): the best source's, by zero-order hold, so the
  values stay the recorded ones and switch at the mapped time;
- **other streams** (force, torque, ...): the best source's, interpolated
  linearly in phase, as recorded (not adapted to the new path; a note says
  so); recorded ``joints`` are dropped (they no longer match the adapted pose);
- **joints** from a robot model's inverse kinematics of the pose path, when
  a robot is given, starting on the branch of the best source's recorded
  joints;
- **timing**: time starts at 0; the path is never changed, only the time of
  each sample. With a robot, its own joint velocity and acceleration limits
  (:attr:`~skillbank.robots.RobotModel.rate_limits`) always apply, tighter
  given ones too. A time base that meets every limit is kept. One that
  breaks a limit is re-timed by the ``time_law``: ``"toppra"`` (default,
  joint trajectories) gives the joint path the fastest timing under the joint
  limits (:func:`skillbank.robots.time_law`: TOPP-RA, from rest to rest),
  never faster than the time base asked for, then any task-space limit it
  still breaks is met by a uniform stretch of that timing (when that makes it
  slower than the uniform law, the uniform law's timing is kept: both meet
  every limit); ``"uniform"`` (and any trajectory without joints) slows the
  whole reproduction down uniformly to the shortest duration that meets the
  limits. A note says which law,
  under which limits, from what duration to what; the trajectory's metadata
  ``"timing"`` holds the law and the limits (the exports state them). Only a
  time base given as time stamps (``t``) is strict, and refused instead.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import POSE_OF, Demonstration, check_pose_of, continuous_quaternions, slerp
from ..core._rotations import _exp, _log, quaternion_conjugate, quaternion_multiply
from ..core._validation import numerical_errors
from ..editing import edit_orientation
from ..robots import CLEARANCE, TIME_LAWS, KinematicsError, RobotModel, clearance, robot_model, tool_point
from ..robots._start import clear_configurations
from ._clear import _label
from ._limits import DURATION_RANGE, LIMITS, check_duration, check_limits, robot_limits
from ._timing import _check_stretch, _plain, _scale_needed, peak_rates, timed_to_limits

__all__ = ["Executable", "make_executable", "retime", "peak_rates", "executable_dict", "LIMITS",
           "DISCRETE_STREAMS", "DURATION_RANGE", "check_duration", "robot_limits"]

#: Streams carried by zero-order hold whatever their values (commands, not measurements).
DISCRETE_STREAMS = ("gripper",)
#: Recorded streams that are derivatives of the path (RAIL stores them): not carried onto a new path.
DERIVED_STREAMS = ("velocity", "acceleration", "jerk", "angular_velocity", "angular_acceleration")

@dataclass
class Executable:
    """A reproduction with every stream a robot needs.

    Attributes
    ----------
    trajectory : Demonstration
        Streams ``position``, and where the sources had them ``orientation``,
        ``gripper`` and other recorded streams; ``joints`` with a robot.
        Metadata holds ``joint_names`` with joints.
    orientation_error : float
        Largest angle (radians) between a constrained orientation and its target.
    peaks : dict
        ``{stream: {"velocity": float, "acceleration": float}}`` after time
        scaling; ``position`` in units/s (norm), ``orientation`` angular (rad/s,
        norm), ``joints`` the largest of any joint (rad/s).
    time_scale : float
        Duration after timing over duration before (1.0: the time base met the
        limits; with the ``"uniform"`` law, the factor every time was stretched by).
    notes : list of str
        What was carried, dropped or changed, in words.
    """

    trajectory: Demonstration
    orientation_error: float = 0.0
    peaks: dict = field(default_factory=dict)
    time_scale: float = 1.0
    notes: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-able: see :func:`executable_dict`."""
        return executable_dict(self.trajectory, orientation_error=self.orientation_error, peaks=self.peaks,
                               notes=self.notes)


def executable_dict(trajectory: Demonstration, *, orientation_error: float, peaks: dict, notes) -> dict:
    """The JSON document of an executable reproduction (what ``--json`` prints, with the command's keys).

    ``{"t", "streams": {name: rows}, "trajectory": position rows, "orientation_error", "peaks", "notes"}``
    and, with a ``joints`` stream, ``"joint_names"`` and ``"peak_joint_velocity"``.

    Examples
    --------
    >>> d = Demonstration([0.0, 1.0], {"position": [[0.0], [1.0]]})
    >>> sorted(executable_dict(d, orientation_error=0.0, peaks={}, notes=[]))
    ['notes', 'orientation_error', 'peaks', 'streams', 't', 'trajectory']
    """
    doc = {"t": trajectory.t.tolist(),
           "streams": {name: data.tolist() for name, data in trajectory.streams.items()},
           "trajectory": trajectory["position"].tolist(), "orientation_error": float(orientation_error),
           "peaks": peaks, "notes": list(notes)}
    if "joints" in trajectory.streams:
        doc["joint_names"] = list(trajectory.metadata.get("joint_names", []))
        doc["peak_joint_velocity"] = float(peaks["joints"]["velocity"]) if "joints" in peaks else 0.0
    return doc


def retime(demo: Demonstration, duration=None) -> Demonstration:
    """The demonstration with its time shifted to start at 0 and, with ``duration``, stretched to it.

    Examples
    --------
    >>> d = Demonstration(np.array([5.0, 6.0, 9.0]), {"position": np.zeros((3, 1))})
    >>> retime(d).t.tolist(), retime(d, duration=2.0).t.tolist()
    ([0.0, 1.0, 4.0], [0.0, 0.5, 2.0])
    """
    t = demo.t - demo.t[0]
    if duration is not None:
        duration = check_duration(duration)
        if demo.n_steps < 2:
            raise ValueError(f"duration: a demonstration of {demo.n_steps} sample has no duration to set")
        t = t * (duration / t[-1])
        t[-1] = duration
    return Demonstration(t, demo.streams, demo.metadata)


def _source_times(source: Demonstration, u: np.ndarray, by_index: bool) -> np.ndarray:
    """Times of ``source`` at phases ``u`` (of its duration, or of its samples when ``by_index``)."""
    if by_index:
        return np.interp(u * (source.n_steps - 1), np.arange(source.n_steps), source.t)
    return source.t[0] + u * (source.t[-1] - source.t[0])


def _mean_orientation(streams: list) -> np.ndarray:
    """Tangent-space mean of orientation streams sample by sample, about the first (one Karcher step)."""
    ref = continuous_quaternions(streams[0])
    if len(streams) == 1:
        return ref
    inv = quaternion_conjugate(ref)
    V = np.mean([_log(quaternion_multiply(inv, q)) for q in streams], axis=0)
    return continuous_quaternions(quaternion_multiply(ref, _exp(V)))


def _is_discrete(name: str, data: np.ndarray) -> bool:
    return name in DISCRETE_STREAMS or bool(np.all(data == np.round(data)))


def _carry(source: Demonstration, ts: np.ndarray, name: str, label: str) -> tuple[np.ndarray, str]:
    """One stream of ``source`` at times ``ts``: zero-order hold for discrete ones, linear otherwise."""
    data = source[name]
    if _is_discrete(name, data):
        i = np.clip(np.searchsorted(source.t, ts, side="right") - 1, 0, source.n_steps - 1)
        return data[i], f"{name}: from {label}, time-warped by zero-order hold (values kept)"
    cols = [np.interp(ts, source.t, data[:, j]) for j in range(data.shape[1])]
    return np.column_stack(cols), f"{name}: carried from {label} as recorded, time-warped (not adapted)"


def _robot(robot) -> RobotModel:
    if isinstance(robot, RobotModel):
        return robot
    return robot_model(robot)


def _joints(model: RobotModel, position, orientation, source: Demonstration, ts0: float,
            branch=None) -> np.ndarray:
    if orientation is None:
        raise ValueError(f"robot: {model.name} inverse kinematics needs an 'orientation' stream, and the "
                         "primitives have none")
    if position.shape[1] != 3:
        raise ValueError(f"robot: {model.name} inverse kinematics needs 3-D positions, got "
                         f"{position.shape[1]}-D")
    stated, tool = source.metadata.get(POSE_OF), tool_point(model)
    if stated is None or check_pose_of(stated) != tool:
        # inverse kinematics of another point's poses puts the tool where that point was (16 cm off for a
        # flange recording and a 2F-85's TCP): never silently
        what = "an unknown point" if stated is None else repr(stated)
        raise ValueError(f"robot: the poses are of {what}, not {model.name}'s tool {tool}: convert them "
                         "first (skillbank.robots.to_tool; reuse and plan do it)")
    seed = None
    if "joints" in source.streams and source["joints"].shape[1] == model.n_joints:
        i = int(np.clip(np.searchsorted(source.t, ts0, side="right") - 1, 0, source.n_steps - 1))
        seed = source["joints"][i]
    try:
        return model.ik(position, orientation, q_seed=seed, branch=branch)
    except KinematicsError as exc:
        raise KinematicsError(f"robot {model.name}: {exc}", index=exc.index, reason=exc.reason) from None


def _clear_start(model: RobotModel, position, orientation, J, obstacles, margin):
    """The joints ``J`` (on the recorded branch) from a start the arm can take among ``obstacles``.

    ``J`` is kept when its first configuration keeps ``margin`` from the obstacles, as
    :func:`~skillbank.selection.keep_clear` checks a reproduction (the base's bodies left out: a table
    given as an obstacle is where the base stands). Otherwise the start is the configuration at the
    start pose clear of the obstacles and of the robot itself nearest ``J``'s
    (:func:`skillbank.robots._start.clear_configurations`, the one choice of a start, which a plan's start
    takes too), the first whose branch the whole path follows; with none, ``J`` (keep_clear then refuses
    its start, as before). Returns ``(joints, note or None)``.
    """
    fixed = [b.name for b in model.bodies if b.frame == 0]
    first = clearance(model, J[:1], obstacles, ignore=fixed, self_collision=False)
    hit = first.first_contact(margin)
    if hit is None:
        return J, None
    clear, _ = clear_configurations(model, position[0], orientation[0], reference=J[0], obstacles=obstacles,
                                    margin=margin, ignore=fixed)
    for q0 in clear:
        try:
            path = model.ik(position, orientation, q_seed=q0)
        except KinematicsError:
            continue  # the path leaves this branch's reach: the next clear start
        d = float(first.min_distance)
        depth = f"{-d * 1000:.3g} mm into" if d < 0 else f"within {d * 1000:.3g} mm of"

        def name(q):
            return model.branch_names[int(model.branch_of(q)[0])] if len(model.branch_names) > 1 else \
                f"[{', '.join(f'{v:.3g}' for v in q)}]"
        return path, (f"start: the recorded joints' branch {name(J[0])} puts the robot's {hit[1]} {depth} "
                      f"{_label(hit[2], obstacles)} at the start; started on {name(q0)}, the nearest "
                      f"configuration clear of the obstacles and of itself (clearance margin "
                      f"{margin * 1000:g} mm)")
    return J, None


def make_executable(out: Demonstration, sources, constraints, *, ids=None, robot=None, limits=None,
                    fixed_time: bool = False, by_index: bool = False, kind: str = "primitive",
                    branch=None, time_law: str = "toppra", clearance_margin=None) -> Executable:
    """Complete a reproduced path with orientation, gripper, other streams, joints and timing.

    Parameters
    ----------
    out : Demonstration
        The reproduction (stream ``"position"``), its time base starting at 0.
    sources : list of Demonstration
        The primitives it was learned from, best first, with every recorded stream.
    constraints : Constraints
        Orientation constraints are met here; positions already are.
    ids : list, optional
        The sources' ids, for the notes.
    kind : str, default="primitive"
        What a source is called in the notes and messages (``"file"`` for ``skillbank edit``).
    robot : str or RobotModel, optional
        Adds a ``joints`` stream by inverse kinematics (``robot_model(robot)``),
        and the robot's own joint limits to ``limits`` (:func:`robot_limits`).
    limits : dict, optional
        Keys of :data:`LIMITS`. A time base that breaks one is re-timed by
        ``time_law`` (a note says which, under which limits, and the duration
        before and after).
    time_law : {"toppra", "uniform"}, default="toppra"
        How a joint trajectory (with ``robot``) is re-timed: the fastest
        timing of its joint path (:func:`skillbank.robots.time_law`), or a
        uniform stretch of the given one. Without joints, always uniform.
    fixed_time : bool, default=False
        The time base was given as time stamps: limits that need a longer one
        are an error instead of a stretch.
    branch : int or str, optional
        The robot's inverse-kinematics branch (a name of its ``branch_names``);
        default the branch of the best source's recorded joints, else of the
        robot's ``home``.
    by_index : bool, default=False
        Map reproduction phase to source samples by index rather than time
        (the sources were resampled by index onto a given time base).
    clearance_margin : float, optional
        With a robot, ``constraints`` with obstacles and no ``branch``:
        metres the robot's start keeps from the obstacles (default
        :data:`skillbank.robots.CLEARANCE`). A start on the recorded branch
        that comes nearer is replaced by the clear configuration at the start
        pose nearest it (``robots._start.clear_configurations``, as a plan's
        start), with a note.

    Returns
    -------
    Executable

    Raises
    ------
    ValueError
        Orientation constraints without orientation streams; a robot without
        orientation or with a pose path it cannot follow (a
        ``KinematicsError`` naming the sample); limits that need a longer
        time base than a fixed one, or that would change a non-zero boundary
        velocity.

    Examples
    --------
    >>> from skillbank import Constraints
    >>> t = np.linspace(0.0, 1.0, 5)
    >>> src = Demonstration(t, {"position": np.c_[t, t], "gripper": [0, 0, 1, 1, 1]})
    >>> res = make_executable(src.select(["position"]), [src], Constraints(), limits={"velocity": 0.5})
    >>> res.time_scale > 2.8, res.trajectory["gripper"].ravel().tolist()
    (True, [0.0, 0.0, 1.0, 1.0, 1.0])
    """
    limits = check_limits(limits)
    if time_law not in TIME_LAWS:
        raise ValueError(f"time_law: expected one of {list(TIME_LAWS)}, got {time_law!r}")
    model = None if robot is None else _robot(robot)
    if model is not None:
        limits, limit_notes = robot_limits(model, limits)
        if branch is not None:
            model.branch_index(branch)  # an unknown name fails before the work, listing the names
    elif branch is not None:
        raise ValueError(f"branch: an inverse-kinematics branch needs a robot, got branch={branch!r} and no "
                         "robot (give robot='ur5e' / --robot ur5e)")
    sources = list(sources)
    ids = list(range(len(sources))) if ids is None else list(ids)
    t = out.t.copy()
    n = t.shape[0]
    u = (t - t[0]) / (t[-1] - t[0]) if n > 1 else np.zeros(1)
    times = [_source_times(s, u, by_index) for s in sources]
    streams = {"position": out["position"]}
    notes = [] if model is None else list(limit_notes)
    with numerical_errors("reuse (orientation)"):
        have = [k for k, s in enumerate(sources) if "orientation" in s.streams]
        orientation, error = None, 0.0
        if constraints.has_orientation and not have:
            names = sorted({name for s in sources for name in s.streams})
            raise ValueError(f"constraints: orientation constraints need an 'orientation' stream, and "
                             f"{kind}(s) {ids} have none (streams {names})")
        if have:
            mean = _mean_orientation([slerp(sources[k].t, sources[k]["orientation"], times[k]) for k in have])
            edited = edit_orientation(mean, constraints, t=t if n > 1 else None)
            orientation, error = edited.q, edited.orientation_error
            streams["orientation"] = orientation
            if len(have) > 1:
                notes.append(f"orientation: tangent-space mean of {kind}s {[ids[k] for k in have]}")
    best, label = sources[0], f"{kind} {ids[0]}"
    for name in best.stream_names:
        if name in ("position", "orientation"):
            continue
        if name == "joints":
            if robot is None:
                notes.append(f"joints: the recorded joints of {label} were dropped (they no longer match "
                             "the adapted pose; pass a robot for joints by inverse kinematics)")
            continue
        if name in DERIVED_STREAMS:
            # derivatives of the recorded path describe the demonstration, not the adapted path
            notes.append(f"{name}: the recorded {name} of {label} was dropped (a derivative of the "
                         "demonstrated path; differentiate the result's position for the new one)")
            continue
        streams[name], note = _carry(best, times[0], name, label)
        notes.append(note)
    metadata = dict(out.metadata)
    # the point the result's poses are of: the robot's tool once converted, else the sources' own point
    points = {s.metadata.get(POSE_OF) for s in sources}
    if model is not None:
        metadata[POSE_OF] = tool_point(model)
    elif len(points) == 1 and None not in points:
        metadata[POSE_OF] = points.pop()
    if model is not None:
        with numerical_errors(f"reuse ({model.name} inverse kinematics)"):
            streams["joints"] = _joints(model, streams["position"], orientation, best, float(times[0][0]),
                                        branch)
            if branch is None and constraints.obstacles and model.bodies:
                margin = CLEARANCE if clearance_margin is None else clearance_margin
                streams["joints"], note = _clear_start(model, streams["position"], orientation,
                                                       streams["joints"], list(constraints.obstacles), margin)
                if note:
                    notes.append(note)
        metadata["joint_names"] = list(model.joint_names)
        metadata["robot"] = model.name
    demo = Demonstration(t, streams, metadata)
    scale = 1.0
    if limits and n > 1:
        with numerical_errors("reuse (time scaling)"):
            scale, key = _scale_needed(demo, limits)
        law = "as given"  # the time base met every limit
        if scale > 1.0:
            _check_stretch(constraints, fixed_time, scale, t, key, limits[key])
            demo, scale, law, note = timed_to_limits(demo, limits, scale, key, model, time_law)
            notes.append(note)
        demo.metadata["timing"] = {"law": law, "limits": {k: _plain(v) for k, v in limits.items()}}
    with numerical_errors("reuse (peak rates)"):
        peaks = peak_rates(demo)
    demo.metadata["time_scale"] = scale
    return Executable(trajectory=demo, orientation_error=error, peaks=peaks, time_scale=scale, notes=notes)
