"""Format detection from extension and content, and the generic ``load``/``load_all``."""

from __future__ import annotations

import inspect
from pathlib import Path

import numpy as np

from ..core import Demonstration, check_pose_of, state_pose_of
from ._errors import (
    HDF5_MAGIC,
    MAT5_MAGIC,
    ZIP_MAGICS,
    FormatError,
    as_file,
    describe_content,
    expect_magic,
    read_head,
)
from ._h5 import open_h5
from ._handwriting_h5 import HANDWRITING_GROUPS, read_handwriting_h5
from ._lerobot import LEROBOT_INFO, read_lerobot
from ._rail import read_rail_file
from ._robomimic import ROBOMIMIC_GROUP, is_robomimic, read_robomimic
from ._robosuite_raw import is_states_only, read_robosuite_raw
from ._robot_h5 import ROBOT_STREAMS, read_robot_h5
from ._ros import ROS2_METADATA, ROS_FILES, read_rosbag, ros_kind
from ._tabular import read_csv, read_npz

__all__ = ["detect_format", "load", "load_all", "FORMATS"]

FORMATS = ("robot-h5", "handwriting-h5", "robomimic-h5", "robosuite-raw", "rail-mat", "csv", "npz",
           "ros1-bag", "ros2-bag", "mcap", "lerobot")
_EXTENSIONS = {
    ".h5": "hdf5", ".hdf5": "hdf5", ".hdf": "hdf5",
    ".mat": "mat", ".npz": "npz", ".csv": "csv", ".txt": "csv",
}
# Recordings read by the optional readers, which take options of their own (load_all's reader_options).
_RECORDINGS = {"ros1-bag": read_rosbag, "ros2-bag": read_rosbag, "mcap": read_rosbag, "lerobot": read_lerobot,
               "robomimic-h5": read_robomimic, "robosuite-raw": read_robosuite_raw}


def _hdf5_kind(path) -> str:
    import h5py  # slow to import; only when an HDF5 file is read

    with open_h5(path) as h5:
        groups = sorted(k for k in h5.keys() if isinstance(h5[k], h5py.Group))
        robomimic = is_robomimic(h5)
        states_only = robomimic and is_states_only(h5)
    robot_group = ROBOT_STREAMS["joints"][0]
    if robot_group in groups:
        return "robot-h5"
    if any(g in groups for g in HANDWRITING_GROUPS):
        return "handwriting-h5"
    if states_only:  # robosuite's raw collection, or robomimic before its observations were extracted
        return "robosuite-raw"
    if robomimic:
        return "robomimic-h5"
    raise FormatError(
        path, f"expected a robot recording (group '{robot_group}'), handwriting "
        f"(groups {list(HANDWRITING_GROUPS)}) or robomimic (group '{ROBOMIMIC_GROUP}' with demo_N groups), "
        f"found groups {groups}"
    )


def _looks_like_csv(head: bytes) -> bool:
    if b"\x00" in head:
        return False
    text = head.decode("utf-8", errors="ignore").lstrip("\ufeff")
    # comment lines before the header (an export's timing) are not the table
    lines = [line for line in text.splitlines() if line.strip()]
    while lines and lines[0].startswith("#"):
        lines.pop(0)
    if not lines or "," not in lines[0]:
        return False
    if len(lines) < 2:
        return True
    # Only the first data row is checked: the head may cut the last line short.
    try:
        [float(cell) for cell in lines[1].split(",")]
    except ValueError:
        return False
    return True


def _folder_kind(path):
    """``"ros2-bag"`` or ``"lerobot"`` for a folder of either kind; None for anything but a folder."""
    try:
        p = Path(path)
    except TypeError:
        return None  # as_file names the bad argument
    if not p.is_dir():
        return None
    if (p / ROS2_METADATA).is_file():
        return ros_kind(p)  # checks the folder's files
    if (p / LEROBOT_INFO).is_file():
        return "lerobot"
    raise FormatError(p, f"expected a file, found a directory that is neither a ROS 2 bag (no "
                      f"{ROS2_METADATA}) nor a LeRobot dataset (no {LEROBOT_INFO})")


def detect_format(path) -> str:
    """Name the format of a demonstration file, from its extension and content.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    str
        One of ``"robot-h5"``, ``"handwriting-h5"``, ``"robomimic-h5"``,
        ``"robosuite-raw"`` (states without observations: robosuite's raw
        collection; all ``.h5``/``.hdf5``, told apart by their groups), ``"rail-mat"``
        (``.mat``), ``"csv"`` (``.csv``/``.txt``), ``"npz"``, ``"ros1-bag"``
        (``.bag``), ``"ros2-bag"`` (a folder with ``metadata.yaml``, or a
        ``.db3`` file), ``"mcap"`` (``.mcap``) or ``"lerobot"`` (a folder with
        ``meta/info.json``).

    Raises
    ------
    FormatError
        If the file is missing, a folder of neither kind, the extension is
        unknown, or the content does not match the extension.

    Examples
    --------
    >>> detect_format("seed/r_shape.h5")  # doctest: +SKIP
    'handwriting-h5'
    """
    folder = _folder_kind(path)
    if folder is not None:
        return folder
    p = as_file(path)
    if p.suffix.lower() in ROS_FILES:
        return ros_kind(p)
    kind = _EXTENSIONS.get(p.suffix.lower())
    if kind is None:
        known = ", ".join(sorted(_EXTENSIONS))
        raise FormatError(p, f"unknown extension {p.suffix or '(none)'!r}: expected one of {known}, a "
                          f"recording ({', '.join(ROS_FILES)}) or a folder (ROS 2 bag, LeRobot dataset)")
    if kind == "hdf5":
        expect_magic(p, HDF5_MAGIC, "HDF5 content")
        return _hdf5_kind(p)
    if kind == "mat":
        expect_magic(p, MAT5_MAGIC, "a MATLAB 5.0 file")
        return "rail-mat"
    if kind == "npz":
        expect_magic(p, ZIP_MAGICS, "an NPZ (zip) archive")
        return "npz"
    head = read_head(p)
    if not _looks_like_csv(head):
        raise FormatError(
            p, f"expected a comma-separated numeric table with a header, found {describe_content(head)}"
        )
    return "csv"


