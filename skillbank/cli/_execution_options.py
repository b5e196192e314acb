"""Options of the commands that make executable output: duration, robot, branch, limits, export.

``library reuse`` and ``edit`` take all of them (:func:`add_execution_options`),
``plan`` the robot and export options. Values are checked here, before any
work, with the library's own checks.
"""

from __future__ import annotations

import math

__all__ = ["add_robot_options", "add_export_options", "add_execution_options", "robot_params",
           "execution_params", "export_params", "add_tool_frame_option", "cli_robot", "ROBOT_HELP"]

#: What ``--robot`` takes, for every command's help.
ROBOT_HELP = ("a registered robot (ur5e, with its Robotiq 2F-85; panda; in any case: UR5e, Panda) or a "
              "URDF / MJCF description file (docs/robots.md)")


def add_tool_frame_option(p) -> None:
    """``--tool-frame LINK`` (the flange of a robot read from a description file), ``--tool`` and
    ``--robot-base``."""
    p.add_argument("--tool-frame", default=None, metavar="LINK",
                   help="with --robot FILE: the link (or site) of the description that is the tool frame "
                        "(default: the last link of its longest chain of joints)")
    p.add_argument("--tool", default=None, metavar="tcp|flange|GRIPPER|X,Y,Z",
                   help="the point of the robot the poses are of: 'tcp' the mounted gripper's tool centre "
                        "point (where its closed fingertips meet), 'flange', a gripper's name (its TCP), or "
                        "an offset in the flange frame (metres); default: the robot's own (the UR5e's "
                        "2F-85 TCP; the Panda's robosuite grip site, 9 mm above its fingertips)")
    p.add_argument("--robot-base", default=None, metavar="X,Y,Z[,QX,QY,QZ,QW]",
                   help="where the robot's base stands in the frame of the poses (metres, and a "
                        "scalar-last quaternion; default: the poses are in the base frame)")


def robot_base(text):
    """``--robot-base``: ``X,Y,Z`` or ``X,Y,Z,QX,QY,QZ,QW`` as a 4 x 4 transform (None: not given).

    Examples
    --------
    >>> robot_base("0.5,0,0.9")[:3, 3].tolist()
    [0.5, 0.0, 0.9]
    """
    if text is None:
        return None
    import numpy as np  # core dependency, when a base is given

    from ..core._rotations import check_quaternions, quaternion_to_matrix  # numpy only
    from ._options import _numbers  # the one parser of comma-separated numbers

    values = _numbers(text, "robot-base", text)
    if len(values) not in (3, 7):
        raise ValueError(f"robot-base: expected X,Y,Z or X,Y,Z,QX,QY,QZ,QW, got {len(values)} numbers in "
                         f"{text!r}")
    T = np.eye(4)
    T[:3, 3] = values[:3]
    if len(values) == 7:
        T[:3, :3] = quaternion_to_matrix(check_quaternions(values[3:], name="robot-base quaternion"))
    return T


def robot_tool(text):
    """``--tool``: a name the robot model takes (``tcp``, ``flange``, a gripper's) or ``X,Y,Z`` as a 4 x 4
    translation in the flange frame (None: not given).

    Examples
    --------
    >>> robot_tool("0,0,0.1")[:3, 3].tolist()
    [0.0, 0.0, 0.1]
    >>> robot_tool("tcp")
    'tcp'
    >>> robot_tool("robotiq_2f85")
    'robotiq_2f85'
    """
    if text is None:
        return None
    if "," not in text:
        # a name (gripper names may hold digits): the model checks it against its gripper and GRIPPERS
        return text
    import numpy as np  # core dependency, when an offset is given

    from ._options import _numbers  # the one parser of comma-separated numbers

    values = _numbers(text, "tool", text)
    if len(values) != 3:
        raise ValueError(f"tool: expected 'tcp', 'flange', a gripper's name or X,Y,Z in the flange frame "
                         f"(metres), got {len(values)} numbers in {text!r}")
    T = np.eye(4)
    T[:3, 3] = values
    return T


