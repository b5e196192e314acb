"""Readers read regular files only, and nothing outside the file or folder they were given (issue 23).

HDF5 files that point elsewhere (external storage, external links, virtual
datasets), FIFOs and devices given as inputs, outputs onto FIFOs: each is
one line, before anything is opened or read.
"""

from __future__ import annotations

import os
import signal
import stat
from contextlib import contextmanager

import h5py
import numpy as np
import pytest

from skillbank.core import Demonstration
from skillbank.io import (
    FormatError,
    atomic_output,
    check_input_file,
    detect_format,
    load_all,
    read_handwriting_h5,
    read_robomimic,
    read_robot_h5,
    write_csv,
    write_json,
    write_npz,
)
from skillbank.io._confine import check_input_folder, inside

SECRET = "password=hunter2\n"


@contextmanager
def no_hang(seconds: int = 20):
    """Fail (instead of blocking the suite) if the block has not finished in ``seconds``."""

    def alarm(*_):
        raise TimeoutError(f"blocked for {seconds} s")

    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def one_line_refusal(code, out, err):
    return code == 2 and out == "" and len(err.strip().splitlines()) == 1 and "Traceback" not in err


# ---------------------------------------------------------------- HDF5 that refers to other files


def _with_external_gripper(path, secret):
    """A robot recording whose gripper_position keeps its bytes in ``secret`` (external storage)."""
    with h5py.File(path, "a") as h5:
        del h5["gripper_info/gripper_position"]
        n = h5["gripper_info/gripper_time"].shape[0]
        h5["gripper_info"].create_dataset("gripper_position", shape=(n, 1), dtype="u1",
                                          external=[(str(secret), 0, n)])
    return path


@pytest.fixture
def secret(tmp_path):
    path = tmp_path / "outside" / "secret.txt"
    path.parent.mkdir()
    path.write_text(SECRET * 20)
    return path


def test_external_storage_is_refused_by_name(robot_h5, secret, raises_format_error):
    path = _with_external_gripper(robot_h5(), secret)
    with h5py.File(path) as h5:  # the file really reads the secret through h5py
        assert bytes(h5["gripper_info/gripper_position"][:5, 0]) == SECRET[:5].encode()
    reason = (r"dataset 'gripper_info/gripper_position' keeps its data in external file\(s\) "
              r"\[.*secret.txt'\]: the file refers to data outside itself; skillbank reads only data "
              "stored in the file itself")
    for read in (read_robot_h5, load_all, detect_format):
        with raises_format_error(path, reason) as info:
            read(path)
        assert "hunter2" not in str(info.value)


def test_external_link_and_virtual_dataset_are_refused(robot_h5, handwriting_h5, tmp_path,
                                                       raises_format_error):
    other = tmp_path / "outside" / "other.h5"
    other.parent.mkdir()
    with h5py.File(other, "w") as h5:
        h5["d"] = np.arange(50.0)
    linked = robot_h5("linked.h5", skip=("gripper_info",))
    with h5py.File(linked, "a") as h5:
        h5["gripper_info/gripper_position"] = h5py.ExternalLink(str(other), "/d")
    with raises_format_error(linked, r"'gripper_info/gripper_position' is an external link to '/d' in file "
                                     r"'.*other.h5': the file refers to data outside itself"):
        read_robot_h5(linked)
    hand = handwriting_h5()
    with h5py.File(hand, "a") as h5:
        layout = h5py.VirtualLayout(shape=(20,), dtype="f8")
        layout[:] = h5py.VirtualSource(str(other), "d", shape=(50,))[:20]
        del h5["normalized/1/x"]
        h5["normalized/1"].create_virtual_dataset("x", layout)
    with raises_format_error(hand, r"dataset 'normalized/1/x' is a virtual dataset mapping data of "
                                   r"\['.*other.h5'\]: the file refers to data outside itself"):
        read_handwriting_h5(hand)
    with raises_format_error(hand, "is a virtual dataset"):
        load_all(hand)


def test_robomimic_external_link_is_refused(tmp_path, raises_format_error):
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as h5:
        h5["obs"] = np.ones((10, 3))
    path = tmp_path / "rm.hdf5"
    with h5py.File(path, "w") as h5:
        h5["data/demo_0/actions"] = np.zeros((10, 2))
        h5["data/demo_0/obs/robot0_eef_pos"] = np.zeros((10, 3))
        h5["data/demo_1/actions"] = np.zeros((10, 2))
        h5["data/demo_1/obs/robot0_eef_pos"] = h5py.ExternalLink(str(other), "/obs")
    with raises_format_error(path, "'data/demo_1/obs/robot0_eef_pos' is an external link"):
        read_robomimic(path)
    with raises_format_error(path, "'data/demo_1/obs/robot0_eef_pos' is an external link"):
        read_robomimic(path, episodes=[0])  # refused as a whole, whichever demonstrations are asked for


