"""Exports of an executable reproduction that a robot stack reads: CSV, NPZ, URScript, ROS 2 bag.

Every writer is all-or-nothing: it writes a temporary file (or folder) next to
the target and renames it into place, so a failure leaves no half-written
file, and an existing target is replaced only by a complete new one (a bag
folder is never replaced).

- ``csv``: ``t`` then every stream; columns ``<stream>_<i>``, except
  ``orientation_x, _y, _z, _w`` (scalar-last) and ``joints_<joint name>``.
- ``npz``: :func:`write_npz` (every stream; metadata as JSON, with
  ``joint_names``).
- ``urscript``: a Universal Robots program that moves to the first joint
  configuration with ``movej`` and then replays the joint trajectory with
  one ``servoj`` per control period (``rate`` Hz, default 125; targets from
  :func:`blended_joints`, within the samples' joint speed and acceleration), calling
  ``skillbank_gripper(value)`` wherever the gripper stream changes. That
  function is defined at the top of the program; its body is the
  ``gripper_command`` (default ``set_tool_digital_out(0, value > THRESHOLD)``,
  the threshold halfway between the stream's extremes): replace it with your
  gripper's call (e.g. a Robotiq URCap's ``rq_move_and_wait_norm(...)``).
- ``rosbag``: a ROS 2 bag folder (``rosbags``, extra ``skillbank[ros]``) with
  one ``trajectory_msgs/msg/JointTrajectory`` on ``/joint_trajectory`` (each
  point with positions, velocities and accelerations), the pose path as
  ``geometry_msgs/msg/PoseStamped`` on ``/pose`` and the gripper stream as
  ``sensor_msgs/msg/JointState`` (one joint, ``gripper``, its value as the
  position) on ``/gripper/joint_states``, one message per sample, stamped
  ``start_time + t``. The topic names are parameters.

No export writes more than :func:`max_export_samples` samples (servoj steps
for URScript, samples otherwise), checked before anything is computed.

A trajectory timed for limits (``metadata["timing"]``: the time law and the
limits, :func:`skillbank.selection.make_executable`) states them in every
format: a comment line before the CSV header and in the URScript program's
header (:data:`TIMING_COMMENT` then JSON), the bag's ``custom_data`` under
``skillbank_timing`` (JSON), the NPZ's metadata. Its samples are within them
as these formats carry them: the CSV's finite differences, the servoj steps
(:func:`blended_joints`) and the bag's ``JointTrajectory`` velocities and
accelerations (:func:`joint_rates`); :func:`skillbank.robots.time_law` meets
both measures.
"""

from __future__ import annotations

import json
import math
import re
import secrets
import shutil
from pathlib import Path

import numpy as np

from ..core import Demonstration
from ..core._validation import check_positive, env_bound
from ._confine import atomic_output
from ._tabular import TIMING_COMMENT, write_npz

__all__ = ["TRAJECTORY_FORMATS", "write_trajectory", "trajectory_format", "trajectory_columns",
           "max_export_samples", "blended_joints", "check_export_samples", "check_control_rate",
           "check_topic", "timing_lines", "LIMIT_UNITS",
           "MAX_EXPORT_SAMPLES", "MAX_EXPORT_VARIABLE", "CONTROL_RATES", "ROS_TOPICS"]

#: Export formats, as ``--format`` names them.
TRAJECTORY_FORMATS = ("csv", "npz", "urscript", "rosbag")
_SUFFIXES = {".csv": "csv", ".txt": "csv", ".npz": "npz", ".script": "urscript", ".urscript": "urscript",
             ".bag": "rosbag"}