def cli_robot(args):
    """The model of ``--robot`` (a name or a description file) and ``--tool-frame``, built once per command.

    None without ``--robot``. Built on first use and kept on ``args``: a description is compiled once.
    """
    name = getattr(args, "robot", None)
    tool_frame = getattr(args, "tool_frame", None)
    if name is None:
        if tool_frame is not None:
            raise ValueError("tool-frame: --tool-frame names a link of a robot's description: give --robot "
                             "FILE too")
        if getattr(args, "robot_base", None) is not None:
            raise ValueError("robot-base: --robot-base places a robot: give --robot too")
        if getattr(args, "tool", None) is not None:
            raise ValueError("tool: --tool names a point of a robot: give --robot too")
        return None
    model = getattr(args, "_robot_model", None)
    if model is None:
        from ..robots import robot_model  # numpy only (mujoco when a description file is read)

        base = robot_base(getattr(args, "robot_base", None))
        model = robot_model(str(name), tool_frame=tool_frame, base=base,
                            tool=robot_tool(getattr(args, "tool", None)))
        args._robot_model = model
    return model


def add_robot_options(p, *, what: str = "the whole result") -> None:
    """``--robot``, ``--max-joint-velocity``, ``--max-joint-acceleration``, ``--branch``.

    See :func:`robot_params`.
    """
    p.add_argument("--robot", default=None, metavar="NAME|FILE",
                   help="add a 'joints' stream by inverse kinematics for this robot, from the pose path "
                        f"(metres, quaternions, in the robot's base frame): {ROBOT_HELP}; the robot's own "
                        "joint velocity and acceleration limits always apply")
    add_tool_frame_option(p)
    p.add_argument("--max-joint-velocity", type=float, default=None, metavar="RAD_PER_S",
                   help=f"re-time {what} until no joint moves faster (needs --robot; the robot's own "
                        "limit where it is lower; docs/robots.md, 'Time law')")
    p.add_argument("--max-joint-acceleration", type=float, default=None, metavar="RAD_PER_S2",
                   help=f"re-time {what} until no joint accelerates faster (needs --robot; the robot's own "
                        "limit where it is lower; docs/robots.md, 'Time law')")
    p.add_argument("--branch", default=None, metavar="NAME",
                   help="the inverse-kinematics branch to follow, e.g. shoulder-left/elbow-up/wrist-up "
                        "(needs --robot; default: the branch of the recorded joints, else of the robot's "
                        "home pose; docs/robots.md names them)")


def add_export_options(p) -> None:
    """``--control-rate`` (URScript) and the ROS 2 bag's topics (see :func:`export_params`)."""
    from ..io._trajectory_export import ROS_TOPICS  # the writers' defaults, written in one place

    p.add_argument("--control-rate", type=float, default=None, metavar="HZ",
                   help="URScript: servoj steps per second, 1 to 500 (default 125, the CB3's rate; the "
                        "e-Series runs at 500); duration x rate steps, at most 2^21 unless "
                        "SKILLBANK_MAX_EXPORT_SAMPLES says more")
    for key, what in (("joint", "the JointTrajectory"), ("pose", "the PoseStamped poses"),
                      ("gripper", "the gripper's JointState")):
        p.add_argument(f"--{key}-topic", default=None, metavar="TOPIC",
                       help=f"ROS 2 bag: the topic of {what} (default {ROS_TOPICS[key]})")


def add_execution_options(p) -> None:
    """``--duration``, the robot options, ``--format`` and the export options (:func:`execution_params`)."""
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS",
                   help="duration of the result (default: the demonstrations' mean); time starts at 0; one "
                        "too short for the limits is stretched to the shortest that meets them, with a note")
    add_robot_options(p)
    p.add_argument("--format", choices=["csv", "npz", "urscript", "rosbag"], default=None,
                   help="format of --out (default from its suffix: .csv, .npz, .script, .bag): every "
                        "stream with the joint names (csv, npz), a UR program of servoj steps (urscript), or "
                        "a ROS 2 bag folder of a JointTrajectory, PoseStamped poses and the gripper's "
                        "JointState (rosbag, needs skillbank[ros])")
    add_export_options(p)
    from ._world import add_world_options  # the world options live beside the simulation's report

    add_world_options(p)