def _recording_options(fmt: str, reader_options) -> dict:
    """The keyword arguments of ``reader_options`` that the reader of ``fmt`` takes."""
    options = dict(reader_options or {})
    taken = {kind: set(inspect.signature(read).parameters) - {"path"} for kind, read in _RECORDINGS.items()}
    known = set().union(*taken.values())
    unknown = sorted(k for k in options if k not in known)
    if unknown:
        raise ValueError(f"reader_options: expected names among {sorted(known)}, got unknown {unknown}")
    return {k: v for k, v in options.items() if k in taken.get(fmt, ())}


def load_all(path, *, group: str = "normalized", repair_time=None,
             reader_options=None) -> list[Demonstration]:
    """Read every demonstration in a file of any supported format.

    Parameters
    ----------
    path : str or path-like
        A file, or a folder holding a ROS 2 bag or a LeRobot dataset.
    group : str, default="normalized"
        For handwriting HDF5 files, which group to read.
    repair_time : {None, "drop"}, default=None
        Time stamps that repeat are an error naming the stream and the sample;
        ``"drop"`` drops the repeating samples instead (keeping the first) and
        records ``metadata["dropped_samples"]``. Passed to the robot HDF5,
        handwriting HDF5, RAIL and ROS bag readers; CSV and NPZ files must be clean.
    reader_options : mapping, optional
        Options for the recording readers (:func:`read_rosbag`,
        :func:`read_lerobot`, :func:`read_robomimic`), for example
        ``{"topics": ["/joint_states=joints"], "episodes": "0:10"}``. Each
        reader takes the ones it knows, so one set serves a mixed list of
        files; a name no reader knows is a ValueError. ``"pose_of"`` (every
        format) says which point of the robot the poses are of where the
        file does not (``metadata["pose_of"]``; see
        :func:`skillbank.core.check_pose_of`); a file that states another
        point is an error.

    Returns
    -------
    list of Demonstration

    Raises
    ------
    FormatError
        If the format is not recognised or the file is unreadable.

    Examples
    --------
    >>> len(load_all("seed/r_shape.h5", group="smoothed"))  # doctest: +SKIP
    5
    """
    options = dict(reader_options or {})
    # every format: which point of the robot the poses are of, where the file does not say
    pose_of = options.pop("pose_of", None)
    if pose_of is not None:
        check_pose_of(pose_of)  # a malformed point fails before the file is read
    fmt = detect_format(path)
    options = _recording_options(fmt, options)
    if fmt in _RECORDINGS:
        if fmt not in ("lerobot", "robomimic-h5", "robosuite-raw"):  # the bag reader checks its clocks too
            options.setdefault("repair_time", repair_time)
        demos = _RECORDINGS[fmt](path, **options)
    elif fmt == "robot-h5":
        demos = [read_robot_h5(path, repair_time=repair_time)]
    elif fmt == "handwriting-h5":
        demos = read_handwriting_h5(path, group=group, repair_time=repair_time)
    elif fmt == "rail-mat":
        demos = read_rail_file(path, repair_time=repair_time)
    elif fmt == "npz":
        demos = [read_npz(path)]
    else:
        demos = [read_csv(path)]
    return state_pose_of(demos, pose_of, source=str(path))


def load(path, *, index=None, group: str = "normalized", repair_time=None,
         reader_options=None) -> Demonstration:
    """Read one demonstration from a file of any supported format.

    Parameters
    ----------
    path : str or path-like
    index : int, optional
        Which demonstration in a multi-demonstration file (RAIL, handwriting,
        a split bag, a LeRobot or robomimic dataset);
        default 0. Negative values count from the end.
    group : str, default="normalized"
        For handwriting HDF5 files, which group to read.
    repair_time : {None, "drop"}, default=None
        See :func:`load_all`.
    reader_options : mapping, optional
        See :func:`load_all`.

    Returns
    -------
    Demonstration

    Raises
    ------
    FormatError
        If the file is unreadable or ``index`` is out of range (the message
        says how many demonstrations the file holds).

    Examples
    --------
    >>> load("rail/REACHING/1.mat", index=2).metadata["index"]  # doctest: +SKIP
    2
    """
    demos = load_all(path, group=group, repair_time=repair_time, reader_options=reader_options)
    if index is None:
        return demos[0]
    n = len(demos)
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
        raise FormatError(path, f"expected an integer index, got {index!r}")
    if not -n <= index < n:
        plural = "demonstration" if n == 1 else "demonstrations"
        raise FormatError(path, f"index {index} is out of range: the file holds {n} {plural} (0..{n - 1})")
    return demos[int(index)]