#: The default body of ``skillbank_gripper(value)`` in URScript; ``{threshold}`` is filled in.
GRIPPER_COMMAND = "set_tool_digital_out(0, value > {threshold})"
#: Most samples an export writes: 2^21 servoj steps are 70 min at 500 Hz (4.7 h at 125 Hz), ~270 MB of
#: URScript. A longer program is legitimate but rare: set the variable below to allow it.
MAX_EXPORT_SAMPLES = 2 ** 21
MAX_EXPORT_VARIABLE = "SKILLBANK_MAX_EXPORT_SAMPLES"
#: servoj rates accepted (Hz): the e-Series controller runs at 500 Hz, so a servoj shorter than 2 ms
#: does not exist; below 1 Hz it is no longer servoing.
CONTROL_RATES = (1.0, 500.0)
#: Default topics of a ROS 2 bag export: joint trajectory, pose path, gripper.
ROS_TOPICS = {"joint": "/joint_trajectory", "pose": "/pose", "gripper": "/gripper/joint_states"}
#: servoj's own ranges (URScript manual): lookahead_time (s) and gain.
SERVOJ_RANGES = {"lookahead_time": (0.03, 0.2), "gain": (100.0, 2000.0)}
# A ROS 2 Time's seconds are an int32: stamps end in January 2038.
_LAST_STAMP = 2 ** 31 - 1
_TOPIC = re.compile(r"^(/[A-Za-z_][A-Za-z0-9_]*)+$")
# servoj lines formatted and written per chunk, so a long program never sits in memory whole.
_CHUNK = 50_000


def max_export_samples(environ=None) -> int:
    """The bound on the samples an export writes: ``$SKILLBANK_MAX_EXPORT_SAMPLES``, else 2^21.

    Examples
    --------
    >>> max_export_samples({}), max_export_samples({"SKILLBANK_MAX_EXPORT_SAMPLES": "10000000"})
    (2097152, 10000000)
    """
    return env_bound(MAX_EXPORT_VARIABLE, MAX_EXPORT_SAMPLES, "samples", environ)


def check_export_samples(n, what: str, environ=None) -> int:
    """``n`` samples if within :func:`max_export_samples`, else a ValueError saying how to go past it.

    Examples
    --------
    >>> check_export_samples(1000, "servoj steps")
    1000
    """
    bound = max_export_samples(environ)
    if not n <= bound:  # also refuses NaN
        raise ValueError(f"out: the export would write {float(n):.4g} {what}, more than the bound of {bound} "
                         f"(set {MAX_EXPORT_VARIABLE} to a larger number to write it, or shorten the motion "
                         "or lower the rate)")
    return int(n)


def check_control_rate(rate) -> float:
    """A servoj rate in Hz within :data:`CONTROL_RATES`, else ValueError.

    Examples
    --------
    >>> check_control_rate(500)
    500.0
    """
    rate = float(check_positive(rate, name="rate"))
    low, high = CONTROL_RATES
    if not low <= rate <= high:
        raise ValueError(f"rate: expected servoj steps per second in [{low:g}, {high:g}] Hz (the e-Series "
                         f"controller runs at 500 Hz, the CB3 at 125 Hz), got {rate:g}")
    return rate


def _check_servoj(value, name: str) -> float:
    low, high = SERVOJ_RANGES[name]
    number = float(check_positive(value, name=name))
    if not low <= number <= high:
        raise ValueError(f"{name}: expected a number in [{low:g}, {high:g}] (servoj's range), got {number:g}")
    return number


def _check_start_time(start_time, duration: float) -> float:
    number = float(check_positive(start_time, name="start_time", allow_zero=True))
    if number + duration > _LAST_STAMP:
        raise ValueError(f"start_time: expected seconds since the epoch with the last stamp before 2^31 s "
                         f"(a ROS 2 Time's seconds are an int32), got {number:g} + {duration:g} s")
    return number


def check_topic(name, *, what: str = "topic") -> str:
    """A fully qualified ROS 2 topic name (``/a/b_c``: tokens of letters, digits and ``_``, not starting
    with a digit), else ValueError.

    Examples
    --------
    >>> check_topic("/arm/joint_trajectory")
    '/arm/joint_trajectory'
    """
    if not isinstance(name, str) or not _TOPIC.match(name):
        raise ValueError(f"{what}: expected a ROS 2 topic name like '/arm/joint_trajectory' (slash-separated "
                         "tokens of letters, digits and '_', none starting with a digit, no trailing slash), "
                         f"got {name!r}")
    return name


