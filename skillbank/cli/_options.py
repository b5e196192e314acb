"""Argument syntax shared by several commands: segmentation options and task constraints.

This module only turns strings into values; what the values mean is defined
in the library (:class:`~skillbank.segmentation.MultimodalSegmenter`,
:class:`~skillbank.core.Constraints`, :func:`~skillbank.core.parse_obstacle`).
Options left out on the command line are left out of the call too, so the
library's defaults apply and are written in one place.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path

from ..core import Constraints, ViaPoint, parse_obstacle
from ._execution_options import (
    add_execution_options,
    add_export_options,
    add_robot_options,
    execution_params,
    export_params,
    robot_params,
)

__all__ = [
    "size", "margin", "ratio_or_none", "add_segmentation_options", "segmentation_params",
    "add_constraint_options", "constraints_from_args", "join_negative_values", "CONSTRAINT_OPTIONS",
    "add_repair_option", "add_reader_options", "reader_options",
    "add_pose_of_option", "show_progress", "check_folder", "EPISODES_DEFAULT", "add_verbose_option",
    "verbose_logging",
    "add_execution_options",
    "execution_params", "add_parallel_options", "add_episode_options", "parallel_params",
    "SCHEDULER_VARIABLE", "add_robot_options",
    "robot_params", "add_export_options", "export_params",
]

#: The environment variable naming a Dask scheduler for `library add` when no option says otherwise.
SCHEDULER_VARIABLE = "SKILLBANK_SCHEDULER"

#: ``--episodes`` of every command that runs robosuite episodes (``plan`` says why its default is 1).
EPISODES_DEFAULT = 10

#: Options whose values are coordinates and may start with a minus sign ("-25,3").
CONSTRAINT_OPTIONS = ("--start", "--goal", "--via", "--obstacle", "--start-velocity", "--end-velocity",
                      "--start-orientation", "--goal-orientation", "--via-orientation", "--robot-base")
_NEGATIVE_VALUE = re.compile(r"^-(\d|\.\d)[\d.eE+\-,:]*$")
_SEGMENTER_KEYS = ("window", "min_size", "threshold", "grace", "stop_ratio", "min_turn", "combine",
                  "stream_kinds", "mode", "phases")


def _size(value: str, *, zero: bool):
    value = value.strip()
    if value == "auto":
        return value
    bound = ">= 0" if zero else "> 0"
    try:
        if value.endswith("s"):
            seconds = float(value[:-1])
            if not (seconds >= 0 if zero else seconds > 0) or seconds == float("inf"):
                raise ValueError
            # Zero seconds is zero samples at any rate; other values are written the way the
            # segmenter reads them ("1.s" -> "1.0s"), and turned into samples against the data.
            return 0 if seconds == 0 else f"{seconds!r}s"
        samples = int(value)
        if not (samples >= 0 if zero else samples > 0):
            raise ValueError
        return samples
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected an integer number of samples {bound} or seconds {bound} like '0.1s', got {value!r}"
        ) from None


def size(value: str):
    """Samples (``64``) or seconds (``0.1s``), both > 0, or ``auto``.

    Seconds become samples later, against the data's sample period.

    Examples
    --------
    >>> size("64"), size("0.1s"), size("auto")
    (64, '0.1s', 'auto')
    >>> size("0s")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: expected an integer number of samples > 0 or seconds > 0 like '0.1s', got '0s'
    """
    return _size(value, zero=False)


def margin(value: str):
    """Like :func:`size` but zero is allowed: ``0`` and ``0s`` are both 0 samples.

    Examples
    --------
    >>> margin("0s"), margin("0"), margin("0.25s")
    (0, 0, '0.25s')
    """
    return _size(value, zero=True)


def ratio_or_none(value: str):
    """A number, or ``none`` to switch the stop-or-turn gate off."""
    if value.strip().lower() == "none":
        return None
    try:
        return float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 1] or 'none', got {value!r}") from None


def show_progress(args) -> bool:
    """Progress bars for a person watching: on a terminal, and not under ``--json``."""
    return not getattr(args, "json", False) and sys.stderr.isatty()


def check_folder(path, name: str) -> None:
    """An output's folder must exist: found before the work, not after part of it is written."""
    if path is not None and not Path(path).parent.is_dir():
        raise ValueError(f"{name}: expected a file in an existing folder, got {str(path)!r}, whose folder "
                         f"{str(Path(path).parent)!r} does not exist")


