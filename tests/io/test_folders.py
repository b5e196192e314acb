"""``load_positions``: the stream to work on is ``position``, or a file's only stream; the rest optional."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.io import load_positions, write_npz


def _file(tmp_path, name, streams, **metadata):
    t = np.linspace(0.0, 1.0, 20)
    demo = Demonstration(t, {k: np.asarray(v(t), float) for k, v in streams.items()}, metadata)
    return write_npz(demo, tmp_path / name), demo


def test_position_alone_or_every_stream(tmp_path):
    path, demo = _file(tmp_path, "a.npz", {"position": lambda t: np.c_[t, t ** 2, 0 * t],
                                           "gripper": lambda t: (t > 0.5)[:, None]}, user=3)
    [alone] = load_positions([path])
    assert alone.stream_names == ["position"] and alone.metadata == {"source": str(path)}
    np.testing.assert_array_equal(alone["position"], demo["position"])
    [every] = load_positions([path], every_stream=True)
    assert every.stream_names == ["position", "gripper"] and every.metadata["user"] == 3
    np.testing.assert_array_equal(every["gripper"], demo["gripper"])
    np.testing.assert_array_equal(every.t, demo.t)


def test_an_only_stream_is_the_position_and_keeps_its_place(tmp_path):
    path, demo = _file(tmp_path, "j.npz", {"joints": lambda t: np.c_[t, -t]})
    for every in (False, True):
        [back] = load_positions([path], every_stream=every)
        assert back.stream_names == ["position"]
        np.testing.assert_array_equal(back["position"], demo["joints"])


def test_errors_name_the_file(tmp_path):
    two, _ = _file(tmp_path, "two.npz", {"joints": lambda t: np.c_[t, t], "force": lambda t: np.c_[t]})
    flat, _ = _file(tmp_path, "flat.npz", {"position": lambda t: np.c_[t, t]})
    deep, _ = _file(tmp_path, "deep.npz", {"position": lambda t: np.c_[t, t, t]})
    for every in (False, True):
        with pytest.raises(ValueError, match=r"input: no such file: '.*missing\.npz'"):
            load_positions([tmp_path / "missing.npz"], every_stream=every)
        with pytest.raises(ValueError, match=r"two\.npz' has streams \['joints', 'force'\] and none is "
                                             r"'position'"):
            load_positions([two], every_stream=every)
        with pytest.raises(ValueError, match=r"deep\.npz' has 3 dimensions, but '.*flat\.npz' has 2"):
            load_positions([flat, deep], every_stream=every)
