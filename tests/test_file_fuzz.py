"""Fuzz of every reader with damaged files (issue 23, evidence): one clear line or a demonstration.

Small valid files of each format skillbank reads are written with the
ecosystem's own writers (h5py, rosbags, pyarrow, skillbank's CSV and NPZ
writers) and then damaged the ways a disk, a transfer or an attacker damages
them: bytes flipped, the file cut short, bytes inserted, and (for the
formats made of JSON metadata) any JSON value put in place of a field. The
only acceptable outcomes of reading one are demonstrations or a
``ValueError`` / ``OSError`` with a one-line message; anything else
(``KeyError``, ``AssertionError``, ``MemoryError``, a traceback from inside
h5py or rosbags) fails. ``SKILLBANK_FUZZ_EXAMPLES`` fuzzes deeper.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skillbank.core import Demonstration
from skillbank.io import load_all, write_csv, write_npz

EXAMPLES = int(os.environ.get("SKILLBANK_FUZZ_EXAMPLES", "25"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


def _clock(t):
    seconds = np.floor(t)
    return np.column_stack([seconds, np.round((t - seconds) * 1e9)])


def _robot_h5(path: Path, n=60):
    t = 1_700_000_000.0 + np.cumsum(np.full(n, 0.006))
    s = np.linspace(0.0, 1.0, n)
    groups = {
        "joint_state_info": {"joint_positions": np.column_stack([s, 0.5 * s, -s, s, 0 * s, s]),
                             "joint_time": _clock(t)},
        "transform_info": {"transform_positions": np.column_stack([s, s ** 2, 0.1 + 0 * s]),
                           "transform_orientations": np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)),
                           "transform_time": _clock(t)},
        "wrench_info": {"wrench_force": np.column_stack([s, 0 * s, 0 * s]),
                        "wrench_torque": np.column_stack([0 * s, s, 0 * s]), "wrench_time": _clock(t)},
        "gripper_info": {"gripper_position": (s > 0.5)[:, None] * 1.0, "gripper_time": _clock(t)},
    }
    with h5py.File(path, "w") as h5:
        for group, datasets in groups.items():
            for name, values in datasets.items():
                h5.create_dataset(f"{group}/{name}", data=values)
    return path


def _demo(n=60):
    t = np.linspace(0.0, 1.0, n)
    return Demonstration(t, {"position": np.column_stack([t, np.sin(3 * t), 0 * t + 0.2]),
                             "gripper": (t > 0.5)[:, None] * 1.0})


def _ros(folder: Path, storage: str):
    from rosbags.rosbag1 import Writer as Ros1Writer
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Ros2Writer
    from rosbags.typesys import Stores, get_typestore

    ros1 = storage == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    JointState = ts.types["sensor_msgs/msg/JointState"]
    Header = ts.types["std_msgs/msg/Header"]
    Time = ts.types["builtin_interfaces/msg/Time"]
    if ros1:
        path = folder / "rec.bag"
        writer = Ros1Writer(path)
    else:
        path = folder / "rec"
        plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
        writer = Ros2Writer(path, version=9, storage_plugin=plugin)
    with writer:
        conn = writer.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts)
        for k in range(40):
            stamp = 1_000_000_000 + k * 10_000_000
            header = Header(seq=k, stamp=Time(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id="") \
                if ros1 else Header(stamp=Time(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id="")
            msg = JointState(header=header, name=["a", "b"], position=np.array([0.01 * k, -0.02 * k]),
                             velocity=np.zeros(0), effort=np.zeros(0))
            data = ts.serialize_ros1(msg, JointState.__msgtype__) if ros1 else \
                ts.serialize_cdr(msg, JointState.__msgtype__)
            writer.write(conn, stamp, data)
    return path


def _lerobot(root: Path, n=12):
    import pyarrow as pa
    import pyarrow.parquet as pq

    info = {"codebase_version": "v2.1", "robot_type": "ur5e", "fps": 30, "chunks_size": 1000,
            "total_episodes": 1,
            "data_path": "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet",
            "features": {"observation.state": {"dtype": "float32", "shape": [3], "names": None},
                         "timestamp": {"dtype": "float32", "shape": [1], "names": None},
                         "frame_index": {"dtype": "int64", "shape": [1], "names": None},
                         "episode_index": {"dtype": "int64", "shape": [1], "names": None},
                         "index": {"dtype": "int64", "shape": [1], "names": None},
                         "task_index": {"dtype": "int64", "shape": [1], "names": None}}}
    (root / "meta").mkdir(parents=True)
    (root / "meta" / "info.json").write_text(json.dumps(info))
    state = np.column_stack([np.arange(n), -np.arange(n), np.ones(n)]).astype(np.float32)
    table = pa.table({"observation.state": pa.array(list(state), type=pa.list_(pa.float32())),
                      "timestamp": pa.array(np.arange(n, dtype=np.float32) / 30),
                      "frame_index": pa.array(np.arange(n)), "episode_index": pa.array(np.zeros(n, int)),
                      "index": pa.array(np.arange(n)), "task_index": pa.array(np.zeros(n, int))})
    data = root / "data" / "chunk-000" / "episode_000000.parquet"
    data.parent.mkdir(parents=True)
    pq.write_table(table, data)
    (root / "meta" / "episodes.jsonl").write_text(json.dumps({"episode_index": 0, "length": n,
                                                              "tasks": ["pick"]}) + "\n")
    (root / "meta" / "tasks.jsonl").write_text(json.dumps({"task_index": 0, "task": "pick"}) + "\n")
    return root


def _build(kind: str, folder: Path) -> tuple[Path, Path]:
    """``(what to read, the file in it to damage)`` of a valid ``kind``."""
    if kind == "robot-h5":
        p = _robot_h5(folder / "rec.h5")
        return p, p
    if kind == "csv":
        p = folder / "rec.csv"
        write_csv(_demo(), p, stream="position")
        return p, p
    if kind == "npz":
        p = folder / "rec.npz"
        write_npz(_demo(), p)
        return p, p
    if kind in ("ros1", "sqlite3", "mcap"):
        p = _ros(folder, kind)
        member = p if kind == "ros1" else next(f for f in p.iterdir() if f.suffix in (".db3", ".mcap"))
        return p, member
    if kind == "lerobot":
        root = _lerobot(folder / "ds")
        return root, next((root / "data").rglob("*.parquet"))
    raise AssertionError(kind)


KINDS = ("robot-h5", "csv", "npz", "ros1", "sqlite3", "mcap", "lerobot")


@pytest.fixture(scope="module")
def originals(tmp_path_factory):
    base = tmp_path_factory.mktemp("originals")
    made = {}
    for kind in KINDS:
        folder = base / kind
        folder.mkdir()
        made[kind] = (folder, *_build(kind, folder))
    return made


def _outcome(path):
    """Read ``path``: the demonstrations, or the one-line error; anything else fails the test."""
    try:
        demos = load_all(path)
    except (ValueError, OSError) as exc:
        message = str(exc)
        assert message and "\n" not in message, f"{type(exc).__name__} of more than one line: {message!r}"
        return message
    assert demos and all(isinstance(d, Demonstration) for d in demos)
    return demos


def test_the_originals_read(originals):
    for kind, (_, target, _) in originals.items():
        assert isinstance(_outcome(target), list), kind


@st.composite
def damage(draw, size: int):
    """A function ``bytes -> bytes``: flips, a cut, or an insertion, at drawn places."""
    how = draw(st.sampled_from(["flip", "flip", "cut", "insert"]))
    if how == "flip":
        spots = draw(st.lists(st.tuples(st.integers(0, size - 1), st.integers(1, 255)),
                              min_size=1, max_size=8))

        def apply(data: bytes) -> bytes:
            out = bytearray(data)
            for at, mask in spots:
                out[at] ^= mask
            return bytes(out)
        return apply
    if how == "cut":
        at = draw(st.integers(0, size - 1))
        return lambda data: data[:at]
    at = draw(st.integers(0, size))
    extra = draw(st.binary(min_size=1, max_size=64))
    return lambda data: data[:at] + extra + data[at:]


@pytest.mark.parametrize("kind", KINDS)
@FUZZ
@given(data=st.data())
def test_damaged_files_give_one_line_or_demonstrations(kind, originals, data):
    folder, target, member = originals[kind]
    original = member.read_bytes()
    change = data.draw(damage(len(original)))
    with tempfile.TemporaryDirectory() as work:
        copy = Path(work) / folder.name
        shutil.copytree(folder, copy)
        damaged_member = copy / member.relative_to(folder)
        damaged_member.write_bytes(change(original))
        _outcome(copy / target.relative_to(folder))


# JSON values a field of a metadata file may be replaced with: every JSON type, and the edges
_LEAVES = (st.none() | st.booleans() | st.integers(-(2**70), 2**70)
           | st.sampled_from([0, -1, 10**400, 2**63 - 1]) | st.floats(allow_nan=False) | st.text(max_size=20)
           | st.sampled_from(["../../../outside/x.parquet", "/etc/passwd", "{episode_index:>1000000000}",
                             "3"]))
JSON_VALUES = (_LEAVES | st.lists(_LEAVES, max_size=3)
               | st.dictionaries(st.text(max_size=8), _LEAVES | st.lists(_LEAVES, max_size=2), max_size=3))


@FUZZ
@given(data=st.data())
def test_lerobot_metadata_with_any_value_gives_one_line_or_demonstrations(originals, data):
    folder, target, _ = originals["lerobot"]
    info = json.loads((target / "meta" / "info.json").read_text())
    key = data.draw(st.sampled_from(["fps", "chunks_size", "data_path", "total_episodes", "codebase_version",
                                     "features", "feature_shape", "feature_dtype"]))
    value = data.draw(JSON_VALUES)
    if key == "feature_shape":
        info["features"]["observation.state"]["shape"] = value
    elif key == "feature_dtype":
        info["features"]["observation.state"]["dtype"] = value
    else:
        info[key] = value
    with tempfile.TemporaryDirectory() as work:
        copy = Path(work) / "ds"
        shutil.copytree(target, copy)
        (copy / "meta" / "info.json").write_text(json.dumps(info))
        _outcome(copy)