def trajectory_format(path, format=None) -> str:
    """The export format: ``format`` if given, else from the file name's suffix.

    Examples
    --------
    >>> trajectory_format("out.csv"), trajectory_format("arm.script"), trajectory_format("x", "rosbag")
    ('csv', 'urscript', 'rosbag')
    """
    if format is not None:
        if format not in TRAJECTORY_FORMATS:
            raise ValueError(f"format: expected one of {list(TRAJECTORY_FORMATS)}, got {format!r}")
        return format
    suffix = Path(path).suffix.lower()
    if suffix not in _SUFFIXES:
        raise ValueError(f"out: expected a file name ending in {', '.join(_SUFFIXES)} or a format, got "
                         f"{str(path)!r}")
    return _SUFFIXES[suffix]


def trajectory_columns(demo: Demonstration) -> list[str]:
    """CSV column names after ``t``: see the module docstring.

    Examples
    --------
    >>> q = np.tile([0.0, 0.0, 0.0, 1.0], (2, 1))
    >>> trajectory_columns(Demonstration([0.0, 1.0], {"position": np.zeros((2, 2)), "orientation": q}))
    ['position_0', 'position_1', 'orientation_x', 'orientation_y', 'orientation_z', 'orientation_w']
    """
    names = []
    joint_names = list(demo.metadata.get("joint_names") or [])
    for stream, data in demo.streams.items():
        width = data.shape[1]
        if stream == "orientation" and width == 4:
            names += [f"orientation_{c}" for c in "xyzw"]
        elif stream == "joints" and len(joint_names) == width:
            names += [f"joints_{j}" for j in joint_names]
        else:
            names += [f"{stream}_{i}" for i in range(width)]
    return names


def _temporary_folder(target: Path) -> Path:
    """A fresh hidden folder next to ``target`` (same file system, so the rename is atomic).

    Its files are created with the user's usual permissions (``tempfile.mkdtemp`` would make it 0700).
    """
    parent = target.parent
    if not parent.is_dir():
        raise ValueError(f"out: folder {str(parent)!r} does not exist")
    tmp = parent / f".{target.name}.{secrets.token_hex(6)}.tmp"
    tmp.mkdir()
    return tmp


#: Units of each kind of limit, as the timing line states them.
LIMIT_UNITS = {"velocity": "m/s", "acceleration": "m/s^2", "angular_velocity": "rad/s",
               "angular_acceleration": "rad/s^2", "joint_velocity": "rad/s per joint",
               "joint_acceleration": "rad/s^2 per joint"}


def timing_lines(demo: Demonstration) -> list[str]:
    """The comment lines stating the time law and limits a trajectory was timed for (none if untimed).

    Examples
    --------
    >>> d = Demonstration([0.0, 1.0], {"position": [[0.0], [1.0]]},
    ...                   {"timing": {"law": "toppra", "limits": {"joint_velocity": [3.1, 3.1]}}})
    >>> timing_lines(d)[0]
    '# skillbank timing: {"law": "toppra", "limits": {"joint_velocity": [3.1, 3.1]}}'
    """
    timing = demo.metadata.get("timing")
    if not isinstance(timing, dict):
        return []
    limits = timing.get("limits") or {}
    words = "; ".join(f"{key} {value} {LIMIT_UNITS.get(key, '')}".rstrip() for key, value in limits.items())
    return [TIMING_COMMENT + json.dumps(timing, sort_keys=True),
            f"# timed by the {timing.get('law')} time law within: {words or 'no limits'} (joints in the "
            "order of the joint columns)"]


def _csv(demo: Demonstration, path: Path) -> None:
    table = np.column_stack([demo.t] + [demo.streams[s] for s in demo.streams])
    header = "\n".join(timing_lines(demo) + [",".join(["t"] + trajectory_columns(demo))])
    np.savetxt(path, table, delimiter=",", header=header, comments="", fmt="%.17g")