def _workers(value: str) -> int:
    try:
        number = int(value)
        if number < 0:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {value!r}") from None
    return number


def add_parallel_options(p, *, work: str = "read and segment",
                         here: str = "writing here (with --keep-going, in transactions of 50 demonstrations)",
                         there: str = "whose workers must see the files",
                         doc: str = "docs/scaling.md"):
    """``--workers`` and ``--scheduler``: do ``work`` on a Dask cluster (see :func:`parallel_params`).

    ``here`` says what this process does meanwhile, ``there`` what an
    existing cluster needs, ``doc`` where the options are explained: the
    one wording of the options for every command that has them.
    """
    g = p.add_argument_group(f"parallel, on Dask (pip install 'skillbank[dask]'; see {doc})")
    g.add_argument("--workers", type=_workers, default=None, metavar="N",
                   help=f"{work} on a new local Dask cluster of N worker processes (at most 2 per core, or "
                        f"$SKILLBANK_MAX_WORKERS), {here}; 0: in this process, ignoring "
                        f"${SCHEDULER_VARIABLE}")
    g.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help=f"{work} on an existing Dask cluster, {there} (default: ${SCHEDULER_VARIABLE} when "
                        "set and --workers is not given)")
    return g


def add_episode_options(p) -> None:
    """``--workers``, ``--scheduler`` and ``-v``: robosuite episodes in parallel, as a parallel add's files.

    Each episode builds its own environment from its seed, so the report is
    the one a run in this process gives, episode for episode, in seed order.
    """
    g = add_parallel_options(p, work="run the episodes",
                             here="each in its own environment from its seed; the report is the one this "
                                  "process gives, in seed order",
                             there="whose workers have skillbank[sim] installed", doc="docs/simulation.md")
    add_verbose_option(g)


def add_verbose_option(p) -> None:
    """``-v``: the log lines of robosuite, MuJoCo and Dask on stderr (:func:`verbose_logging`)."""
    p.add_argument("-v", "--verbose", action="store_true",
                   help="let robosuite's, MuJoCo's and Dask's log lines through, on stderr (off by default, "
                        "in Dask's workers too)")


def verbose_logging(args) -> None:
    """With ``-v``, the root logger at INFO: robosuite's own logger then stays on when it is imported
    (``io.import_robosuite`` turns it off otherwise), and its console handler writes to stderr."""
    if getattr(args, "verbose", False):
        import logging  # the standard library, only when asked

        root = logging.getLogger()
        root.setLevel(min(root.level or logging.INFO, logging.INFO))


def parallel_params(args, environ=None) -> dict:
    """``workers`` and ``scheduler`` keyword arguments from :func:`add_parallel_options`' options.

    Examples
    --------
    >>> import argparse
    >>> parallel_params(argparse.Namespace(workers=None, scheduler=None), {"SKILLBANK_SCHEDULER": "tcp://h:8786"})
    {'workers': None, 'scheduler': 'tcp://h:8786'}
    >>> parallel_params(argparse.Namespace(workers=0, scheduler=None), {"SKILLBANK_SCHEDULER": "tcp://h:8786"})
    {'workers': None, 'scheduler': None}
    """
    environ = os.environ if environ is None else environ
    workers, scheduler = args.workers, args.scheduler
    if workers == 0:
        if scheduler is not None:
            raise ValueError(f"workers: --workers 0 works in this process, --scheduler on a cluster: give "
                             f"one, got --workers 0 and --scheduler {scheduler!r}")
        return {"workers": None, "scheduler": None}
    if workers is None and scheduler is None:
        scheduler = environ.get(SCHEDULER_VARIABLE, "").strip() or None
    return {"workers": workers, "scheduler": scheduler}


