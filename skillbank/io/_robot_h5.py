"""Reader for multi-stream robot recordings stored as HDF5 (one group per sensor)."""

from __future__ import annotations

import numpy as np

from ..core import Demonstration
from ..core._validation import summarise
from ._errors import (
    HDF5_MAGIC,
    FormatError,
    as_file,
    check_clock,
    check_repair_time,
    expect_magic,
    reading,
    real_array,
)

__all__ = ["read_robot_h5", "ROBOT_STREAMS"]

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


def _read_stream(path, h5, name):
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
    clock = real_array(path, group[clock_name][()], f"'{group_name}/{clock_name}'")
    data = real_array(path, group[data_name][()], f"'{group_name}/{data_name}'")
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


def read_robot_h5(path, *, repair_time=None) -> Demonstration:
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

    Returns
    -------
    Demonstration
        Streams ``joints`` (unwrapped), ``position``, ``orientation``
        (quaternions as stored), ``force``, ``torque`` and ``gripper``; the
        last four only when their group exists. ``t`` starts at 0; metadata
        holds ``source``, ``format`` (``"robot-h5"``) and ``t0``, the absolute
        start time in seconds.

    Raises
    ------
    FormatError
        If the file is not HDF5, or lacks the joints or position streams, or a
        clock is malformed or does not increase (see ``repair_time``).

    Examples
    --------
    >>> demo = read_robot_h5("seed/three_button_pressing_demo.h5")  # doctest: +SKIP
    >>> demo["joints"].shape  # doctest: +SKIP
    (4099, 6)
    """
    import h5py  # slow to import; only when an HDF5 file is read

    check_repair_time(repair_time)
    p = as_file(path)
    expect_magic(p, HDF5_MAGIC, "HDF5 content")
    with reading(p, "corrupt HDF5 file"), h5py.File(p, "r") as h5:
        raw = {name: _read_stream(p, h5, name) for name in ROBOT_STREAMS}
    raw = {name: value for name, value in raw.items() if value is not None}

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
        # Joint angles are stored wrapped to (-pi, pi]; a jump of 2 pi is not motion.
        clocked[name] = (t_k, np.unwrap(data, axis=0) if name == "joints" else data)

    metadata = {"source": str(p), "format": "robot-h5", "t0": s0 + start}
    # Only the reference clock's drops change the number of samples.
    if dropped["joints"]:
        metadata["dropped_samples"] = dropped["joints"]
    with reading(p, "invalid robot recording"):
        return Demonstration.from_clocks(clocked, reference="joints", metadata=metadata)
