"""Format detection and the generic ``load`` / ``load_all``."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.io import FormatError, detect_format, load, load_all, write_csv, write_npz


def test_detect_real_files(data_dir):
    assert detect_format(data_dir / "seed" / "three_button_pressing_demo.h5") == "robot-h5"
    assert detect_format(data_dir / "seed" / "r_shape.h5") == "handwriting-h5"
    assert detect_format(str(data_dir / "rail" / "WRITING" / "10.mat")) == "rail-mat"


def test_detect_written_files(tmp_path, robot_h5, handwriting_h5):
    demo = Demonstration.from_array(np.ones((4, 2)))
    assert detect_format(write_csv(demo, tmp_path / "d.csv")) == "csv"
    assert detect_format(write_npz(demo, tmp_path / "d.NPZ")) == "npz"
    assert detect_format(robot_h5("r.hdf5")) == "robot-h5"
    assert detect_format(handwriting_h5("h.h5")) == "handwriting-h5"


def test_load_and_load_all_dispatch(data_dir, tmp_path, robot_h5):
    r_shape = data_dir / "seed" / "r_shape.h5"
    assert len(load_all(r_shape)) == 5
    assert [d.n_steps for d in load_all(r_shape, group="unsmoothed")][:2] == [299, 262]
    assert load(r_shape).metadata["index"] == 0
    assert load(r_shape, index=-1).metadata["index"] == 4
    assert load(r_shape, index=2, group="unsmoothed").n_steps == 237

    rail = data_dir / "rail" / "PRESSING" / "1.mat"
    demos = load_all(rail)
    assert load(rail, index=len(demos) - 1).metadata["index"] == len(demos) - 1

    robot = load_all(robot_h5())
    assert len(robot) == 1 and "joints" in robot[0]

    demo = Demonstration.from_array(np.arange(6.0).reshape(3, 2))
    for name, writer in (("d.csv", write_csv), ("d.npz", write_npz)):
        back = load(writer(demo, tmp_path / name))
        np.testing.assert_array_equal(back["position"], demo["position"])


def test_load_index_errors(data_dir, tmp_path, raises_format_error):
    r_shape = data_dir / "seed" / "r_shape.h5"
    with raises_format_error(r_shape, r"index 5 is out of range: the file holds 5 demonstrations \(0..4\)"):
        load(r_shape, index=5)
    with raises_format_error(r_shape, "expected an integer index, got 'a'"):
        load(r_shape, index="a")
    single = write_csv(Demonstration.from_array(np.ones((3, 1))), tmp_path / "one.csv")
    with raises_format_error(single, "index 1 is out of range: the file holds 1 demonstration "):
        load(single, index=1)


def _truncated_hdf5(path):
    with h5py.File(path, "w") as h5:
        h5["normalized/0/t"] = np.arange(5000.0)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 3])
    return path


RANDOM = np.random.default_rng(1).integers(0, 256, 2048, dtype=np.uint8).tobytes()


@pytest.mark.parametrize(
    ("name", "content", "reason"),
    [
        ("random.h5", RANDOM, "expected HDF5 content, found binary data"),
        ("text.hdf5", b"t,x\n0,1\n", "expected HDF5 content, found a text file$"),
        ("zip.h5", b"PK\x03\x04rest", "expected HDF5 content, found a zip archive"),
        ("random.mat", RANDOM, "expected a MATLAB 5.0 file, found binary data"),
        ("v73.mat", b"MATLAB 7.3 MAT-file" + RANDOM, "found a MATLAB 7.3"),
        ("random.npz", RANDOM, r"expected an NPZ \(zip\) archive, found binary data"),
        ("text.npz", b"just some text\n", r"expected an NPZ \(zip\) archive, found a text file$"),
        ("empty.npz", b"", "found an empty file"),
        ("random.csv", RANDOM, "expected a comma-separated numeric table"),
        ("words.csv", b"hello world\nno commas here\n", "expected a comma-separated numeric table"),
        ("words2.csv", b"a,b\nc,d\n", "expected a comma-separated numeric table"),
        ("demo.xyz", b"t,x\n0,1\n", r"unknown extension '.xyz': expected one of .csv, .h5"),
        ("noext", b"t,x\n0,1\n", r"unknown extension '\(none\)'"),
    ],
)
def test_detect_rejects_mismatched_content(tmp_path, raises_format_error, name, content, reason):
    path = tmp_path / name
    path.write_bytes(content)
    with raises_format_error(path, reason):
        detect_format(path)
    with raises_format_error(path, reason):
        load(path)


def test_detect_corrupt_and_foreign_hdf5(tmp_path, raises_format_error):
    truncated = _truncated_hdf5(tmp_path / "trunc.h5")
    with raises_format_error(truncated, "corrupt HDF5 file: .*truncated"):
        detect_format(truncated)
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as h5:
        h5["images/0"] = np.zeros(3)
    with raises_format_error(foreign, r"expected a robot recording .* found groups \['images'\]"):
        load_all(foreign)


def test_corrupt_mat_and_npz_bodies(tmp_path, raises_format_error):
    mat = tmp_path / "broken.mat"
    mat.write_bytes(b"MATLAB 5.0 MAT-file" + b" " * 105 + RANDOM)
    assert detect_format(mat) == "rail-mat"
    with raises_format_error(mat, "invalid MATLAB file"):
        load(mat)
    npz = tmp_path / "broken.npz"
    npz.write_bytes(b"PK\x03\x04" + RANDOM)
    with raises_format_error(npz, "corrupt NPZ archive"):
        load(npz)


def test_missing_file_and_directory(tmp_path, raises_format_error):
    with raises_format_error(tmp_path / "absent.h5", "no such file"):
        detect_format(tmp_path / "absent.h5")
    with raises_format_error(tmp_path / "absent.csv", "no such file"):
        load(tmp_path / "absent.csv")
    with raises_format_error(tmp_path, "expected a file, found a directory"):
        load_all(tmp_path)


def test_errors_are_value_errors(tmp_path):
    with pytest.raises(ValueError, match="cannot read"):
        load(tmp_path / "absent.npz")
    assert issubclass(FormatError, ValueError)