def test_soft_links_and_hard_link_cycles_inside_the_file_are_read(robot_h5):
    path = robot_h5()
    plain = read_robot_h5(path)
    with h5py.File(path, "a") as h5:
        h5["copy"] = h5py.SoftLink("/gripper_info")
        h5["wrench_info/loop"] = h5["/"]  # a hard link back to the root: a cycle
    demo = read_robot_h5(path)
    np.testing.assert_array_equal(demo["gripper"], plain["gripper"])


def test_library_add_and_segment_of_an_external_file_exit_2(robot_h5, secret, tmp_path, cli, table_rows):
    path = _with_external_gripper(robot_h5(n=400), secret)
    db = tmp_path / "lib.sqlite"
    assert cli("library", "add", db, path)[0] == 2 and not db.exists()  # no library is created
    assert cli("library", "init", db)[0] == 0
    before = table_rows(db)
    code, out, err = cli("library", "add", db, path, "--whole")
    assert one_line_refusal(code, out, err) and "refers to data outside itself" in err, err
    assert "hunter2" not in err and table_rows(db) == before
    code, out, err = cli("segment", path, "--json")
    assert one_line_refusal(code, out, err) and "external file" in err


# ---------------------------------------------------------------- inputs must be regular files


@pytest.mark.parametrize("name", ["rec.bag", "rec.mcap", "rec.db3", "rec.h5", "rec.hdf5", "rec.csv",
                                  "rec.npz", "rec.mat"])
def test_a_fifo_input_is_refused_without_blocking(tmp_path, name, raises_format_error):
    fifo = tmp_path / name
    os.mkfifo(fifo)
    with no_hang():
        with raises_format_error(fifo, r"expected a regular file, found a FIFO \(named pipe\)$"):
            detect_format(fifo)
        with raises_format_error(fifo, r"found a FIFO \(named pipe\)$"):
            load_all(fifo)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


def test_a_fifo_given_to_the_cli_exits_2_at_once(tmp_path, limited, cli, table_rows):
    fifo = tmp_path / "rec.bag"
    os.mkfifo(fifo)
    code, out, err = limited("segment", fifo, "--json", memory=1 << 30, timeout=60)
    assert one_line_refusal(code, out, err) and "FIFO" in err, err
    db = tmp_path / "lib.sqlite"
    assert cli("library", "init", db)[0] == 0
    before = table_rows(db)
    code, out, err = limited("library", "add", db, fifo, memory=1 << 30, timeout=60)
    assert one_line_refusal(code, out, err) and "FIFO" in err, err
    assert table_rows(db) == before and stat.S_ISFIFO(os.stat(fifo).st_mode)


def test_a_fifo_inside_a_ros2_bag_folder_is_refused(tmp_path, raises_format_error, limited):
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.LATEST)
    bag = tmp_path / "bag"
    with Writer(bag, version=9) as writer:
        conn = writer.add_connection("/x", "std_msgs/msg/Float64", typestore=store)
        for k in range(3):
            msg = store.types["std_msgs/msg/Float64"](data=float(k))
            writer.write(conn, k * 10**8, store.serialize_cdr(msg, "std_msgs/msg/Float64"))
    data = next(bag.glob("*.db3"))
    data.unlink()
    os.mkfifo(data)
    # In a child process first: a FIFO opened by sqlite's C code would block past any signal here.
    code, out, err = limited("segment", bag, "--json", memory=1 << 30, timeout=60)
    assert one_line_refusal(code, out, err) and "FIFO" in err, err
    with no_hang():
        fifo = rf"the file '{data.name}' is a FIFO \(named pipe\): expected a regular file"
        with raises_format_error(bag, fifo):
            load_all(bag)
        with raises_format_error(bag, "is a FIFO"):
            detect_format(bag)