def join_negative_values(argv, options=CONSTRAINT_OPTIONS) -> list:
    """Write ``--start -25,3`` as ``--start=-25,3`` so that argparse takes the value, not an option.

    argparse reads a token starting with ``-`` as an option unless it looks
    like one plain negative number; coordinates like ``-25,3`` do not.

    Examples
    --------
    >>> join_negative_values(["edit", "a.csv", "--goal", "-1,2", "--json"])
    ['edit', 'a.csv', '--goal=-1,2', '--json']
    """
    argv = list(argv)
    out, i = [], 0
    while i < len(argv):
        token = argv[i]
        if token in options and i + 1 < len(argv) and _NEGATIVE_VALUE.match(argv[i + 1]):
            out.append(f"{token}={argv[i + 1]}")
            i += 2
            continue
        out.append(token)
        i += 1
    return out


def add_repair_option(p) -> None:
    """``--repair-time drop``: the documented repair of repeated time stamps (see skillbank.io.load_all)."""
    p.add_argument("--repair-time", choices=["drop"], default=None,
                   help="time stamps that repeat are an error naming the stream and sample; 'drop' drops "
                        "the repeating samples (keeping the first) and records how many in the metadata")


#: ``--pose-of``'s help: the one text for every command that reads demonstrations.
POSE_OF_HELP = ("which point of the robot the file's poses are of, where the file does not say (a UR "
                "recording's transform is the flange's, robosuite's the gripper's grip site): 'flange', a "
                "gripper's TCP "
                "(robotiq_2f85, panda_hand or GRIPPER:tcp), its grip site (GRIPPER:grip_site), or an offset "
                "X,Y,Z[,QX,QY,QZ,QW] in the flange frame (metres); stored with each demonstration, and "
                "converted to the robot's tool by --robot (reuse, edit, plan)")


def add_pose_of_option(p) -> None:
    """``--pose-of``: the point of the robot the poses of the files read are of."""
    p.add_argument("--pose-of", default=None, metavar="POINT", help=POSE_OF_HELP)


def add_reader_options(p) -> None:
    """Options of the recording readers (ROS bags, MCAP, LeRobot, robomimic); other formats ignore them.

    With them ``--pose-of``, which every format takes.
    """
    add_pose_of_option(p)
    g = p.add_argument_group("recordings (ROS 1/2 bags, MCAP, LeRobot, robomimic)")
    g.add_argument("--topic", action="append", default=None, metavar="TOPIC=STREAM", dest="topics",
                   help="read TOPIC as STREAM (repeatable): joints, pose (position + orientation), wrench "
                        "(force + torque), gripper, or any other name for a stream of that name; default: "
                        "by message type")
    g.add_argument("--reference", default=None, metavar="STREAM",
                   help="the stream whose clock is the time base (default: joints, else the busiest topic)")
    g.add_argument("--rate", type=float, default=None, metavar="HZ",
                   help="resample every stream at this rate instead of the reference stream's clock (at "
                        "most 10^7 samples; the variable SKILLBANK_MAX_SAMPLES sets another bound)")
    g.add_argument("--max-gap", type=float, default=None, metavar="SECONDS",
                   help="a stamped topic silent longer than this is an error (default 0.5 s)")
    g.add_argument("--parent-frame", default=None, help="with /tf: the parent frame of the pose")
    g.add_argument("--child-frame", default=None, help="with /tf: the child frame of the pose")
    g.add_argument("--split", default=None, metavar="HOW",
                   help="several demonstrations in one bag: 'gaps', a marker topic '/name', or time ranges "
                        "'0:12.5,20:31' in seconds")
    g.add_argument("--episodes", default=None, metavar="SELECTION",
                   help="LeRobot / robomimic episodes to read: '0:100' or '3,7' (default: all)")
    g.add_argument("--feature", action="append", default=None, metavar="FEATURE[=STREAM]", dest="features",
                   help="LeRobot: read only these features (repeatable), each as the stream STREAM if given "
                        "(a library needs a 'position' stream: --feature observation.state=position)")


