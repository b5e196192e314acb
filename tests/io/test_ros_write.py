"""The small-bag writer the examples and the reader's tests share (``skillbank.io._ros_write``): what it
writes is what rosbags' own reader reads back, message by message."""

from __future__ import annotations

import sys

import numpy as np
import pytest

pytest.importorskip("rosbags")  # the extra skillbank[ros]

from rosbags.highlevel import AnyReader  # noqa: E402

from skillbank.io._ros_write import STORAGES, typestore, write_bag  # noqa: E402

NS = 1_000_000_000
RECORDING = {
    "/joint_states": ("sensor_msgs/msg/JointState",
                      [(NS + k, NS + k + 1000, (["a", "b"], [0.1 * k, -0.1 * k])) for k in (2, 0, 1)]),
    "/tool_pose": ("geometry_msgs/msg/PoseStamped",
                   [(NS, NS + 500, ((0.4, 0.0, 0.3), (0.0, 0.0, 0.0, 1.0)))]),
    "/ft": ("geometry_msgs/msg/WrenchStamped", [(NS, NS + 1500, ((0.0, 0.0, -8.0), (0.0, 0.0, 0.0)))]),
}


@pytest.mark.parametrize("storage", STORAGES)
def test_every_message_is_written_at_its_log_time_with_its_stamp(tmp_path, storage):
    name = {"ros1": "rec.bag", "plain-mcap": "rec.mcap"}.get(storage, "rec")
    path = write_bag(tmp_path / name, storage, RECORDING)
    assert path == tmp_path / name and path.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]  # a plain MCAP file leaves no folder
    with AnyReader([path], default_typestore=typestore(storage == "ros1")) as reader:
        read = [(c.topic, log, reader.deserialize(raw, c.msgtype)) for c, log, raw in reader.messages()]
    logs = [log for _, log, _ in read]
    assert logs == sorted(logs) and len(read) == 5
    joints = [(log, m) for topic, log, m in read if topic == "/joint_states"]
    assert [log for log, _ in joints] == [NS + 1000, NS + 1001, NS + 1002]
    _, last = joints[-1]
    assert last.header.stamp.sec == 1 and last.header.stamp.nanosec == 2 and last.name == ["a", "b"]
    np.testing.assert_allclose(last.position, [0.2, -0.2])
    pose, = (m for topic, _, m in read if topic == "/tool_pose")
    assert pose.header.frame_id == "base" and (pose.pose.position.x, pose.pose.orientation.w) == (0.4, 1.0)
    wrench, = (m for topic, _, m in read if topic == "/ft")
    assert wrench.header.frame_id == "tool0" and wrench.wrench.force.z == -8.0


def test_types_the_store_lacks_are_registered_and_others_are_refused(tmp_path):
    ts = typestore(True, {"control_msgs/msg/GripperCommand": "float64 position\nfloat64 max_effort\n"})
    assert "control_msgs/msg/GripperCommand" in ts.types
    command = {"/grip": ("control_msgs/msg/GripperCommand", [(NS, NS, 0.5)])}
    with pytest.raises(ValueError, match=r"^msgtype: expected one of JointState, PoseStamped, WrenchStamped, "
                                         r"got 'control_msgs/msg/GripperCommand'$"):
        write_bag(tmp_path / "a.bag", "ros1", command, ts=ts)
    path = write_bag(tmp_path / "b.bag", "ros1", command, ts=ts,
                     build=lambda ts, msgtype, ns, value: ts.types[msgtype](position=value, max_effort=1.0))
    with AnyReader([path], default_typestore=ts) as reader:
        (connection, _, raw), = reader.messages()
        assert reader.deserialize(raw, connection.msgtype).position == 0.5
    with pytest.raises(ValueError, match=r"^storage: expected one of \['ros1', 'sqlite3', 'mcap', "
                                         r"'plain-mcap'\], got 'db3'$"):
        write_bag(tmp_path / "c", "db3", command, ts=ts)


def test_without_rosbags_one_line_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "rosbags.rosbag1", None)
    with pytest.raises(ImportError, match=r"^writing ROS bags needs the 'rosbags' package: "
                                          r"pip install skillbank\[ros\]$"):
        write_bag(tmp_path / "rec.bag", "ros1", RECORDING)