def robot_params(args) -> dict:
    """``robot``, ``limits`` and ``branch`` from :func:`add_robot_options`' options, checked before the work.

    Examples
    --------
    >>> import argparse
    >>> robot_params(argparse.Namespace(robot="ur5e", max_joint_velocity=1.0, max_joint_acceleration=None,
    ...                                 branch=None))
    {'robot': UR5e(), 'limits': {'joint_velocity': 1.0}, 'branch': None}
    """
    from ..core._validation import check_positive  # numpy only

    limits = {}
    for key, option in (("joint_velocity", "max-joint-velocity"),
                        ("joint_acceleration", "max-joint-acceleration")):
        value = getattr(args, f"max_{key}", None)
        if value is None:
            continue
        if args.robot is None:
            raise ValueError(f"{option}: a joint {key.split('_')[1]} limit needs joints: give --robot too")
        limits[key] = check_positive(value, name=option)
    branch = getattr(args, "branch", None)
    if branch is not None:
        if args.robot is None:
            raise ValueError(f"branch: --branch {branch} needs joints: give --robot too")
        branch = int(branch) if branch.strip().isdigit() else branch  # an index, as the message offers
        cli_robot(args).branch_index(branch)  # an unknown name fails first, listing the names
    return {"robot": cli_robot(args), "limits": limits, "branch": branch}


def execution_params(args) -> dict:
    """``duration``, ``robot``, ``limits``, ``branch`` keyword arguments from :func:`add_execution_options`.

    Examples
    --------
    >>> import argparse
    >>> execution_params(argparse.Namespace(duration=None, robot="ur5e", max_joint_velocity=1.0))
    {'duration': None, 'robot': UR5e(), 'limits': {'joint_velocity': 1.0}, 'branch': None}
    """
    duration = args.duration
    if duration is not None:
        from ..selection._execution import check_duration  # numpy only

        duration = check_duration(duration)
    return {"duration": duration, **robot_params(args)}


def export_params(args, kind, duration=None) -> dict:
    """Keyword arguments of ``write_trajectory`` from :func:`add_export_options`' options, for ``--out``.

    Options of another format than ``kind`` are an error; with ``duration`` known, the number of servoj
    steps is checked against its bound here, before the work.
    """
    from ..io._trajectory_export import (  # the writers' checks, only when a result is written
        check_control_rate,
        check_export_samples,
        check_topic,
    )

    rate = getattr(args, "control_rate", None)
    topics = {f"{key}_topic": getattr(args, f"{key}_topic", None) for key in ("joint", "pose", "gripper")}
    topics = {key: value for key, value in topics.items() if value is not None}
    got = f"a {kind} --out" if kind else "no --out"
    if rate is not None and kind != "urscript":
        raise ValueError(f"control-rate: --control-rate is the servoj rate of a URScript export (--out "
                         f"arm.script), got {got}")
    if topics and kind != "rosbag":
        option = next(iter(topics)).replace("_", "-")
        raise ValueError(f"{option}: topics are for a ROS 2 bag export (--out folder.bag or --format "
                         f"rosbag), got {got}")
    out = {key: check_topic(value, what=key.replace("_", "-")) for key, value in topics.items()}
    if kind == "urscript":
        rate = check_control_rate(125.0 if rate is None else rate)
        out["rate"] = rate
        if duration is not None:
            check_export_samples(math.ceil(duration * rate - 1e-9) + 1,
                                 f"servoj steps ({duration:g} s at {rate:g} Hz)")
    return out
