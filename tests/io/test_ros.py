"""ROS 1 bags, ROS 2 bags (sqlite3, MCAP) and plain MCAP files, written here with rosbags' own writers
(message by message, through ``skillbank.io._ros_write`` as the examples are)."""

from __future__ import annotations

import json
import re
import sys

import h5py
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer

from skillbank.io import FormatError, detect_format, load, load_all, parse_topics, read_robot_h5, read_rosbag
from skillbank.io._align import check_split
from skillbank.io._ros_write import header, message, typestore
from skillbank.io._ros_write import write_bag as _write_bag
from skillbank.segmentation import MultimodalSegmenter

NS = 1_000_000_000
T0 = 1_700_000_000 * NS  # epoch nanoseconds: a stamp like a real robot's
STORAGES = ("ros1", "sqlite3", "mcap", "plain-mcap")
UR_ALPHABETICAL = ["elbow_joint", "shoulder_lift_joint", "shoulder_pan_joint", "wrist_1_joint",
                   "wrist_2_joint", "wrist_3_joint"]
UR_CHAIN = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
            "wrist_3_joint"]

# Types the standard stores lack for one ROS version or the other; their definitions travel in the bag.
_EXTRA_TYPES = {
    "control_msgs/msg/GripperCommand": "float64 position\nfloat64 max_effort\n",
    "tf2_msgs/msg/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
}


TYPESTORES = {True: typestore(True, _EXTRA_TYPES), False: typestore(False, _EXTRA_TYPES)}


# ---------------------------------------------------------------- building messages


def _vec(ts, name, xyz):
    return ts.types[name](**dict(zip("xyz", map(float, xyz), strict=False)))


def _quat(ts, q):
    return ts.types["geometry_msgs/msg/Quaternion"](**dict(zip("xyzw", map(float, q), strict=True)))


def _transform(ts, stamp, parent, child, xyz, q):
    tr = ts.types["geometry_msgs/msg/Transform"](translation=_vec(ts, "geometry_msgs/msg/Vector3", xyz),
                                                 rotation=_quat(ts, q))
    return ts.types["geometry_msgs/msg/TransformStamped"](header=header(ts, stamp, parent),
                                                          child_frame_id=child, transform=tr)


def _message(ts, msgtype: str, stamp: int, value):
    """A message of ``msgtype`` stamped ``stamp`` (ns) carrying ``value`` (its numbers)."""
    if msgtype in ("sensor_msgs/msg/JointState", "geometry_msgs/msg/PoseStamped",
                   "geometry_msgs/msg/WrenchStamped"):
        return message(ts, msgtype, stamp, value)  # as the examples' recordings build them
    cls = ts.types[msgtype]
    if msgtype == "geometry_msgs/msg/TransformStamped":
        return _transform(ts, stamp, *value)
    if msgtype == "tf2_msgs/msg/TFMessage":
        return cls(transforms=[_transform(ts, stamp, *v) for v in value])
    if msgtype == "control_msgs/msg/GripperCommand":
        return cls(position=float(value), max_effort=10.0)
    if msgtype in ("std_msgs/msg/Float64", "std_msgs/msg/Bool", "std_msgs/msg/String"):
        return cls(data=value)
    if msgtype == "std_msgs/msg/Empty":
        return cls()
    raise AssertionError(msgtype)


def write_bag(folder, storage: str, recording: dict, name: str = "rec"):
    """Write ``{topic: (msgtype, [(stamp_ns, log_ns, value), ...])}`` with rosbags' own writers; return the
    path to read.

    ``storage`` is ``"ros1"`` (a .bag), ``"sqlite3"`` or ``"mcap"`` (ROS 2
    bag folders), or ``"plain-mcap"`` (the .mcap file alone).
    """
    path = folder / {"ros1": f"{name}.bag", "plain-mcap": f"{name}.mcap"}.get(storage, name)
    return _write_bag(path, storage, recording, ts=TYPESTORES[storage == "ros1"], build=_message)


def raises_format(path, match: str):
    """A one-line FormatError about ``path`` matching ``match``."""
    return pytest.raises(FormatError, match=f"^cannot read '{re.escape(str(path))}': {match}")


def jittered_clock(rng, rate: float, duration: float, start: float = 0.0) -> np.ndarray:
    """Sample times at ``rate`` Hz, each moved by up to 20 % of a period, strictly increasing."""
    n = int(duration * rate) + 1
    t = start + (np.arange(n) + rng.uniform(-0.2, 0.2, n)) / rate
    return t[(t >= start) & (t <= start + duration)]


def stamped(t, values, *, delay=0.001):
    """``(stamp_ns, log_ns, value)`` triples: the log time lags the stamp, as a recorder's does."""
    ns = T0 + np.round(np.asarray(t) * NS).astype(np.int64)
    lag = round(delay * NS)  # added as integers: epoch nanoseconds do not fit a float64 exactly
    return [(int(s), int(s) + lag, v) for s, v in zip(ns, values, strict=True)]


# ---------------------------------------------------------------- the three-button recording, re-recorded


def _raw_three_button(data_dir):
    """The file's groups as recorded: {group: (clock seconds from the joints' start, {dataset: data})}."""
    with h5py.File(data_dir / "seed" / "three_button_pressing_demo.h5", "r") as h5:
        groups = {g: {k: h5[g][k][()] for k in h5[g]} for g in h5}
    clock = {g: next(v for k, v in d.items() if k.endswith("_time")) for g, d in groups.items()}
    start = clock["joint_state_info"][0]
    # Whole seconds first: epoch seconds in float64 would lose the nanoseconds.
    seconds = {g: (c[:, 0] - start[0]) + (c[:, 1] - start[1]) * 1e-9 for g, c in clock.items()}
    return {g: (seconds[g], groups[g]) for g in groups}


