"""Reader for multi-stream robot recordings stored as HDF5 (one group per sensor)."""

from __future__ import annotations

import numpy as np

from ..core import Demonstration
from ._errors import HDF5_MAGIC, FormatError, as_file, drop_repeated_times, expect_magic, reading

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
            found = sorted(h5.keys())
            raise FormatError(path, f"expected a group '{group_name}' (stream {name!r}), found {found}")
        return None
    group = h5[group_name]
    for key in (data_name, clock_name):
        if key not in group:
            raise FormatError(
                path, f"expected a dataset '{group_name}/{key}', found {sorted(group.keys())}"
            )
    clock = np.asarray(group[clock_name][()], dtype=float)
    data = np.asarray(group[data_name][()], dtype=float)
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


def read_robot_h5(path) -> Demonstration:
    """Read a robot recording with one HDF5 group (and clock) per sensor.

    The groups ``joint_state_info``, ``transform_info``, ``wrench_info`` and
    ``gripper_info`` each carry their own clock of ``[seconds, nanoseconds]``
    pairs. Every stream is interpolated onto the joints' clock.

    Parameters
    ----------
    path : str or path-like
        The ``.h5`` file.

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
        clock is malformed.

    Examples
    --------
    >>> demo = read_robot_h5("seed/three_button_pressing_demo.h5")  # doctest: +SKIP
    >>> demo["joints"].shape  # doctest: +SKIP
    (4099, 6)
    """
    import h5py  # slow to import; only when an HDF5 file is read

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
        t_k, data, dropped[name] = drop_repeated_times(clocks[name] - start, data)
        # Joint angles are stored wrapped to (-pi, pi]; a jump of 2 pi is not motion.
        clocked[name] = (t_k, np.unwrap(data, axis=0) if name == "joints" else data)

    metadata = {"source": str(p), "format": "robot-h5", "t0": s0 + start}
    # Only the reference clock's drops change the number of samples.
    if dropped["joints"]:
        metadata["dropped_samples"] = dropped["joints"]
    with reading(p, "invalid robot recording"):
        return Demonstration.from_clocks(clocked, reference="joints", metadata=metadata)
