"""Reader for multi-stream robot recordings stored as HDF5 (one group per sensor)."""

from __future__ import annotations

import numpy as np

from ..core import POSE_OF, Demonstration
from ..core._validation import summarise
from ._confine import ReadBudget
from ._errors import FormatError, as_file, check_clock, check_repair_time, reading, real_array
from ._h5 import open_h5

__all__ = ["read_robot_h5", "ROBOT_STREAMS", "UR_JOINT_NAMES", "UR_JOINT_STATES_ORDER"]

# stream name -> (group, dataset, clock dataset)
ROBOT_STREAMS = {
    "joints": ("joint_state_info", "joint_positions", "joint_time"),
    "position": ("transform_info", "transform_positions", "transform_time"),
    "orientation": ("transform_info", "transform_orientations", "transform_time"),
    "force": ("wrench_info", "wrench_force", "wrench_time"),
    "torque": ("wrench_info", "wrench_torque", "wrench_time"),
    "gripper": ("gripper_info", "gripper_position", "gripper_time"),
}
_REQUIRED = ("joints", "position")

#: A UR arm's joints in kinematic-chain order, base to flange (the order of ``skillbank.robots.UR5e``).
UR_JOINT_NAMES = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                  "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
#: The order a UR driver publishes them on ROS ``joint_states`` (alphabetical), and the recorder stores.
UR_JOINT_STATES_ORDER = tuple(sorted(UR_JOINT_NAMES))


def _read_stream(path, h5, name, budget):
    """Return (clock (n, 2), data (n, d)) for one stream, or None if its group is absent."""
    group_name, data_name, clock_name = ROBOT_STREAMS[name]
    if group_name not in h5:
        if name in _REQUIRED:
            found = summarise(map(repr, sorted(h5.keys())))
            raise FormatError(path, f"expected a group '{group_name}' (stream {name!r}), found [{found}]")
        return None
    group = h5[group_name]
    for key in (data_name, clock_name):
        if key not in group:
            found = summarise(map(repr, sorted(group.keys())))
            raise FormatError(path, f"expected a dataset '{group_name}/{key}', found [{found}]")
    clock = real_array(path, budget.dataset(group[clock_name], f"{group_name}/{clock_name}"),
                       f"'{group_name}/{clock_name}'")
    data = real_array(path, budget.dataset(group[data_name], f"{group_name}/{data_name}"),
                      f"'{group_name}/{data_name}'")
    if clock.ndim != 2 or clock.shape[1] != 2 or clock.shape[0] == 0:
        raise FormatError(
            path, f"expected '{group_name}/{clock_name}' of shape (n, 2) [seconds, nanoseconds] "
            f"with n >= 1, found shape {clock.shape}"
        )
    if data.ndim == 1:
        data = data[:, None]
    if data.ndim != 2 or data.shape[0] != clock.shape[0]:
        raise FormatError(
            path, f"expected '{group_name}/{data_name}' with {clock.shape[0]} rows to match its clock, "
            f"found shape {data.shape}"
        )
    return clock, data


def _check_joint_names(joint_names) -> list[str] | None:
    if joint_names is None:
        return None
    names = list(joint_names) if isinstance(joint_names, (list, tuple)) else None
    if not names or not all(isinstance(n, str) and n for n in names) or len(set(names)) != len(names):
        raise ValueError(f"joint_names: expected a list of distinct non-empty names, got {joint_names!r}")
    return names


def _joint_order(path, n_columns: int, names: list[str] | None) -> tuple[list[int], list[str]]:
    """The column order that puts the stored joints in chain order, and the names in that order."""
    if names is None:
        if n_columns != len(UR_JOINT_STATES_ORDER):
            return list(range(n_columns)), [f"joint_{k}" for k in range(n_columns)]
        names = list(UR_JOINT_STATES_ORDER)
    if len(names) != n_columns:
        raise FormatError(path, f"expected {len(names)} joint columns to match joint_names, found "
                          f"{n_columns} in 'joint_state_info/joint_positions'")
    if set(names) == set(UR_JOINT_NAMES):
        order = [names.index(n) for n in UR_JOINT_NAMES]
        return order, list(UR_JOINT_NAMES)
    return list(range(n_columns)), names