def three_button_recording(data_dir, rates=None, seed=0, duration=None):
    """The three-button demonstration as topics (and the same per-sensor clocks and data, as HDF5 groups).

    ``rates=None`` keeps every sensor's own recorded clock; otherwise
    ``{"joints": 500, "pose": 125, "wrench": 100, "gripper": 30}`` resamples
    each sensor named (linearly from the recording, orientation by SLERP)
    onto a jittered clock of that rate. ``duration`` keeps the first seconds.
    """
    from skillbank.core import slerp

    raw = _raw_three_button(data_dir)
    rng = np.random.default_rng(seed)
    t_joint = raw["joint_state_info"][0]
    joints = np.unwrap(raw["joint_state_info"][1]["joint_positions"], axis=0)
    sensors = {
        "joints": (t_joint, {"joints": joints}),
        "pose": (raw["transform_info"][0], {
            "position": raw["transform_info"][1]["transform_positions"],
            "orientation": raw["transform_info"][1]["transform_orientations"]}),
        "wrench": (raw["wrench_info"][0], {"force": raw["wrench_info"][1]["wrench_force"],
                                           "torque": raw["wrench_info"][1]["wrench_torque"]}),
        "gripper": (raw["gripper_info"][0], {"gripper": raw["gripper_info"][1]["gripper_position"]}),
    }
    if rates is not None:
        span = (t_joint[0], t_joint[-1])
        for name, (t_k, data) in list(sensors.items()):
            if name not in rates:
                continue
            t_new = jittered_clock(rng, rates[name], span[1] - span[0], span[0])
            sensors[name] = (t_new, {
                k: slerp(t_k, v, t_new) if k == "orientation" else
                np.column_stack([np.interp(t_new, t_k, c) for c in v.reshape(len(t_k), -1).T])
                for k, v in data.items()})
    if duration is not None:
        sensors = {name: (t[t <= duration], {k: v[t <= duration] for k, v in data.items()})
                   for name, (t, data) in sensors.items()}
    t, d = sensors["joints"]
    recording = {"/joint_states": ("sensor_msgs/msg/JointState",
                                   stamped(t, [(UR_ALPHABETICAL, q) for q in d["joints"]]))}
    t, d = sensors["pose"]
    recording["/tool_pose"] = ("geometry_msgs/msg/PoseStamped",
                               stamped(t, list(zip(d["position"], d["orientation"], strict=True))))
    t, d = sensors["wrench"]
    recording["/ft"] = ("geometry_msgs/msg/WrenchStamped",
                        stamped(t, list(zip(d["force"], d["torque"], strict=True))))
    t, d = sensors["gripper"]
    recording["/gripper/joint_states"] = ("sensor_msgs/msg/JointState",
                                          stamped(t, [(["finger_joint"], g) for g in d["gripper"]]))
    return recording, sensors