def test_check_input_file():
    with pytest.raises(ValueError, match=r"^demo: expected a regular file, got '/dev/null', a character "
                                         "device; give the path of a file$"):
        check_input_file("/dev/null", name="demo")
    with pytest.raises(ValueError, match=r"^input: expected a regular file, got '/nonexistent/x.h5', no"):
        check_input_file("/nonexistent/x.h5")
    with pytest.raises(ValueError, match=r"^input: expected a file path, got int$"):
        check_input_file(3)


def test_check_input_file_refuses_a_fifo_and_a_folder(tmp_path):
    fifo = tmp_path / "f"
    os.mkfifo(fifo)
    with no_hang(), pytest.raises(ValueError, match=r"^out: .* a FIFO \(named pipe\); give the path of a"):
        check_input_file(fifo, name="out")
    with pytest.raises(ValueError, match="a directory; give the path of a file$"):
        check_input_file(tmp_path)
    (tmp_path / "ok.csv").write_text("t,x\n0,1\n")
    assert check_input_file(tmp_path / "ok.csv") == tmp_path / "ok.csv"


def test_paths_named_by_a_dataset_stay_inside_it(tmp_path, secret):
    root = tmp_path / "ds"
    (root / "data").mkdir(parents=True)
    (root / "data" / "a.parquet").write_bytes(b"x")
    (root / "data" / "same.parquet").symlink_to("a.parquet")  # a link that stays inside: followed
    assert inside(root, "data/same.parquet") == (root / "data" / "a.parquet").resolve()
    assert inside(root, "data/missing.parquet") == (root / "data" / "missing.parquet").resolve()
    for rel, message in [("../outside/secret.txt", "leaves the dataset folder"),
                         (str(secret), "leaves the dataset folder"),
                         ("data/../../outside/secret.txt", "leaves the dataset folder"),
                         (5, "expected the path as a string, found int 5")]:
        with pytest.raises(FormatError, match=message):
            inside(root, rel)
    (root / "data" / "out.parquet").symlink_to(secret)
    with pytest.raises(FormatError, match=r"'data/out.parquet' is a symbolic link \(or under one\) to "
                                          "'.*secret.txt', outside the dataset folder"):
        inside(root, "data/out.parquet")
    (root / "linked").symlink_to(secret.parent)
    with pytest.raises(FormatError, match="under one"):
        inside(root, "linked/secret.txt")
    with pytest.raises(FormatError, match="'linked' is a symbolic link"):
        check_input_folder(root)


# ---------------------------------------------------------------- outputs: whole or not at all


def test_atomic_output_replaces_on_success_and_keeps_the_old_file_on_failure(tmp_path):
    out = tmp_path / "r.json"
    out.write_text("old")
    os.chmod(out, 0o640)
    with pytest.raises(RuntimeError, match="half-way"), atomic_output(out) as tmp:
        tmp.write_text("half")
        raise RuntimeError("half-way")
    assert out.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]
    with atomic_output(out) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".json"
        tmp.write_text("new")
    assert out.read_text() == "new" and stat.S_IMODE(os.stat(out).st_mode) == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]


def test_atomic_output_refuses_a_fifo_a_folder_and_a_missing_folder(tmp_path):
    fifo = tmp_path / "out.csv"
    os.mkfifo(fifo)
    demo = Demonstration.from_array(np.eye(3))
    with no_hang():
        with pytest.raises(ValueError, match=r"^out: expected a regular file to write \(or a new one\), got "
                                             r"'.*out.csv', a FIFO \(named pipe\); give the path of a file$"):
            with atomic_output(fifo):
                pass
        for write in (write_csv, write_npz):
            with pytest.raises(ValueError, match=r"^path: .* a FIFO \(named pipe\)"):
                write(demo, fifo)
        with pytest.raises(ValueError, match=r"^path: .* a FIFO"):
            write_json({"a": 1}, fifo)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]
    with pytest.raises(ValueError, match="a directory; give the path of a file$"):
        write_csv(demo, tmp_path)
    with pytest.raises(ValueError, match=r"^path: the folder '.*nowhere' of .* does not exist; create it"):
        write_json({}, tmp_path / "nowhere" / "r.json")
    with pytest.raises(ValueError, match=r"^out: expected a regular file to write .* a character device"):
        with atomic_output("/dev/null"):
            pass


def test_segment_out_onto_a_fifo_exits_2_and_leaves_the_fifo(tmp_path, cli):
    t = np.linspace(0.0, 2.0, 200)
    src = write_csv(Demonstration.from_array(np.column_stack([np.sin(t), np.cos(t)]), t), tmp_path / "d.csv")
    out = tmp_path / "segments"
    out.mkdir()
    fifo = out / "d_segment00.npz"
    os.mkfifo(fifo)
    with no_hang():
        code, stdout, err = cli("segment", src, "--out", out)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "FIFO" in err, err
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and [p.name for p in out.iterdir()] == ["d_segment00.npz"]