def _held(demo: Demonstration, name: str, times: np.ndarray) -> np.ndarray:
    i = np.clip(np.searchsorted(demo.t, times, side="right") - 1, 0, demo.n_steps - 1)
    return demo[name][i, 0]


def _fmt(values) -> str:
    return "[" + ", ".join(f"{v:.9f}" for v in values) + "]"


def blended_joints(times: np.ndarray, t: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Joint targets at ``times`` whose speed and acceleration are no more than the samples'.

    Linear interpolation between samples would change velocity within one control period at every
    sample (an acceleration growing with the control rate). Instead the velocity is the piecewise-
    linear profile through each segment's mean velocity at its midpoint (held before the first and
    after the last midpoint), integrated from the first sample. Its slopes are exactly the samples'
    finite-difference accelerations (:func:`skillbank.selection.peak_rates`), so the servo steps'
    finite differences, which average it, stay within both peaks. The path passes within about
    ``h^2 a / 4`` of each sample (``h`` the sample step, ``a`` the acceleration) rather than through
    it; a linear-in-time correction of that drift makes it end exactly on the last sample.

    Examples
    --------
    >>> t = np.array([0.0, 1.0, 2.0])
    >>> blended_joints(np.array([0.0, 0.5, 1.0, 2.0]), t, np.array([[0.0], [1.0], [1.0]])).ravel().tolist()
    [0.0, 0.5, 0.875, 1.0]
    """
    if Q.shape[0] < 2:
        return np.repeat(Q[:1], len(times), axis=0)
    h = np.diff(t)
    v = np.diff(Q, axis=0) / h[:, None]
    knots = np.concatenate([[t[0]], 0.5 * (t[1:] + t[:-1]), [t[-1]]])
    w = np.vstack([v[:1], v, v[-1:]])
    dk = np.diff(knots)
    # the integral of the velocity profile at its knots, then within a piece (linear velocity)
    at_knots = np.vstack([np.zeros((1, Q.shape[1])), np.cumsum(0.5 * dk[:, None] * (w[1:] + w[:-1]), axis=0)])
    j = np.clip(np.searchsorted(knots, times, side="right") - 1, 0, len(dk) - 1)
    u = (times - knots[j])[:, None]
    p = Q[0] + at_knots[j] + u * w[j] + 0.5 * u**2 * (w[j + 1] - w[j]) / dk[j][:, None]
    drift = Q[-1] - (Q[0] + at_knots[-1])
    return p + drift * ((times - t[0]) / (t[-1] - t[0]))[:, None]


def _servo_times(demo: Demonstration, rate: float) -> tuple[int, float, float]:
    """Number of servoj steps, start and duration: one per control period, the last at the end."""
    t0, duration = float(demo.t[0]), float(demo.t[-1] - demo.t[0])
    steps = math.ceil(duration * rate - 1e-9) + 1 if math.isfinite(duration * rate) else math.inf
    return steps, t0, duration


def _urscript(demo: Demonstration, path: Path, rate: float, gripper_command: str | None, lookahead: float,
              gain: float) -> None:
    if "joints" not in demo.streams:
        raise ValueError("demo: a URScript export replays joints, and the trajectory has no 'joints' stream "
                         "(reuse or edit with robot='ur5e' / --robot ur5e)")
    robot = demo.metadata.get("robot")
    # URScript runs on Universal Robots' controllers only; their models are named UR3, UR5e, UR10, ...
    if robot is not None and not re.match(r"ur\d", str(robot), re.IGNORECASE):
        raise ValueError(f"demo: URScript runs on Universal Robots arms only, and this trajectory's joints "
                         f"are for {robot!r}: export a ROS 2 bag (--format rosbag), CSV or NPZ instead")
    Q = demo["joints"]
    if Q.shape[1] != 6:
        raise ValueError(f"demo: a UR arm has 6 joints, the 'joints' stream has {Q.shape[1]}")
    period = 1.0 / rate
    n, t0, duration = _servo_times(demo, rate)
    n = check_export_samples(n, f"servoj steps ({duration:.6g} s at {rate:g} Hz)")
    names = demo.metadata.get("joint_names") or [f"joint_{j}" for j in range(6)]
    head = [
        f"# skillbank joint trajectory: {n} servoj steps at {rate:g} Hz (t = {period:.6g} s each), "
        f"{duration:.6g} s",
        f"# joints (radians): {', '.join(names)}",
        *timing_lines(demo),
        "def skillbank_trajectory():",
    ]
    gripper = "gripper" in demo.streams
    if gripper:
        g = demo["gripper"][:, 0]
        threshold = 0.5 * (float(g.min()) + float(g.max()))
        body = (gripper_command or GRIPPER_COMMAND).replace("{threshold}", f"{threshold:.9g}")
        head += ["  # Gripper: called with the gripper stream's value wherever it changes. Replace the body",
                 "  # with your gripper's command (write_trajectory(..., gripper_command=...)).",
                 "  def skillbank_gripper(value):", f"    {body}", "  end"]
    servo = f", t={period:.6g}, lookahead_time={lookahead:g}, gain={gain:g})"
    last = None
    with open(path, "w", encoding="utf-8") as fh:
        for start in range(0, n, _CHUNK):
            k = np.arange(start, min(start + _CHUNK, n))
            # One servoj per control period; the last holds the final configuration.
            times = t0 + np.minimum(k * period, duration)
            joints = blended_joints(times, demo.t, Q)
            held = _held(demo, "gripper", times) if gripper else None
            lines = head + [f"  movej({_fmt(joints[0])}, a=0.5, v=0.25)"] if start == 0 else []
            for i, q in enumerate(joints):
                if held is not None and held[i] != last:
                    last = held[i]
                    lines.append(f"  skillbank_gripper({last:.9g})")
                lines.append(f"  servoj({_fmt(q)}{servo}")
            fh.write("\n".join(lines) + "\n")
        fh.write("\n".join(["  stopj(2.0)", "end", "skillbank_trajectory()", ""]))


def _stamp(ns: int):
    """``(sec, nanosec)`` of integer nanoseconds."""
    return ns // 1_000_000_000, ns % 1_000_000_000


def joint_rates(Q: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Velocities and accelerations of joint positions ``Q (n, n_joints)`` at times ``t``.

    Second-order finite differences on the uneven time base (first-order at the ends), the
    acceleration the derivative of the velocity: integrated with the trapezoidal rule they give the
    positions back to the truncation error of the scheme. One sample: zero rates.
    """
    if Q.shape[0] < 2:
        return np.zeros_like(Q), np.zeros_like(Q)
    V = np.gradient(Q, t, axis=0)
    return V, np.gradient(V, t, axis=0)


