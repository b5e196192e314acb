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
  one ``servoj`` per control period (``rate`` Hz, default 125), calling
  ``skillbank_gripper(value)`` wherever the gripper stream changes. That
  function is defined at the top of the program; its body is the
  ``gripper_command`` (default ``set_tool_digital_out(0, value > THRESHOLD)``,
  the threshold halfway between the stream's extremes): replace it with your
  gripper's call (e.g. a Robotiq URCap's ``rq_move_and_wait_norm(...)``).
- ``rosbag``: a ROS 2 bag folder (``rosbags``, extra ``skillbank[ros]``) with
  one ``trajectory_msgs/msg/JointTrajectory`` on ``/joint_trajectory`` and
  the pose path as ``geometry_msgs/msg/PoseStamped`` on ``/pose``, one per
  sample, stamped ``start_time + t``.
"""

from __future__ import annotations

import math
import os
import secrets
import shutil
from pathlib import Path

import numpy as np

from ..core import Demonstration
from ..core._validation import check_positive
from ._tabular import write_npz

__all__ = ["TRAJECTORY_FORMATS", "write_trajectory", "trajectory_format", "trajectory_columns"]

#: Export formats, as ``--format`` names them.
TRAJECTORY_FORMATS = ("csv", "npz", "urscript", "rosbag")
_SUFFIXES = {".csv": "csv", ".txt": "csv", ".npz": "npz", ".script": "urscript", ".urscript": "urscript",
             ".bag": "rosbag"}
#: The default body of ``skillbank_gripper(value)`` in URScript; ``{threshold}`` is filled in.
GRIPPER_COMMAND = "set_tool_digital_out(0, value > {threshold})"


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


def _temporary(target: Path, directory: bool = False) -> Path:
    """A fresh hidden name next to ``target`` (same file system, so the rename is atomic).

    Files are then created with the user's usual permissions (``tempfile.mkstemp`` would make them 0600).
    """
    parent = target.parent
    if not parent.is_dir():
        raise ValueError(f"out: folder {str(parent)!r} does not exist")
    tmp = parent / f".{target.name}.{secrets.token_hex(6)}.tmp"
    if directory:
        tmp.mkdir()
    return tmp


def _csv(demo: Demonstration, path: Path) -> None:
    table = np.column_stack([demo.t] + [demo.streams[s] for s in demo.streams])
    header = ",".join(["t"] + trajectory_columns(demo))
    np.savetxt(path, table, delimiter=",", header=header, comments="", fmt="%.17g")


def _held(demo: Demonstration, name: str, times: np.ndarray) -> np.ndarray:
    i = np.clip(np.searchsorted(demo.t, times, side="right") - 1, 0, demo.n_steps - 1)
    return demo[name][i, 0]


def _fmt(values) -> str:
    return "[" + ", ".join(f"{v:.9f}" for v in values) + "]"


def _urscript(demo: Demonstration, path: Path, rate: float, gripper_command: str | None, lookahead: float,
              gain: float) -> None:
    if "joints" not in demo.streams:
        raise ValueError("demo: a URScript export replays joints, and the trajectory has no 'joints' stream "
                         "(reuse or edit with robot='ur5e' / --robot ur5e)")
    Q = demo["joints"]
    if Q.shape[1] != 6:
        raise ValueError(f"demo: a UR arm has 6 joints, the 'joints' stream has {Q.shape[1]}")
    period = 1.0 / rate
    t0, duration = float(demo.t[0]), float(demo.t[-1] - demo.t[0])
    # One servoj per control period; the last holds the final configuration.
    times = t0 + np.minimum(np.arange(math.ceil(duration * rate - 1e-9) + 1) * period, duration)
    joints = np.column_stack([np.interp(times, demo.t, Q[:, j]) for j in range(6)])
    names = demo.metadata.get("joint_names") or [f"joint_{j}" for j in range(6)]
    lines = [
        f"# skillbank joint trajectory: {len(times)} servoj steps at {rate:g} Hz (t = {period:.6g} s each), "
        f"{duration:.6g} s",
        f"# joints (radians): {', '.join(names)}",
        "def skillbank_trajectory():",
    ]
    gripper = _held(demo, "gripper", times) if "gripper" in demo.streams else None
    if gripper is not None:
        g = demo["gripper"][:, 0]
        threshold = 0.5 * (float(g.min()) + float(g.max()))
        body = (gripper_command or GRIPPER_COMMAND).replace("{threshold}", f"{threshold:.9g}")
        lines += ["  # Gripper: called with the gripper stream's value wherever it changes. Replace the body",
                  "  # with your gripper's command (write_trajectory(..., gripper_command=...)).",
                  "  def skillbank_gripper(value):", f"    {body}", "  end"]
    lines.append(f"  movej({_fmt(joints[0])}, a=0.5, v=0.25)")
    last = None
    for k, q in enumerate(joints):
        if gripper is not None and gripper[k] != last:
            last = gripper[k]
            lines.append(f"  skillbank_gripper({last:.9g})")
        lines.append(f"  servoj({_fmt(q)}, t={period:.6g}, lookahead_time={lookahead:g}, gain={gain:g})")
    lines += ["  stopj(2.0)", "end", "skillbank_trajectory()", ""]
    path.write_text("\n".join(lines))


def _stamp(ns: int):
    """``(sec, nanosec)`` of integer nanoseconds."""
    return ns // 1_000_000_000, ns % 1_000_000_000


def _rosbag(demo: Demonstration, folder: Path, start_time: float, frame_id: str) -> None:
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
        if "joints" in demo.streams:
            names = list(demo.metadata.get("joint_names") or
                         [f"joint_{j}" for j in range(demo["joints"].shape[1])])
            empty, JointPoint = np.empty(0), T["trajectory_msgs/msg/JointTrajectoryPoint"]
            points = [JointPoint(positions=np.asarray(q, dtype=np.float64), velocities=empty,
                                 accelerations=empty, effort=empty,
                                 time_from_start=Duration(*_stamp(ns)))
                      for q, ns in zip(demo["joints"], offsets, strict=True)]
            msg = T["trajectory_msgs/msg/JointTrajectory"](
                header=Header(stamp=Time(*_stamp(start)), frame_id=frame_id), joint_names=names,
                points=points)
            conn = writer.add_connection("/joint_trajectory", msg.__msgtype__, typestore=ts)
            writer.write(conn, start, ts.serialize_cdr(msg, msg.__msgtype__))
        conn = writer.add_connection("/pose", PoseStamped.__msgtype__, typestore=ts)
        for p, q, ns in zip(demo["position"], demo["orientation"], offsets, strict=True):
            msg = PoseStamped(header=Header(stamp=Time(*_stamp(start + ns)), frame_id=frame_id),
                              pose=Pose(position=Point(x=float(p[0]), y=float(p[1]), z=float(p[2])),
                                        orientation=Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]),
                                                               w=float(q[3]))))
            writer.write(conn, start + ns, ts.serialize_cdr(msg, msg.__msgtype__))


def write_trajectory(demo, path, *, format=None, rate: float = 125.0, gripper_command: str | None = None,
                     lookahead_time: float = 0.1, gain: float = 300.0, start_time: float = 0.0,
                     frame_id: str = "base") -> Path:
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
        URScript: servoj steps per second (the e-Series controller runs at 500 Hz;
        125 Hz is the CB3's rate and a common choice).
    gripper_command : str, optional
        URScript: the body of ``skillbank_gripper(value)``; ``{threshold}`` is
        replaced by the midpoint of the gripper stream's range. Default
        :data:`GRIPPER_COMMAND`.
    lookahead_time, gain : float
        URScript: servoj's smoothing parameters.
    start_time : float, default=0.0
        ROS bag: seconds (since the epoch) of the first sample's stamp.
    frame_id : str, default="base"
        ROS bag: the frame of the poses (UR's controller base frame).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        For an unknown format or suffix, a missing folder, a URScript
        without a 6-joint ``joints`` stream, a bag without a pose path or
        onto an existing path; ImportError naming ``pip install
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
    rate = check_positive(rate, name="rate")
    if kind == "rosbag":
        if target.exists():
            raise ValueError(f"out: {str(target)!r} already exists; a ROS 2 bag is written to a new folder")
        tmp = _temporary(target, directory=True)
        bag = tmp / "bag"
        try:
            _rosbag(demo, bag, float(start_time), str(frame_id))
            bag.rename(target)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        return target
    tmp = _temporary(target)
    try:  # a failure leaves the target as it was
        if kind == "csv":
            _csv(demo, tmp)
        elif kind == "npz":
            write_npz(demo, tmp)
        else:
            _urscript(demo, tmp, rate, gripper_command, float(lookahead_time), float(gain))
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()
    return target