# ---------------------------------------------------------------- a few bytes that declare gigabytes


def _declaring_gigabytes(path):
    """A robot recording whose joints declare 2^28 rows (12.9 GB) in chunks never written: a small file."""
    with h5py.File(path, "a") as h5:
        del h5["joint_state_info/joint_positions"]
        h5["joint_state_info"].create_dataset("joint_positions", shape=(1 << 28, 6), dtype="f8",
                                              chunks=(4096, 6))
    return path


def test_a_dataset_declaring_gigabytes_is_refused_before_it_is_read(robot_h5, raises_format_error):
    path = _declaring_gigabytes(robot_h5())
    assert path.stat().st_size < 100_000
    reason = (r"dataset 'joint_state_info/joint_positions' \(\(268435456, 6\), float64\) would take "
              r"12884901888 bytes in memory, and with the 800 bytes read before it that passes the bound of "
              r"1073741824 bytes read from one file; set SKILLBANK_MAX_READ_BYTES to read more$")
    with raises_format_error(path, reason):
        read_robot_h5(path)


def test_the_gigabyte_dataset_exits_2_within_a_small_memory_limit(robot_h5, limited):
    path = _declaring_gigabytes(robot_h5())
    code, out, err = limited("segment", path, "--json", memory=1 << 30, timeout=60)
    assert one_line_refusal(code, out, err) and "SKILLBANK_MAX_READ_BYTES" in err, err


def test_the_read_bound_is_set_by_the_environment(robot_h5, handwriting_h5, monkeypatch, raises_format_error):
    path, hand = robot_h5(), handwriting_h5()
    monkeypatch.setenv("SKILLBANK_MAX_READ_BYTES", "1000")
    with raises_format_error(path, r"passes the bound of 1000 bytes read from one file"):
        read_robot_h5(path)
    monkeypatch.setenv("SKILLBANK_MAX_READ_BYTES", "500")  # 320 bytes a demonstration: the second passes it
    with raises_format_error(hand, r"dataset 'normalized/1/x' \(\(20,\), int32\) would take 80 bytes in "
                                   r"memory, and with the 480 bytes read before it that passes the bound"):
        read_handwriting_h5(hand)
    monkeypatch.setenv("SKILLBANK_MAX_READ_BYTES", str(1 << 20))
    assert read_robot_h5(path).n_steps == 50
    monkeypatch.setenv("SKILLBANK_MAX_READ_BYTES", "lots")
    with pytest.raises(ValueError, match=r"^SKILLBANK_MAX_READ_BYTES: expected a positive number of bytes, "
                                         r"got 'lots'$"):
        read_robot_h5(path)


def test_load_positions_refuses_a_fifo(tmp_path):
    from skillbank.io import load_positions

    fifo = tmp_path / "path.csv"
    os.mkfifo(fifo)
    with no_hang(), pytest.raises(ValueError, match=r"^input: expected a regular file, got '.*', a FIFO"):
        load_positions([fifo])


def test_a_flipped_byte_in_an_hdf5_file_is_read_or_one_line(tmp_path):
    # h5py raises SystemError walking the links of some corrupt files (byte 736 of this one): one line too.
    n = 50
    t = 1_700_000_000.25 + np.cumsum(np.full(n, 0.006))
    whole = np.floor(t)
    clock = np.column_stack([whole, np.round((t - whole) * 1e9)])
    base = tmp_path / "base.h5"
    with h5py.File(base, "w") as h5:
        h5["joint_state_info/joint_positions"] = np.zeros((n, 6))
        h5["joint_state_info/joint_time"] = clock
        h5["transform_info/transform_positions"] = np.zeros((n, 3))
        h5["transform_info/transform_time"] = clock
        h5["transform_info/transform_orientations"] = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    data = base.read_bytes()
    refused = 0
    for i in range(0, 2048, 16):
        flipped = bytearray(data)
        flipped[i] ^= 0xFF
        path = tmp_path / "flipped.h5"
        path.write_bytes(bytes(flipped))
        try:
            load_all(path)
        except FormatError as exc:
            assert "\n" not in str(exc)
            refused += 1
    assert refused > 0
