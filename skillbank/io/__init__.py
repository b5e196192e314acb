"""Reading and writing demonstrations.

Readers for the robot multi-stream HDF5 recordings, handwriting HDF5 files,
the RAIL benchmark (MATLAB v5) and the LASA dataset; what labs record: ROS 1
and ROS 2 bags and MCAP files (:func:`read_rosbag`, extra ``skillbank[ros]``),
LeRobot datasets (:func:`read_lerobot`, extra ``skillbank[lerobot]``) and
robomimic HDF5 files (:func:`read_robomimic`), robosuite's raw collection format (states replayed in
robosuite, :func:`read_robosuite_raw`); generic CSV and NPZ readers and
writers; JSON output for results; and format detection with :func:`load` /
:func:`load_all`. Every reading problem raises
:class:`FormatError`, a :class:`ValueError` with a one-line message
``cannot read '<path>': <reason>``. Inputs must be regular files (or folders
of them; :func:`check_input_file`), and nothing outside the folder a reader
was pointed at is read; outputs are written whole or not at all
(:func:`atomic_output`).

Examples
--------
>>> from skillbank.io import load, detect_format
>>> demo = load("seed/three_button_pressing_demo.h5")  # doctest: +SKIP
>>> demo.stream_names  # doctest: +SKIP
['joints', 'position', 'orientation', 'force', 'torque', 'gripper']
"""

from ._arms import ARM_INDEX, arm_count, arm_of, split_arms
from ._confine import atomic_output, check_input_file, check_output_path
from ._detect import detect_format, load, load_all
from ._errors import FormatError
from ._folders import load_folder, load_positions
from ._handwriting_h5 import read_handwriting_h5
from ._lasa import lasa_shapes, load_lasa
from ._lerobot import read_lerobot, select_episodes
from ._rail import load_rail, read_rail_file
from ._robomimic import ROBOSUITE_POSE_OF, read_robomimic
from ._robosuite_raw import (
    import_robosuite,
    read_robosuite_raw,
    reported_body,
    robosuite_objects,
    with_object_poses,
)
from ._robot_h5 import read_robot_h5
from ._ros import read_rosbag
from ._ros_messages import parse_topics
from ._tabular import (
    read_csv,
    read_feature_matrix,
    read_npz,
    to_jsonable,
    write_csv,
    write_json,
    write_npz,
)
from ._trajectory_export import TRAJECTORY_FORMATS, trajectory_format, write_trajectory

__all__ = [
    "FormatError",
    "split_arms",
    "arm_count",
    "arm_of",
    "ARM_INDEX",
    "check_input_file",
    "atomic_output",
    "check_output_path",
    "read_robot_h5",
    "read_handwriting_h5",
    "read_rosbag",
    "parse_topics",
    "read_lerobot",
    "read_robomimic", "ROBOSUITE_POSE_OF", "read_robosuite_raw", "import_robosuite", "robosuite_objects",
    "with_object_poses", "reported_body",
    "select_episodes",
    "read_rail_file",
    "load_rail",
    "load_lasa",
    "lasa_shapes",
    "read_csv",
    "read_feature_matrix",
    "write_csv",
    "read_npz",
    "write_npz",
    "write_json",
    "to_jsonable",
    "detect_format",
    "load",
    "load_all",
    "load_folder",
    "load_positions",
    "write_trajectory",
    "trajectory_format",
    "TRAJECTORY_FORMATS",
]
