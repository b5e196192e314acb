"""Builders of small synthetic files for the io tests."""

from __future__ import annotations

import re

import h5py
import numpy as np
import pytest

from skillbank.io import FormatError


@pytest.fixture
def raises_format_error():
    """``with raises_format_error(path, "reason regex"):`` checks a one-line FormatError."""

    def check(path, match: str = ""):
        return _Check(path, match)

    return check


class _Check:
    def __init__(self, path, match):
        self.path, self.match = str(path), match
        self._ctx = pytest.raises(FormatError)

    def __enter__(self):
        self.info = self._ctx.__enter__()
        return self.info

    def __exit__(self, *exc):
        suppressed = self._ctx.__exit__(*exc)
        message = str(self.info.value)
        assert "\n" not in message
        assert message.startswith(f"cannot read '{self.path}': ")
        assert re.search(self.match, message), message
        return suppressed


def _clock(t):
    """Absolute times -> [seconds, nanoseconds] pairs, as the robot recorder writes them."""
    seconds = np.floor(t)
    return np.column_stack([seconds, np.round((t - seconds) * 1e9)])


@pytest.fixture
def robot_h5(tmp_path):
    """Write a small robot recording; ``skip`` lists groups to leave out."""

    def build(name="robot.h5", *, n=50, skip=(), clock_shape=None):
        path = tmp_path / name
        t = 1_700_000_000.25 + np.cumsum(np.full(n, 0.006))
        angle = np.linspace(0, 4 * np.pi, n)
        joints = np.column_stack([np.angle(np.exp(1j * angle)), np.zeros(n)])  # wraps at +-pi
        groups = {
            "joint_state_info": {"joint_positions": joints, "joint_time": _clock(t)},
            "transform_info": {
                "transform_positions": np.column_stack([t - t[0], np.zeros(n), np.ones(n)]),
                "transform_orientations": np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)),
                "transform_time": _clock(t),
            },
            "wrench_info": {
                "wrench_force": np.ones((n, 3)), "wrench_torque": np.zeros((n, 3)),
                "wrench_time": _clock(t),
            },
            # Shifted clock: interpolation onto the joints' clock must happen.
            "gripper_info": {"gripper_position": (t - t[0])[:, None], "gripper_time": _clock(t + 0.003)},
        }
        with h5py.File(path, "w") as h5:
            for group, datasets in groups.items():
                if group in skip:
                    continue
                for key, value in datasets.items():
                    if key == "joint_time" and clock_shape is not None:
                        value = np.zeros(clock_shape)
                    h5[f"{group}/{key}"] = value
        return path

    return build


@pytest.fixture
def handwriting_h5(tmp_path):
    """Write a handwriting file with demos named ``names`` in group ``normalized``."""

    def build(name="hand.h5", *, names=("0", "1", "2"), n=20):
        path = tmp_path / name
        with h5py.File(path, "w") as h5:
            for i, key in enumerate(names):
                h5[f"normalized/{key}/t"] = 1000.0 + 10.0 * np.arange(n) + i
                h5[f"normalized/{key}/x"] = np.arange(n, dtype=np.int32) + i
                h5[f"normalized/{key}/y"] = -np.arange(n, dtype=np.int32)
        return path

    return build


@pytest.fixture(scope="session")
def uniform_three_button(data_dir, tmp_path_factory):
    """The three-button demonstration resampled onto a uniform 100 Hz clock, and written as a robot HDF5 file.

    Returns ``{"rate", "t", "streams", "joint_names", "h5"}``: what a LeRobot or
    robomimic recording of the same motion holds (no clock of its own but a
    frame rate), and the robot HDF5 file of the same samples to compare with.
    """
    from skillbank.core import slerp
    from skillbank.io import read_robot_h5

    demo = read_robot_h5(data_dir / "seed" / "three_button_pressing_demo.h5")
    rate = 100.0
    t = np.arange(int(demo.t[-1] * rate) + 1) / rate
    streams = {name: slerp(demo.t, Y, t) if name == "orientation" else
               np.column_stack([np.interp(t, demo.t, col) for col in Y.T])
               for name, Y in demo.streams.items()}
    names = list(demo.metadata.get("joint_names", [f"joint_{k}" for k in range(streams["joints"].shape[1])]))
    # The recorder stores a UR arm's joints alphabetically (the order read_robot_h5 expects).
    stored = sorted(range(len(names)), key=lambda k: names[k]) if "joint_names" in demo.metadata else None
    path = tmp_path_factory.mktemp("uniform") / "three_button_100hz.h5"
    whole = np.floor(t)  # built from the small times: an epoch in float64 would blur the nanoseconds
    clock = np.column_stack([1_700_000_000 + whole, np.round((t - whole) * 1e9)])
    with h5py.File(path, "w") as h5:
        h5["joint_state_info/joint_positions"] = streams["joints"][:, stored] if stored else streams["joints"]
        h5["transform_info/transform_positions"] = streams["position"]
        h5["transform_info/transform_orientations"] = streams["orientation"]
        h5["wrench_info/wrench_force"] = streams["force"]
        h5["wrench_info/wrench_torque"] = streams["torque"]
        h5["gripper_info/gripper_position"] = streams["gripper"]
        for group in ("joint_state_info/joint", "transform_info/transform", "wrench_info/wrench",
                      "gripper_info/gripper"):
            h5[f"{group}_time"] = clock
    return {"rate": rate, "t": t, "streams": streams, "joint_names": names, "h5": path}