def read_robot_h5(path, *, repair_time=None, joint_names=None, scalar_first: bool = False) -> Demonstration:
    """Read a robot recording with one HDF5 group (and clock) per sensor.

    The groups ``joint_state_info``, ``transform_info``, ``wrench_info`` and
    ``gripper_info`` each carry their own clock of ``[seconds, nanoseconds]``
    pairs. Every stream is interpolated onto the joints' clock.

    Parameters
    ----------
    path : str or path-like
        The ``.h5`` file.
    repair_time : {None, "drop"}, default=None
        A clock whose stamps repeat, run backwards or never advance is an
        error naming the stream and the sample (no sample is lost silently).
        ``"drop"`` drops samples that repeat their clock's previous stamp
        (keeping the first) and records how many of the joints' (the time
        base's) were dropped in ``metadata["dropped_samples"]``; backwards
        or frozen clocks stay errors.
    joint_names : sequence of str, optional
        The names of the stored joint columns, in the file's order. Default:
        six columns are a UR driver's ``joint_states`` order
        (:data:`UR_JOINT_STATES_ORDER`, the layout of the three-button
        recording); any other number is named ``joint_0, joint_1, ...``.

    Returns
    -------
    Demonstration
        Streams ``joints`` (unwrapped), ``position``, ``orientation``
        (unit quaternions, scalar-last as stored, SLERP-interpolated onto the
        joints' clock, signs made continuous; ``scalar_first=True`` for files
        that store ``(w, x, y, z)``), ``force``, ``torque`` and ``gripper``; the
        last four only when their group exists. ``t`` starts at 0; metadata
        holds ``source``, ``format`` (``"robot-h5"``), ``t0``, the absolute
        start time in seconds, ``joint_names``, the names of the
        ``joints`` columns, and ``pose_of``: ``"flange"``, since the layout's
        ``transform_info`` is the pose of the flange (UR's ``tool0``).

        The joints come in kinematic-chain order (base to flange). A UR
        arm's six joints (a UR driver publishes them alphabetically: elbow,
        shoulder_lift, shoulder_pan, wrist_1, wrist_2, wrist_3) are reordered
        to ``shoulder_pan_joint, shoulder_lift_joint, elbow_joint,
        wrist_1_joint, wrist_2_joint, wrist_3_joint``, the order of
        :class:`skillbank.robots.UR5e`. Other names keep the stored order.

    Raises
    ------
    FormatError
        If the file is not HDF5, or lacks the joints or position streams, or a
        clock is malformed or does not increase (see ``repair_time``), or the
        joints do not have one column per name of ``joint_names``.

    Examples
    --------
    >>> demo = read_robot_h5("seed/three_button_pressing_demo.h5")  # doctest: +SKIP
    >>> demo["joints"].shape  # doctest: +SKIP
    (4099, 6)
    >>> demo.metadata["joint_names"][0]  # doctest: +SKIP
    'shoulder_pan_joint'
    """
    check_repair_time(repair_time)
    joint_names = _check_joint_names(joint_names)
    p = as_file(path)
    budget = ReadBudget(p)
    with open_h5(p) as h5:
        raw = {name: _read_stream(p, h5, name, budget) for name in ROBOT_STREAMS}
    raw = {name: value for name, value in raw.items() if value is not None}
    order, names = _joint_order(p, raw["joints"][1].shape[1], joint_names)
    raw["joints"] = (raw["joints"][0], raw["joints"][1][:, order])

    # Epoch seconds (~1.7e9) leave ~1e-7 s of float resolution; subtracting the
    # whole seconds first keeps the nanoseconds exact.
    s0 = float(np.floor(raw["joints"][0][0, 0]))
    clocks = {name: (clock[:, 0] - s0) + clock[:, 1] * 1e-9 for name, (clock, _) in raw.items()}
    start = float(clocks["joints"][0])

    clocked, dropped = {}, {}
    for name, (_, data) in raw.items():
        group, _, clock = ROBOT_STREAMS[name]
        t_k, data, dropped[name] = check_clock(p, clocks[name] - start, data, repair_time=repair_time,
                                               where=f"stream {name!r} (clock '{group}/{clock}')")
        if name == "orientation" and scalar_first:
            data = data[:, [1, 2, 3, 0]]  # (w, x, y, z) -> (x, y, z, w), the convention inside skillbank
        # Joint angles are stored wrapped to (-pi, pi]; a jump of 2 pi is not motion.
        clocked[name] = (t_k, np.unwrap(data, axis=0) if name == "joints" else data)

    # the layout's transform_info is the UR recorder's TF lookup of tool0, the flange (data README; forward
    # kinematics of the joints meets it within 0.8 mm): the poses say so, and no robot's TCP is assumed
    metadata = {"source": str(p), "format": "robot-h5", "t0": s0 + start, "joint_names": names,
                POSE_OF: "flange"}
    # Only the reference clock's drops change the number of samples.
    if dropped["joints"]:
        metadata["dropped_samples"] = dropped["joints"]
    with reading(p, "invalid robot recording"):
        return Demonstration.from_clocks(clocked, reference="joints", metadata=metadata)