def write_robot_h5(path, sensors):
    """The same sensors, clocks and data in the robot HDF5 layout (one group and clock per sensor)."""
    layout = {"joints": ("joint_state_info", "joint_time", {"joints": "joint_positions"}),
              "pose": ("transform_info", "transform_time", {"position": "transform_positions",
                                                            "orientation": "transform_orientations"}),
              "wrench": ("wrench_info", "wrench_time", {"force": "wrench_force", "torque": "wrench_torque"}),
              "gripper": ("gripper_info", "gripper_time", {"gripper": "gripper_position"})}
    with h5py.File(path, "w") as h5:
        for name, (group, clock, datasets) in layout.items():
            t, data = sensors[name]
            ns = T0 + np.round(t * NS).astype(np.int64)
            h5[f"{group}/{clock}"] = np.column_stack([ns // NS, ns % NS]).astype(float)
            for key, dataset in datasets.items():
                h5[f"{group}/{dataset}"] = data[key]
    return path


# ---------------------------------------------------------------- a synthetic recording with known answers


def _wrap(angle):
    return np.angle(np.exp(1j * np.asarray(angle)))


def synthetic(seed=0, duration=2.0, extra=None):
    """Joints at 500 Hz, a pose at 125 Hz, a wrench at 100 Hz and a gripper at 30 Hz, all jittered.

    Every value is linear in time (the orientation turns about z at a
    constant rate), so interpolation reproduces it exactly inside each
    topic's time range. Joint ``a`` crosses pi (stored wrapped); every
    third joints message lists the joints in the other order.
    """
    rng = np.random.default_rng(seed)
    clocks = {name: jittered_clock(rng, rate, duration) for name, rate in
              (("joints", 500), ("pose", 125), ("wrench", 100), ("gripper", 30))}
    t = clocks["joints"]
    joints = [(["b", "a"], [0.3 * s, _wrap(np.pi - 0.5 + s)]) if k % 3 != 1 else
              (["a", "b"], [_wrap(np.pi - 0.5 + s), 0.3 * s]) for k, s in enumerate(t)]
    t = clocks["pose"]
    pose = [((s, 2 * s, -s), (0.0, 0.0, np.sin(0.4 * s), np.cos(0.4 * s))) for s in t]
    t = clocks["wrench"]
    wrench = [((s, 0.0, 1.0), (0.0, -s, 0.0)) for s in t]
    t = clocks["gripper"]
    gripper = [(["finger"], [10.0 * s]) for s in t]
    recording = {
        "/joint_states": ("sensor_msgs/msg/JointState", stamped(clocks["joints"], joints)),
        "/tool_pose": ("geometry_msgs/msg/PoseStamped", stamped(clocks["pose"], pose)),
        "/ft": ("geometry_msgs/msg/WrenchStamped", stamped(clocks["wrench"], wrench)),
        "/gripper/joint_states": ("sensor_msgs/msg/JointState", stamped(clocks["gripper"], gripper)),
        "/chatter": ("std_msgs/msg/String", stamped([0.5], ["hello"])),
    }
    recording.update(extra or {})
    return recording, clocks


def _inside(demo, start, clock):
    """Which samples of ``demo`` (time base from ``start``) are in ``clock``'s range, and their times."""
    t = demo.t + start
    return (t >= clock[0] - 1e-9) & (t <= clock[-1] + 1e-9), t


@pytest.mark.parametrize("storage", STORAGES)
def test_every_storage_reads_back_the_known_streams(tmp_path, storage):
    recording, clocks = synthetic()
    path = write_bag(tmp_path, storage, recording)
    demo, = read_rosbag(path)
    meta = demo.metadata
    expected = {"ros1": "ros1-bag", "sqlite3": "ros2-bag", "mcap": "ros2-bag", "plain-mcap": "mcap"}[storage]
    assert meta["format"] == expected == detect_format(path)
    assert demo.stream_names == ["force", "torque", "gripper", "joints", "position", "orientation"]
    assert meta["reference"] == "/joint_states" and meta["joint_names"] == ["b", "a"]
    assert meta["column_names"] == {"gripper": ["finger"]}
    assert meta["skipped_topics"] == {"/chatter": "std_msgs/msg/String"}
    assert meta["streams"]["position"] == meta["streams"]["orientation"] == "/tool_pose"
    # The time base is the joints' own header clock.
    t = clocks["joints"]
    assert demo.n_steps == t.size and meta["t0"] == pytest.approx(T0 / NS + t[0], abs=1e-6)
    np.testing.assert_allclose(demo.t, t - t[0], atol=1e-9)
    # Joints by name whatever the message's order, unwrapped across pi.
    np.testing.assert_allclose(demo["joints"], np.column_stack([0.3 * t, np.pi - 0.5 + t]), atol=1e-9)
    inside, tt = _inside(demo, t[0], clocks["pose"])
    np.testing.assert_allclose(demo["position"][inside], np.column_stack([tt, 2 * tt, -tt])[inside],
                               atol=1e-9)
    angle = 0.4 * tt[inside]
    expected = np.column_stack([0 * angle, 0 * angle, np.sin(angle), np.cos(angle)])
    np.testing.assert_allclose(demo["orientation"][inside], expected, atol=1e-9)
    # Before the pose's first message the first one is held.
    first = clocks["pose"][0]
    np.testing.assert_allclose(demo["position"][tt < first], [[first, 2 * first, -first]], atol=1e-9)
    inside, tt = _inside(demo, t[0], clocks["wrench"])
    np.testing.assert_allclose(demo["force"][inside, 0], tt[inside], atol=1e-9)
    np.testing.assert_allclose(demo["torque"][inside, 1], -tt[inside], atol=1e-9)
    inside, tt = _inside(demo, t[0], clocks["gripper"])
    np.testing.assert_allclose(demo["gripper"][inside, 0], 10 * tt[inside], atol=1e-9)  # measured: linear
    report = meta["topics"]
    rates = {"/joint_states": 500, "/tool_pose": 125, "/ft": 100, "/gripper/joint_states": 30}
    for topic, rate in rates.items():
        assert report[topic]["rate_hz"] == pytest.approx(rate, rel=0.03)
        assert report[topic]["clock"] == "header" and report[topic]["n_gaps"] == 0
        assert report[topic]["max_gap"] < 1.5 / rate
    assert report["/tool_pose"]["stream"] == "pose" and report["/tool_pose"]["type"].endswith("PoseStamped")
    assert json.loads(json.dumps(meta, allow_nan=False)) == meta  # a library stores metadata as JSON


def test_a_ros2_storage_file_alone(tmp_path):
    recording, clocks = synthetic(duration=0.5)
    folder = write_bag(tmp_path, "sqlite3", recording)
    db3 = next(folder.glob("*.db3"))
    assert detect_format(db3) == "ros2-bag"
    demo, = load_all(db3)
    assert demo.n_steps == clocks["joints"].size and demo.metadata["source"] == str(db3)


def _only(recording, *topics):
    return {k: v for k, v in recording.items() if k in topics}


def test_options_reference_rate_and_hand_mapping(tmp_path):
    recording, clocks = synthetic()
    level = [(0.1 * k, 0.1 * k) for k in range(21)]
    recording["/level"] = ("std_msgs/msg/Float64", stamped([s for s, _ in level], [v for _, v in level]))
    path = write_bag(tmp_path, "mcap", recording)
    by_pose, = read_rosbag(path, reference="/tool_pose")
    assert by_pose.n_steps == clocks["pose"].size
    assert read_rosbag(path, reference="orientation")[0].n_steps == clocks["pose"].size
    at_100, = read_rosbag(path, rate=100)
    span = clocks["joints"][-1] - clocks["joints"][0]
    assert at_100.n_steps == int(np.floor(span * 100)) + 1 and at_100.metadata["rate_hz"] == 100
    np.testing.assert_allclose(np.diff(at_100.t), 0.01, atol=1e-12)
    t = at_100.t + clocks["joints"][0]
    np.testing.assert_allclose(at_100["joints"][:, 0], 0.3 * t, atol=1e-9)
    # By hand: any other name makes a stream of that name; the list form is the command line's.
    demo, = read_rosbag(path, topics=["/joint_states=arm", "/ft=wrench", "/level=level"])
    assert demo.stream_names == ["arm", "force", "torque", "level"]
    assert demo.metadata["reference"] == "/joint_states"  # no 'joints' stream: the topic with most messages
    assert demo.metadata["column_names"] == {"arm": ["b", "a"]}
    level_report = demo.metadata["topics"]["/level"]
    assert level_report["clock"] == "log" and not level_report["gaps_checked"] and not level_report["held"]
    t = demo.t + clocks["joints"][0] - 0.001  # a Float64 has no header: its clock is the log time, 1 ms late
    np.testing.assert_allclose(demo["level"][:, 0], np.clip(t, 0.0, 2.0), atol=1e-9)


def test_reference_defaults_to_the_busiest_topic(tmp_path):
    recording, clocks = synthetic()
    path = write_bag(tmp_path, "sqlite3", recording)
    demo, = read_rosbag(path, topics={"/ft": "wrench", "/tool_pose": "pose"})
    assert demo.metadata["reference"] == "/tool_pose" and demo.n_steps == clocks["pose"].size


def test_zero_stamps_fall_back_to_log_time(tmp_path):
    recording, clocks = synthetic()
    msgtype, items = recording["/ft"]
    recording["/ft"] = (msgtype, [(0 if k % 2 else s, log, v) for k, (s, log, v) in enumerate(items)])
    path = write_bag(tmp_path, "ros1", recording)
    demo, = read_rosbag(path, reference="/ft")
    assert demo.metadata["topics"]["/ft"]["clock"] == "header+log"
    stamps = np.array([log if k % 2 else s for k, (s, log, _) in enumerate(items)])
    np.testing.assert_allclose(demo.t, (stamps - stamps[0]) / NS, atol=1e-9)


def test_transforms_from_tf_for_named_frames(tmp_path):
    recording, clocks = synthetic()
    tf = [[("base", "tool0", (s, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)),
           ("base", "camera", (9.0, 9.0, 9.0), (0, 0, 0, 1))] for s in clocks["pose"]]
    pairs = [("/base", "flange", (s, 1.0, 0.0), (0.0, 0.0, 0.0, 1.0)) for s in clocks["pose"]]
    recording = {**_only(recording, "/joint_states"),
                 "/tf": ("tf2_msgs/msg/TFMessage", stamped(clocks["pose"], tf)),
                 "/tool_tf": ("geometry_msgs/msg/TransformStamped", stamped(clocks["pose"], pairs))}
    for storage in ("ros1", "mcap"):
        path = write_bag(tmp_path, storage, recording, name=storage)
        demo, = read_rosbag(path, topics={"/joint_states": "joints", "/tf": "pose"}, parent_frame="/base",
                            child_frame="tool0")
        inside, t = _inside(demo, clocks["joints"][0], clocks["pose"])
        np.testing.assert_allclose(demo["position"][inside, 0], t[inside], atol=1e-9)
        assert demo.metadata["topics"]["/tf"]["type"] == "tf2_msgs/msg/TFMessage"
        # Without frames the default mapping leaves /tf aside; with them, /tf is the pose.
        with raises_format(path, r"several topics could give 'pose' \(/tf, /tool_tf\)"):
            read_rosbag(path, parent_frame="base", child_frame="tool0")
        demo, = read_rosbag(path, topics={"/joint_states": "joints", "/tool_tf": "pose"})
        np.testing.assert_allclose(demo["position"][inside, 1], 1.0)
        assert read_rosbag(path, topics=["/joint_states=joints"])[0].stream_names == ["joints"]
        with raises_format(path, r"topic '/tf' holds transforms between many frames: name the pose with "):
            read_rosbag(path, topics={"/joint_states": "joints", "/tf": "pose"})
        with raises_format(path, r"no transform from 'base' to 'gripper' on '/tf'; it holds \[base->camera, "
                                 r"base->tool0\]"):
            read_rosbag(path, topics={"/joint_states": "joints", "/tf": "pose"}, parent_frame="base",
                        child_frame="gripper")
    mixed = {"/pose_tf": ("geometry_msgs/msg/TransformStamped",
                          stamped([0.0, 0.1, 0.2], [("base", c, (0, 0, 0), (0, 0, 0, 1)) for c in "aba"]))}
    path = write_bag(tmp_path, "sqlite3", mixed, name="mixed")
    with raises_format(path, r"topic '/pose_tf' holds transforms between several frames \[base->a, "
                             r"base->b\]: name one with parent_frame and child_frame"):
        read_rosbag(path)
    demo, = read_rosbag(path, parent_frame="base", child_frame="a")
    np.testing.assert_allclose(demo.t, [0.0, 0.2])


def test_commands_are_held_and_their_gaps_only_reported(tmp_path):
    recording, clocks = synthetic()
    command = ("control_msgs/msg/GripperCommand", stamped([0.2, 1.0], [0.0, 0.08]))
    recording = {**_only(recording, "/joint_states"), "/gripper_cmd": command}
    path = write_bag(tmp_path, "mcap", recording)
    demo, = read_rosbag(path)
    t = demo.t + clocks["joints"][0]
    log = t - 0.001  # a command has no header: its log time (1 ms after the stamp written) is its clock
    np.testing.assert_array_equal(demo["gripper"][:, 0], np.where(log >= 1.0, 0.08, 0.0))
    report = demo.metadata["topics"]["/gripper_cmd"]
    assert report["held"] and not report["gaps_checked"]
    assert report["n_gaps"] == 2 and report["clock"] == "log"
    # A gripper that reports open or closed as a JointState: hold it by name.
    recording, clocks = synthetic()
    path = write_bag(tmp_path, "mcap", recording, name="held")
    demo, = read_rosbag(path, hold=["gripper"])
    inside, t = _inside(demo, clocks["joints"][0], clocks["gripper"])
    last = np.searchsorted(clocks["gripper"], t[inside] + 1e-12, side="right") - 1
    np.testing.assert_allclose(demo["gripper"][inside, 0], 10 * clocks["gripper"][last], atol=1e-6)


def _with_hole(recording, topic, start, stop):
    msgtype, items = recording[topic]
    keep = [(s, log, v) for s, log, v in items if not start * NS <= s - T0 < stop * NS]
    return {**recording, topic: (msgtype, keep)}


def test_gaps_are_rejected_warned_or_split(tmp_path):
    recording, clocks = synthetic(duration=3.0)
    holed = _with_hole(_with_hole(recording, "/joint_states", 1.0, 2.0), "/ft", 1.0, 2.0)
    path = write_bag(tmp_path, "ros1", holed)
    with raises_format(path, r"topic '/ft' has 1 gap\(s\) longer than max_gap=0.5 s, the first from 0.99\d s "
                             r"to 2.00\d s \(longest 1.0\d\d s\); raise max_gap, read with on_gap='warn', or "
                             r"split='gaps'"):
        read_rosbag(path)
    with pytest.warns(UserWarning, match=r"topic '/(ft|joint_states)' has 1 gap"):
        demo, = read_rosbag(path, on_gap="warn")
    assert demo.metadata["topics"]["/joint_states"]["n_gaps"] == 1
    assert read_rosbag(path, max_gap=1.5)[0].metadata["topics"]["/ft"]["gaps"] == []
    first, second = read_rosbag(path, split="gaps")
    assert first.metadata["index"] == 0 and second.metadata["index"] == 1
    assert first.metadata["split"][1] < 1.0 < 2.0 <= second.metadata["split"][0] + clocks["joints"][0] + 1e-3
    offset = second.metadata["t0"] - first.metadata["t0"]
    assert offset == pytest.approx(second.metadata["split"][0], abs=1e-6)
    assert first.n_steps + second.n_steps == np.sum((clocks["joints"] < 1.0) | (clocks["joints"] >= 2.0))
    # A topic that starts late has a gap at the start of the time base.
    late = _with_hole(recording, "/ft", 0.0, 1.0)
    path = write_bag(tmp_path, "mcap", late, name="late")
    with raises_format(path, r"topic '/ft' has 1 gap\(s\) .* the first from 0.000 s to 1.00\d s"):
        read_rosbag(path)


def test_split_by_time_ranges_and_markers(tmp_path):
    recording, clocks = synthetic(duration=3.0)
    # True opens, False closes; a second True while open changes nothing.
    marker = ("std_msgs/msg/Bool", stamped([0.5, 0.8, 1.2, 2.0, 2.5], [True, True, False, True, False]))
    starts = ("std_msgs/msg/Empty", stamped([0.25, 1.75], [None, None]))
    path = write_bag(tmp_path, "mcap", {**recording, "/recording": marker, "/start": starts})
    ranges = read_rosbag(path, split=[(0.0, 0.5), (1.0, 1.8)])
    assert [d.n_steps for d in read_rosbag(path, split="0:0.5,1:1.8")] == [d.n_steps for d in ranges]
    t = clocks["joints"] - clocks["joints"][0]
    assert [d.n_steps for d in ranges] == [np.sum(t < 0.5), np.sum((t >= 1.0) & (t < 1.8))]
    assert ranges[1].metadata["split"][0] == pytest.approx(t[t >= 1.0][0], abs=1e-9)
    pieces = read_rosbag(path, split="/recording")
    stamps = clocks["joints"] + 0.0  # the marker is stamped on the same clock as the joints
    assert [d.n_steps for d in pieces] == [np.sum((stamps >= 0.5) & (stamps < 1.2)), np.sum((stamps >= 2.0) &
                                                                                           (stamps < 2.5))]
    # A marker of any other type starts a demonstration lasting until the next; before the first is dropped.
    opened = read_rosbag(path, split="/start")
    logs = stamps  # std_msgs/Empty has no header: its log time, 1 ms after 0.25 s and 1.75 s
    assert [d.n_steps for d in opened] == [np.sum((logs >= 0.251) & (logs < 1.751)), np.sum(logs >= 1.751)]
    with pytest.raises(ValueError, match=r"split: expected at least 2 samples of the reference "
                                         r"'/joint_states' in range 0 \(10 s to 20 s\), got 0"):
        read_rosbag(path, split=[(10, 20)])
    with raises_format(path, r"marker topic '/nowhere' is not in the bag; its topics are \['/chatter', "):
        read_rosbag(path, split="/nowhere")


def test_joint_order_ur_chain_and_by_name(tmp_path):
    t = np.linspace(0, 1, 50)
    values = [(UR_ALPHABETICAL, np.arange(6.0) * 0.1 + s) for s in t]
    path = write_bag(tmp_path, "mcap", {"/joint_states": ("sensor_msgs/msg/JointState", stamped(t, values))})
    demo, = read_rosbag(path)
    assert demo.metadata["joint_names"] == UR_CHAIN
    np.testing.assert_allclose(demo["joints"][0], [0.2, 0.1, 0.0, 0.3, 0.4, 0.5])
    demo, = read_rosbag(path, joint_names=["wrist_3_joint", "elbow_joint"])
    assert demo.metadata["joint_names"] == ["wrist_3_joint", "elbow_joint"]
    np.testing.assert_allclose(demo["joints"][0], [0.5, 0.0])
    with raises_format(path, r"joints \['knee'\] are not on '/joint_states', which has \['elbow_joint'"):
        read_rosbag(path, joint_names=["knee"])


def test_load_all_and_load_pass_reader_options(tmp_path):
    recording, _ = synthetic()
    path = write_bag(tmp_path, "ros1", recording)
    demos = load_all(path, reader_options={"topics": ["/ft=wrench"], "episodes": "0:3"})
    assert [d.stream_names for d in demos] == [["force", "torque"]]
    assert load(path, reader_options={"split": [(0, 0.5), (1, 1.5)]}, index=1).metadata["index"] == 1
    with pytest.raises(ValueError, match=r"reader_options: expected names among \[.*'topics'.*\], got "
                                         r"unknown \['topic'\]"):
        load_all(path, reader_options={"topic": "/ft"})


# ---------------------------------------------------------------- what cannot be read: one line each


@pytest.mark.parametrize("storage", STORAGES)
def test_truncated_bags(tmp_path, storage):
    recording, _ = synthetic(duration=0.5)
    path = write_bag(tmp_path, storage, recording)
    data_file = path if path.is_file() else next(f for f in path.iterdir() if f.suffix in (".db3", ".mcap"))
    data_file.write_bytes(data_file.read_bytes()[: data_file.stat().st_size // 2])
    reason = {"ros1": "Bag index looks damaged", "sqlite3": "database disk image is malformed",
              "mcap": "File end magic is invalid", "plain-mcap": "File end magic is invalid"}[storage]
    with raises_format(path, f"unreadable ROS bag: .*{reason}"):
        read_rosbag(path)
    with raises_format(path, f"unreadable ROS bag: .*{reason}"):
        load_all(path)


def test_files_that_are_not_bags(tmp_path):
    text = tmp_path / "notes.bag"
    text.write_text("not a bag\n")
    with raises_format(text, "expected a ros1-bag file, found a text file$"):
        read_rosbag(text)
    with raises_format(text, "expected a ros1-bag file, found a text file$"):
        detect_format(text)
    zeros = tmp_path / "zeros.mcap"
    zeros.write_bytes(b"\x00" * 64)
    with raises_format(zeros, "expected a mcap file, found binary data$"):
        load_all(zeros)
    with raises_format(tmp_path / "absent.bag", "no such file or folder$"):
        read_rosbag(tmp_path / "absent.bag")
    with raises_format(tmp_path, "expected a ROS 2 bag folder holding metadata.yaml, found a folder without"):
        read_rosbag(tmp_path)
    with raises_format(tmp_path, "expected a file, found a directory that is neither a ROS 2 bag"):
        load_all(tmp_path)
    other = tmp_path / "demo.csv"
    other.write_text("t,x\n0,1\n")
    with raises_format(other, r"expected a ROS bag \(.bag, .mcap, .db3 or a ROS 2 bag folder\), found "
                              "extension '.csv'$"):
        read_rosbag(other)
    recording, _ = synthetic(duration=0.2)
    path = write_bag(tmp_path, "sqlite3", recording)
    (path / "metadata.yaml").write_text("rosbag2_bagfile_information: [unclosed\n")
    with raises_format(path, "unreadable ROS bag: Could not load YAML"):
        read_rosbag(path)
    unknown = tmp_path / "demo.xyz"
    unknown.write_text("t,x\n0,1\n")
    with raises_format(unknown, r"unknown extension '.xyz': expected one of .csv, .h5, .*, a recording "
                                r"\(.bag, .mcap, .db3\) or a folder \(ROS 2 bag, LeRobot dataset\)$"):
        detect_format(unknown)


def test_topics_and_types_that_do_not_map(tmp_path):
    recording, _ = synthetic(duration=0.3)
    path = write_bag(tmp_path, "mcap", recording)
    with raises_format(path, r"topic '/joints' is not in the bag; its topics are \['/chatter', '/ft', "):
        read_rosbag(path, topics={"/joints": "joints"})
    with raises_format(path, r"topic '/chatter' has message type 'std_msgs/msg/String', which has no mapping "
                             r"to stream 'joints': expected one of \[sensor_msgs/msg/JointState\]$"):
        read_rosbag(path, topics={"/chatter": "joints"})
    with raises_format(path, r"topic '/ft' has message type 'geometry_msgs/msg/WrenchStamped', which has no "
                             r"mapping to stream 'pose': expected one of \[geometry_msgs/msg/Pose, "):
        read_rosbag(path, topics={"/ft": "pose"})
    with raises_format(path, r"topic '/chatter' has message type 'std_msgs/msg/String', which has no mapping "
                             r"to stream 'words'"):
        read_rosbag(path, topics={"/chatter": "words"})
    only_text = write_bag(tmp_path, "ros1", _only(recording, "/chatter"), name="text")
    with raises_format(only_text, r"no topic has a default mapping \(found /chatter "
                                  r"\(std_msgs/msg/String\)\): map topics by hand with "
                                  r"topics=\{'/joint_states': 'joints', \.\.\.\}$"):
        read_rosbag(only_text)
    two = {**recording, "/other_joints": recording["/joint_states"]}
    path = write_bag(tmp_path, "ros1", two, name="two")
    with raises_format(path, r"several topics could give 'joints' \(/joint_states, /other_joints\): choose "
                             r"one with topics=\{'/joint_states': 'joints', \.\.\.\}$"):
        read_rosbag(path)


def _written_connection_without_messages(path):
    ts = TYPESTORES[False]
    with Ros2Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        writer.add_connection("/ft", "geometry_msgs/msg/WrenchStamped", typestore=ts)
        conn = writer.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts)
        for stamp, log, value in stamped([0.0, 0.1], [(["a"], [0.0]), (["a"], [1.0])]):
            writer.write(conn, log, ts.serialize_cdr(_message(ts, "sensor_msgs/msg/JointState", stamp, value),
                                                    "sensor_msgs/msg/JointState"))
    return path


def test_bad_content(tmp_path):
    path = _written_connection_without_messages(tmp_path / "silent")
    with raises_format(path, "topic '/ft' holds no messages$"):
        read_rosbag(path)
    renamed = {"/joint_states": ("sensor_msgs/msg/JointState", stamped([0.0, 0.1, 0.2], [
        (["a", "b"], [0, 1]), (["a", "b"], [0, 1]), (["a", "c"], [0, 1])]))}
    path = write_bag(tmp_path, "ros1", renamed, name="renamed")
    with raises_format(path, r"topic '/joint_states': message 2 names joints \['a', 'c'\], expected the "
                             r"first message's \['a', 'b'\]$"):
        read_rosbag(path)
    short = {"/joint_states": ("sensor_msgs/msg/JointState", stamped([0.0, 0.1], [(["a", "b"], [0, 1]),
                                                                                 (["a", "b"], [0])]))}
    path = write_bag(tmp_path, "ros1", short, name="short")
    with raises_format(path, r"topic '/joint_states': expected 2 joint positions, message 1 has 1$"):
        read_rosbag(path)
    values = [(["a"], [v]) for v in range(4)]
    repeated = {"/joint_states": ("sensor_msgs/msg/JointState", stamped([0.0, 0.1, 0.1, 0.2], values))}
    path = write_bag(tmp_path, "mcap", repeated, name="repeated")
    with raises_format(path, r"topic '/joint_states' \(header clock\): expected strictly increasing time "
                             r"stamps, but sample 2 \(0.1 s\) repeats sample 1"):
        read_rosbag(path)
    demo, = read_rosbag(path, repair_time="drop")
    assert demo.n_steps == 3 and demo.metadata["dropped_samples"] == 1
    np.testing.assert_allclose(demo["joints"].ravel(), [0, 1, 3])
    unit = {"/joint_states": ("sensor_msgs/msg/JointState",
                              stamped([0.0, 0.2], [(["a"], [0]), (["a"], [1])])),
            "/tool_pose": ("geometry_msgs/msg/PoseStamped", stamped([0.0, 0.1, 0.2], [
                ((0, 0, 0), (0, 0, 0, 1)), ((0, 0, 0), (0, 0, 0, 0)), ((0, 0, 0), (0, 0, 0, 1))]))}
    path = write_bag(tmp_path, "mcap", unit, name="zero_quaternion")
    with raises_format(path, r"topic '/tool_pose', stream 'orientation': q: expected unit quaternions"):
        read_rosbag(path)


def test_duplicate_joint_names_are_refused(tmp_path):
    same = (["a", "b", "a"], [0, 1, 2])
    twice = {"/joint_states": ("sensor_msgs/msg/JointState", stamped([0.0, 0.1], [same, same]))}
    path = write_bag(tmp_path, "ros1", twice, name="twice")
    with raises_format(path, r"topic '/joint_states': message 0 names joint\(s\) 'a' more than once; "
                             "expected distinct joint names, one per position$"):
        read_rosbag(path)
    # a later message that repeats a name while it reorders: one of its positions would go unread
    messages = [(["a", "b"], [0, 1]), (["b", "a", "b"], [1, 0, 5])]
    later = {"/joint_states": ("sensor_msgs/msg/JointState", stamped([0.0, 0.1], messages))}
    path = write_bag(tmp_path, "mcap", later, name="later")
    with raises_format(path, r"topic '/joint_states': message 1 names joint\(s\) 'b' more than once"):
        read_rosbag(path)


def _flip_until_the_reader_asserts(path):
    """Flip one byte at a time of a ROS 1 bag until rosbags' own reader fails an assert on it.

    Every 5th byte: the fields the reader checks against each other (an index entry's time against its
    message's) are 8 of every 12 bytes, so a stride finds one as surely, in a fifth of the reads."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    data = path.read_bytes()
    for i in range(len(data) // 8, len(data), 5):  # past the header: an index or record field
        flipped = bytearray(data)
        flipped[i] ^= 0xFF
        path.write_bytes(bytes(flipped))
        try:
            with AnyReader([path], default_typestore=get_typestore(Stores.LATEST)) as reader:
                for _ in reader.messages():
                    pass
        except AssertionError:
            return i
        except Exception:  # noqa: BLE001, S112 - other damage: not the case this test is about
            continue
    raise AssertionError("no flipped byte makes rosbags assert")


def test_a_ros1_bag_with_a_flipped_byte_is_one_line(tmp_path, cli):
    recording, _ = synthetic(duration=0.3)
    path = write_bag(tmp_path, "ros1", recording)
    _flip_until_the_reader_asserts(path)
    reason = (r"unreadable ROS bag: its records contradict each other \(a consistency check of the reader "
              r"failed\), so the file is corrupt; 'rosbag reindex' may repair a copy of it$")
    with raises_format(path, reason):
        read_rosbag(path)
    code, out, err = cli("segment", path, "--json")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and "contradict each other" in err


@pytest.mark.parametrize(("options", "message"), [
    ({"topics": "/joint_states"}, r"topics: expected a mapping of topic to stream name or 'topic=stream' "
                                  r"strings, got '/joint_states'"),
    ({"topics": ["/joint_states"]}, r"topics: expected 'topic=stream' like '/joint_states=joints', got "
                                    r"'/joint_states'"),
    ({"topics": {"/a": ""}}, r"topics: expected non-empty topic and stream names, got '/a': ''"),
    ({"topics": []}, r"topics: expected at least one topic, got none"),
    ({"topics": {"/a": "pose", "/b": "position"}}, r"topics: expected each stream from one topic, got "
                                                   r"\['position'\] from several"),
    ({"rate": 0}, r"rate: expected a number > 0, got 0"),
    ({"max_gap": -1}, r"max_gap: expected a number > 0, got -1"),
    ({"on_gap": "ignore"}, r"on_gap: expected 'error' or 'warn', got 'ignore'"),
    ({"parent_frame": "base"}, r"parent_frame, child_frame: expected both or neither, got 'base' and None"),
    ({"joint_names": "a"}, r"joint_names: expected a list of joint names, got 'a'"),
    ({"split": "marker"}, r"split: expected None, 'gaps', a marker topic like '/marker', or \(start, stop\)"),
    ({"split": "0:1:2"}, r"split: expected None, 'gaps'.* got '0:1:2'"),
    ({"split": [(2, 1)]}, r"split: expected None, 'gaps'.* got \[\(2, 1\)\]"),
    ({"split": []}, r"split: expected None, 'gaps'"),
    ({"repair_time": "fix"}, r"repair_time: expected None"),
    ({"reference": "/nowhere"}, r"reference: expected a read topic or stream among \['/ft', .*'torque'\], "
                                r"got '/nowhere'"),
    ({"hold": ["force"]}, r"hold: expected names among the read streams \['gripper', 'joints'\], got "
                          r"\['force'\]"),
])
def test_bad_options(tmp_path, options, message):
    recording, _ = synthetic(duration=0.3)
    path = write_bag(tmp_path, "mcap", _only(recording, "/joint_states", "/ft", "/gripper/joint_states"))
    with pytest.raises(ValueError, match=message):
        read_rosbag(path, **options)


def test_missing_rosbags_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)
    with pytest.raises(ImportError, match=r"^reading ROS bags and MCAP files needs the 'rosbags' package: "
                                          r"pip install skillbank\[ros\]$"):
        read_rosbag(tmp_path / "any.bag")


def test_parse_topics_forms():
    assert parse_topics({"/a": "joints"}) == parse_topics(["/a=joints"]) == parse_topics((" /a = joints ",))
    assert parse_topics(["/x=anything"]) == {"/x": "anything"}


_NAME = st.text(st.characters(whitelist_categories=("L", "N"), whitelist_characters="_/"), min_size=1,
                max_size=12)


@given(st.dictionaries(_NAME, _NAME, min_size=1, max_size=5))
def test_topics_as_strings_mean_the_same_mapping(mapping):
    made = [s for name in mapping.values() for s in {"pose": ("position", "orientation"),
                                                      "wrench": ("force", "torque")}.get(name, (name,))]
    if len(made) != len(set(made)):
        with pytest.raises(ValueError, match="topics: expected each stream from one topic"):
            parse_topics(mapping)
    else:
        assert parse_topics([f"{t}={n}" for t, n in mapping.items()]) == parse_topics(mapping) == mapping


@given(st.lists(st.tuples(st.floats(-1e6, 1e6), st.floats(-1e6, 1e6)), min_size=1, max_size=4))
def test_split_ranges_need_start_before_stop(pairs):
    text = ",".join(f"{a!r}:{b!r}" for a, b in pairs)
    if all(a < b for a, b in pairs):
        assert check_split(pairs) == check_split(text) == [(float(a), float(b)) for a, b in pairs]
    else:
        with pytest.raises(ValueError, match="split: expected None, 'gaps'"):
            check_split(text)


# ---------------------------------------------------------------- the three-button demonstration


def _angle(q1, q2):
    """Rotation angle between unit quaternions, whatever their signs."""
    dots = np.abs(np.sum(q1 * q2, axis=1)) / (np.linalg.norm(q1, axis=1) * np.linalg.norm(q2, axis=1))
    return 2 * np.arccos(np.clip(dots, 0.0, 1.0))


def _segment(demo):
    """What ``skillbank segment`` computes, with its defaults."""
    return MultimodalSegmenter().fit(demo).result_


@pytest.mark.parametrize("storage", ["ros1", "plain-mcap"])
def test_three_button_on_its_recorded_clocks_reads_as_the_hdf5_file(data_dir, tmp_path, storage):
    recording, _ = three_button_recording(data_dir)
    bag, = read_rosbag(write_bag(tmp_path, storage, recording))
    h5 = read_robot_h5(data_dir / "seed" / "three_button_pressing_demo.h5")
    assert bag.metadata["joint_names"] == h5.metadata["joint_names"] == UR_CHAIN
    assert bag.stream_names == ["force", "torque", "gripper", "joints", "position", "orientation"]
    np.testing.assert_allclose(bag.t, h5.t, atol=1e-9)
    assert bag.metadata["t0"] == T0 / NS  # re-recorded from T0
    for name in h5.stream_names:
        np.testing.assert_allclose(bag[name], h5[name], atol=1e-9, err_msg=name)
    ours, theirs = _segment(bag), _segment(h5)
    assert ours.bounds == theirs.bounds


def test_three_button_at_other_rates_reads_as_the_same_recording_in_hdf5(data_dir, tmp_path):
    # Each sensor at its own rate with jitter, the same clocks and numbers in both containers.
    rates = {"joints": 500, "pose": 125, "wrench": 100, "gripper": 30}
    recording, sensors = three_button_recording(data_dir, rates, duration=15.0)
    bag, = read_rosbag(write_bag(tmp_path, "mcap", recording))
    h5 = read_robot_h5(write_robot_h5(tmp_path / "same.h5", sensors))
    report = bag.metadata["topics"]
    for topic, sensor in (("/joint_states", "joints"), ("/tool_pose", "pose"), ("/ft", "wrench"),
                          ("/gripper/joint_states", "gripper")):
        assert report[topic]["rate_hz"] == pytest.approx(rates[sensor], rel=0.01)
        assert report[topic]["max_gap"] < 1.4 / rates[sensor]
    np.testing.assert_allclose(bag.t, h5.t, atol=1e-9)
    for name in ("joints", "position", "force", "torque", "gripper"):
        np.testing.assert_allclose(bag[name], h5[name], atol=1e-9, err_msg=name)
    # SLERP against the HDF5 reader's interpolation of each quaternion component: 125 Hz steps differ little.
    assert _angle(bag["orientation"], h5["orientation"]).max() < 1e-4
    ours, theirs = _segment(bag), _segment(h5)
    assert ours.n_segments == theirs.n_segments > 1
    np.testing.assert_allclose(ours.keypoints, theirs.keypoints, atol=1)


def test_three_button_slower_sensors_against_the_recorded_file(data_dir, tmp_path):
    # The joints on the recorder's clock (the reference), the pose at 125 Hz and the gripper at 30 Hz.
    recording, _ = three_button_recording(data_dir, {"pose": 125, "gripper": 30})
    bag, = read_rosbag(write_bag(tmp_path, "ros1", recording))
    h5 = read_robot_h5(data_dir / "seed" / "three_button_pressing_demo.h5")
    np.testing.assert_allclose(bag.t, h5.t, atol=1e-9)
    for name in ("joints", "force", "torque"):
        np.testing.assert_allclose(bag[name], h5[name], atol=1e-9, err_msg=name)
    # Interpolation error: what sampling at the lower rate and interpolating back loses.
    span = np.ptp(h5["position"], axis=0).max()
    assert np.abs(bag["position"] - h5["position"]).max() < 1e-3 * span
    assert _angle(bag["orientation"], h5["orientation"]).max() < 2e-3
    assert np.abs(bag["gripper"] - h5["gripper"]).max() < 0.05 * np.ptp(h5["gripper"])
    ours, theirs = _segment(bag), _segment(h5)
    assert ours.n_segments == theirs.n_segments == 6
    # a rest sits in the middle of the speed's valley, which a pose interpolated from 125 Hz places to
    # within a period or two of the pose sensor (1.3 recorder samples each)
    pose_period = (1.0 / 125) / np.median(np.diff(h5.t))
    np.testing.assert_allclose(ours.keypoints, theirs.keypoints, atol=2 * pose_period)


# ---------------------------------------------------------------- the command line


def test_segment_command_reads_a_bag_with_its_options(tmp_path, cli):
    recording, _ = synthetic(duration=3.0)
    path = write_bag(tmp_path, "mcap", recording)
    code, out, err = cli("segment", path, "--json", "--topic", "/joint_states=joints",
                         "--topic", "/ft=wrench", "--split", "0:1.5,1.5:3")
    assert code == 0, err
    doc = json.loads(out)
    # two pieces of the bag by time range; the first is segmented, and the command says so
    assert doc["n_demos"] == 2 and doc["demo"] == 0
    assert set(doc["changepoints"]) == {"joints", "force", "torque"}
    assert "holds 2 demonstrations" in err


def test_segment_command_names_a_topic_that_is_not_there(tmp_path, cli):
    recording, _ = synthetic()
    path = write_bag(tmp_path, "ros1", recording)
    code, out, err = cli("segment", path, "--topic", "/nope=joints")
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and "/nope" in err


def test_library_add_reads_a_bag_with_hand_mapped_topics(tmp_path, cli):
    recording, _ = synthetic(duration=3.0)
    path = write_bag(tmp_path, "sqlite3", recording)
    db = tmp_path / "lib.sqlite"
    assert cli("library", "init", db)[0] == 0
    code, out, err = cli("library", "add", db, path, "--topic", "/tool_pose=pose", "--topic", "/ft=wrench",
                         "--whole", "--json")
    assert code == 0, err
    assert len(json.loads(out)["demonstrations"]) == 1
    code, out, err = cli("library", "add", db, path, "--topic", "/missing=pose")
    assert code == 2 and "/missing" in err and len(err.strip().splitlines()) == 1