def reader_options(args) -> dict:
    """The reader options given on the command line, for :func:`skillbank.io.load_all`."""
    names = ("topics", "reference", "rate", "max_gap", "parent_frame", "child_frame", "split", "episodes",
             "features", "pose_of")
    return {name: getattr(args, name) for name in names if getattr(args, name, None) is not None}


def add_segmentation_options(p) -> None:
    """Input selection and :class:`~skillbank.segmentation.MultimodalSegmenter` parameters."""
    keep = argparse.SUPPRESS  # an option not given is not passed: the segmenter's default applies
    add_repair_option(p)
    p.add_argument("--demo", type=int, default=None,
                   help="which demonstration of a multi-demonstration file (RAIL .mat, handwriting .h5), "
                        "from 0; negative counts from the end")
    p.add_argument("--group", default="normalized", help="group inside handwriting HDF5 files")
    p.add_argument("--stream", action="append", default=None, help="stream to use (repeatable; default all)")
    p.add_argument("--window", type=size, default=keep,
                   help="sliding-window width, samples or seconds like '0.1s' (default auto: 4 %% of the "
                        "length but at most the motion's own time scale, at least 8 samples)")
    p.add_argument("--min-size", type=size, default=keep,
                   help="minimum segment length, samples or seconds like '0.5s' (default one window; two "
                        "windows with --combine product)")
    p.add_argument("--threshold", type=float, default=keep, help="minimum jerk-event prominence in (0, 1]")
    p.add_argument("--grace", type=margin, default=keep,
                   help="samples or seconds like '0.1s' ignored at each end of a stream (default one window)")
    p.add_argument("--stop-ratio", type=ratio_or_none, default=keep,
                   help="keep a changepoint where the speed drops below this fraction of the movements' "
                        "peak speed ('none': keep every jerk event, as in the paper)")
    p.add_argument("--min-turn", type=float, default=keep,
                   help="or where the direction turns by at least this many degrees")
    p.add_argument("--combine", choices=["product", "evidence"], default=keep,
                   help="evidence (default): rests, turns, contact steps and gripper switches, each kind "
                        "of stream a witness (one confident kind carries a keypoint); product: the paper's "
                        "product of every stream's jerk changepoints")
    p.add_argument("--stream-kind", action="append", default=keep, metavar="NAME=KIND", type=_stream_kind,
                   dest="stream_kinds",
                   help="treat stream NAME as KIND: motion, contact or discrete "
                        "(default by name: force, torque, wrench are contact, gripper discrete; repeatable)")
    p.add_argument("--mode", choices=["deterministic", "sampling"], default=keep,
                   help="deterministic (default): keypoints where the streams agree; sampling: the paper's "
                        "random draws, reproducible with --seed")
    p.add_argument("--no-phases", dest="phases", action="store_false", default=keep,
                   help="cut by the streams alone, also where the demonstration records a gripper and "
                        "objects (default: there, cut at its phases, a reach, a carry and a retreat per "
                        "object, and not again at the pauses inside one)")
    p.add_argument("--seed", type=int, default=None, help="random seed for --mode sampling")


def _stream_kind(text: str) -> tuple[str, str]:
    """``NAME=KIND`` of ``--stream-kind``."""
    name, sep, kind = text.partition("=")
    if not sep or not name.strip() or kind.strip() not in ("motion", "contact", "discrete"):
        raise argparse.ArgumentTypeError(
            f"expected NAME=KIND with KIND one of motion, contact, discrete, got {text!r}")
    return name.strip(), kind.strip()


def segmentation_params(args) -> dict:
    """The segmenter keyword arguments given on the command line (and the seed)."""
    params = {k: getattr(args, k) for k in _SEGMENTER_KEYS if hasattr(args, k)}
    if "stream_kinds" in params:
        params["stream_kinds"] = dict(params["stream_kinds"])
    params["random_state"] = args.seed
    return params