def _rosbag(demo: Demonstration, folder: Path, start_time: float, frame_id: str, topics: dict) -> None:
    try:
        from rosbags.rosbag2 import Writer  # optional extra skillbank[ros], imported when a bag is written
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise ImportError("writing a ROS 2 bag needs the 'rosbags' package: "
                          "pip install skillbank[ros]") from None
    if "position" not in demo.streams or "orientation" not in demo.streams:
        raise ValueError(f"demo: a ROS bag holds the pose path, and the trajectory has streams "
                         f"{demo.stream_names} (need 'position' and 'orientation')")
    if demo["position"].shape[1] != 3:
        raise ValueError(f"demo: a PoseStamped needs 3-D positions, got {demo['position'].shape[1]}-D")
    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    Time, Duration, Header = T["builtin_interfaces/msg/Time"], T["builtin_interfaces/msg/Duration"], \
        T["std_msgs/msg/Header"]
    Pose, Point, Quaternion = T["geometry_msgs/msg/Pose"], T["geometry_msgs/msg/Point"], \
        T["geometry_msgs/msg/Quaternion"]
    PoseStamped = T["geometry_msgs/msg/PoseStamped"]
    # Integer nanoseconds: an epoch time in float64 keeps only ~0.2 us.
    offsets = [int(round(float(x - demo.t[0]) * 1e9)) for x in demo.t]
    start = int(round(start_time * 1e9))
    with Writer(folder, version=8) as writer:
        if isinstance(demo.metadata.get("timing"), dict):  # the law and the limits the points were timed for
            writer.set_custom_data("skillbank_timing", json.dumps(demo.metadata["timing"], sort_keys=True))
        if "joints" in demo.streams:
            names = list(demo.metadata.get("joint_names") or
                         [f"joint_{j}" for j in range(demo["joints"].shape[1])])
            empty, JointPoint = np.empty(0), T["trajectory_msgs/msg/JointTrajectoryPoint"]
            Q = np.asarray(demo["joints"], dtype=np.float64)
            V, A = joint_rates(Q, demo.t - demo.t[0])
            points = [JointPoint(positions=q, velocities=v, accelerations=a, effort=empty,
                                 time_from_start=Duration(*_stamp(ns)))
                      for q, v, a, ns in zip(Q, V, A, offsets, strict=True)]
            msg = T["trajectory_msgs/msg/JointTrajectory"](
                header=Header(stamp=Time(*_stamp(start)), frame_id=frame_id), joint_names=names,
                points=points)
            conn = writer.add_connection(topics["joint"], msg.__msgtype__, typestore=ts)
            writer.write(conn, start, ts.serialize_cdr(msg, msg.__msgtype__))
        if "gripper" in demo.streams:
            JointState = T["sensor_msgs/msg/JointState"]
            conn = writer.add_connection(topics["gripper"], JointState.__msgtype__, typestore=ts)
            for g, ns in zip(demo["gripper"][:, 0], offsets, strict=True):
                msg = JointState(header=Header(stamp=Time(*_stamp(start + ns)), frame_id=""),
                                 name=["gripper"], position=np.array([g], dtype=np.float64), velocity=empty,
                                 effort=empty)
                writer.write(conn, start + ns, ts.serialize_cdr(msg, msg.__msgtype__))
        conn = writer.add_connection(topics["pose"], PoseStamped.__msgtype__, typestore=ts)
        for p, q, ns in zip(demo["position"], demo["orientation"], offsets, strict=True):
            msg = PoseStamped(header=Header(stamp=Time(*_stamp(start + ns)), frame_id=frame_id),
                              pose=Pose(position=Point(x=float(p[0]), y=float(p[1]), z=float(p[2])),
                                        orientation=Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]),
                                                               w=float(q[3]))))
            writer.write(conn, start + ns, ts.serialize_cdr(msg, msg.__msgtype__))