def add_constraint_options(p) -> None:
    """``--start``, ``--goal``, ``--via`` and ``--obstacle`` (see :func:`constraints_from_args`)."""
    p.add_argument("--start", default=None, metavar="X,Y[,Z]", help="new initial point")
    p.add_argument("--goal", default=None, metavar="X,Y[,Z]", help="new final point")
    p.add_argument("--via", action="append", default=[], metavar="PHASE:X,Y[,Z]",
                   help="via-point at a phase in [0, 1] (repeatable)")
    p.add_argument("--obstacle", action="append", default=[], metavar="sphere:X,Y,Z,R|box:...",
                   help="region to avoid: sphere:X,Y[,Z],R or box:XMIN,YMIN[,ZMIN],XMAX,YMAX[,ZMAX] "
                        "(repeatable)")
    p.add_argument("--start-orientation", default=None, metavar="QX,QY,QZ,QW",
                   help="orientation at the start: a unit quaternion, scalar-last (as ROS and scipy)")
    p.add_argument("--goal-orientation", default=None, metavar="QX,QY,QZ,QW",
                   help="orientation at the goal: a unit quaternion, scalar-last")
    p.add_argument("--via-orientation", action="append", default=[], metavar="PHASE:QX,QY,QZ,QW",
                   help="orientation at a phase in [0, 1]: a unit quaternion, scalar-last (repeatable)")


def _number(text: str, name: str, whole) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{name}: expected a number, got {text.strip()!r} in {whole!r}") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise ValueError(f"{name}: expected a finite number, got {text.strip()!r} in {whole!r}")
    return value


def _numbers(text: str, name: str, whole) -> list[float]:
    parts = text.split(",")
    if not text.strip() or any(not p.strip() for p in parts):
        raise ValueError(f"{name}: expected comma-separated numbers like '0.1,0.2,0.3', got {whole!r}")
    return [_number(p, name, whole) for p in parts]


def constraints_from_args(start=None, goal=None, via=(), obstacle=(), *, start_velocity=None,
                          end_velocity=None, start_orientation=None, goal_orientation=None,
                          via_orientation=()):
    """Build :class:`~skillbank.core.Constraints` from command-line strings.

    Parameters
    ----------
    start, goal, start_velocity, end_velocity : str, optional
        ``"X,Y[,Z...]"``.
    via : sequence of str
        ``"PHASE:X,Y[,Z...]"`` with PHASE in [0, 1].
    start_orientation, goal_orientation : str, optional
        ``"QX,QY,QZ,QW"``: a unit quaternion, scalar-last.
    via_orientation : sequence of str
        ``"PHASE:QX,QY,QZ,QW"`` with PHASE in [0, 1].
    obstacle : sequence of str
        Obstacle specs, see :func:`skillbank.core.parse_obstacle`.

    Examples
    --------
    >>> c = constraints_from_args(start="0,0", goal="1,1", via=["0.5:0.5,0.9"],
    ...                           obstacle=["sphere:0.5,0.5,0.1"])
    >>> c.n_dims, len(c.via), c.obstacles[0].radius
    (2, 1, 0.1)
    >>> constraints_from_args(via_orientation=["0.5:0,0,1,0"]).via_orientation[0].position.tolist()
    [0.0, 0.0, 1.0, 0.0]
    """
    via, obstacle, via_orientation = ([v] if isinstance(v, str) else v
                                      for v in (via, obstacle, via_orientation))
    vias = [_via(text, "via", "X,Y[,Z]") for text in via or ()]
    turns = [_via(text, "via-orientation", "QX,QY,QZ,QW") for text in via_orientation or ()]
    obstacles = [parse_obstacle(str(text)) for text in (obstacle or ())]
    given = dict(start=start, goal=goal, start_velocity=start_velocity, end_velocity=end_velocity,
                 start_orientation=start_orientation, goal_orientation=goal_orientation)
    vec = {k: None if v is None else _numbers(str(v), k, v) for k, v in given.items()}
    return Constraints(via=vias, obstacles=obstacles, via_orientation=turns, **vec)


def _via(text, name: str, coords: str) -> ViaPoint:
    """``"PHASE:V1,V2,..."`` as a ViaPoint; ``name`` and ``coords`` for the message."""
    phase, sep, values = str(text).partition(":")
    if not sep:
        raise ValueError(f"{name}: expected 'PHASE:{coords}', got {text!r}")
    return ViaPoint(_numbers(values, name, text), phase=_number(phase, f"{name} phase", text))