def write_trajectory(demo, path, *, format=None, rate: float = 125.0, gripper_command: str | None = None,
                     lookahead_time: float = 0.1, gain: float = 300.0, start_time: float = 0.0,
                     frame_id: str = "base", joint_topic: str = ROS_TOPICS["joint"],
                     pose_topic: str = ROS_TOPICS["pose"],
                     gripper_topic: str = ROS_TOPICS["gripper"]) -> Path:
    """Write an executable reproduction as CSV, NPZ, a URScript program or a ROS 2 bag, all or nothing.

    Parameters
    ----------
    demo : Demonstration
        A reproduction (``ReuseResult.trajectory``): ``position``, and
        ``orientation``, ``gripper``, ``joints`` where it has them.
    path : str or path-like
        The file (a folder for ``rosbag``, which must not exist yet).
    format : {"csv", "npz", "urscript", "rosbag"}, optional
        Default from the suffix (``.csv``, ``.npz``, ``.script``, ``.bag``).
    rate : float, default=125.0
        URScript: servoj steps per second, in :data:`CONTROL_RATES` (the
        e-Series controller runs at 500 Hz; 125 Hz is the CB3's rate and a
        common choice). ``duration * rate`` steps are written, at most
        :func:`max_export_samples`.
    gripper_command : str, optional
        URScript: the body of ``skillbank_gripper(value)``; ``{threshold}`` is
        replaced by the midpoint of the gripper stream's range. Default
        :data:`GRIPPER_COMMAND`.
    lookahead_time, gain : float
        URScript: servoj's smoothing parameters, within its ranges
        (:data:`SERVOJ_RANGES`: 0.03 to 0.2 s, 100 to 2000).
    start_time : float, default=0.0
        ROS bag: seconds (since the epoch) of the first sample's stamp, >= 0;
        the last stamp must come before 2^31 s (an int32 in ROS 2).
    frame_id : str, default="base"
        ROS bag: the frame of the poses (UR's controller base frame).
    joint_topic, pose_topic, gripper_topic : str
        ROS bag: the topics of the ``JointTrajectory``, the ``PoseStamped``
        poses and the gripper's ``JointState`` (fully qualified names, see
        :func:`check_topic`; default :data:`ROS_TOPICS`).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        For an unknown format or suffix, a missing folder, a URScript
        without a 6-joint ``joints`` stream, a bag without a pose path or
        onto an existing path, more samples than :func:`max_export_samples`,
        a rate outside :data:`CONTROL_RATES`, a bad or repeated topic name; ImportError naming ``pip install
        skillbank[ros]`` when ``rosbags`` is missing.

    Examples
    --------
    >>> import os, tempfile
    >>> t = np.linspace(0.0, 0.1, 3)
    >>> demo = Demonstration(t, {"position": np.zeros((3, 3)), "joints": np.zeros((3, 6)),
    ...                          "gripper": [[0.0], [1.0], [1.0]]})
    >>> path = write_trajectory(demo, os.path.join(tempfile.mkdtemp(), "arm.script"), rate=50)
    >>> lines = [line.strip() for line in path.read_text().splitlines()]
    >>> sum(line.startswith("servoj(") for line in lines), [x for x in lines if x.startswith("skillbank_g")]
    (6, ['skillbank_gripper(0)', 'skillbank_gripper(1)'])
    """
    if not isinstance(demo, Demonstration):
        raise ValueError(f"demo: expected a Demonstration, got {type(demo).__name__}")
    target = Path(path)
    kind = trajectory_format(target, format)
    rate = check_control_rate(rate)
    check_export_samples(demo.n_steps, "samples")
    if kind == "rosbag":
        topics = {"joint": check_topic(joint_topic, what="joint_topic"),
                  "pose": check_topic(pose_topic, what="pose_topic"),
                  "gripper": check_topic(gripper_topic, what="gripper_topic")}
        if len(set(topics.values())) < 3:
            raise ValueError(f"joint_topic, pose_topic, gripper_topic: expected three different topics, got "
                             f"{list(topics.values())}")
        start = _check_start_time(start_time, float(demo.t[-1] - demo.t[0]))
        if target.exists():
            raise ValueError(f"out: {str(target)!r} already exists; a ROS 2 bag is written to a new folder")
        tmp = _temporary_folder(target)
        bag = tmp / "bag"
        try:
            _rosbag(demo, bag, start, str(frame_id), topics)
            bag.rename(target)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        return target
    if kind == "urscript":  # the bound and servoj's ranges before the temporary file exists
        lookahead_time = _check_servoj(lookahead_time, "lookahead_time")
        gain = _check_servoj(gain, "gain")
        n, _, duration = _servo_times(demo, rate)
        check_export_samples(n, f"servoj steps ({duration:.6g} s at {rate:g} Hz)")
    # whole or not at all; a FIFO or a device at the target is refused, not replaced
    with atomic_output(target) as tmp:
        if kind == "csv":
            _csv(demo, tmp)
        elif kind == "npz":
            write_npz(demo, tmp)
        else:
            _urscript(demo, tmp, rate, gripper_command, lookahead_time, gain)
    return target
