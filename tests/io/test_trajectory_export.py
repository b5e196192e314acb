"""Exports of an executable reproduction, each read back: CSV, NPZ, URScript, ROS 2 bag; all or nothing."""

from __future__ import annotations

import builtins
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.core import Demonstration, exp_map
from skillbank.io import TRAJECTORY_FORMATS, read_npz, trajectory_format, write_trajectory
from skillbank.io._trajectory_export import blended_joints
from skillbank.robots import UR5e

NAMES = list(UR5e.joint_names)


@pytest.fixture
def executable():
    """1.3 s, 40 uneven samples: pose, a gripper closing then opening, joints with their names, a force."""
    s = np.linspace(0.0, 1.0, 40)
    t = 1.3 * s + 0.01 * np.sin(np.pi * s)
    P = np.c_[0.4 + 0.1 * s, -0.2 + 0.2 * s, 0.3 - 0.1 * s]
    Q = exp_map(np.c_[0 * s, 0 * s, 0.8 * s], reference=[1.0, 0.0, 0.0, 0.0])
    gripper = np.where((s > 0.3) & (s < 0.7), 1.0, 0.0)
    joints = UR5e().ik(P, Q)
    return Demonstration(t, {"position": P, "orientation": Q, "gripper": gripper, "joints": joints,
                             "force": np.c_[s, -s, 2 * s]},
                         {"method": "ja", "joint_names": NAMES, "used": [3]})


def test_csv_has_every_stream_and_the_joint_names(executable, tmp_path):
    path = write_trajectory(executable, tmp_path / "out.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header == (["t", "position_0", "position_1", "position_2", "orientation_x", "orientation_y",
                       "orientation_z", "orientation_w", "gripper_0"] + [f"joints_{n}" for n in NAMES]
                      + ["force_0", "force_1", "force_2"])
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    expected = np.column_stack([executable.t] + list(executable.streams.values()))
    np.testing.assert_array_equal(table, expected)  # %.17g: exact


def test_npz_has_every_stream_and_the_joint_names(executable, tmp_path):
    back = read_npz(write_trajectory(executable, tmp_path / "out.npz"))
    assert back.stream_names == executable.stream_names and back.metadata["joint_names"] == NAMES
    for name in executable.streams:
        np.testing.assert_array_equal(back[name], executable[name])
    np.testing.assert_array_equal(back.t, executable.t)


@pytest.mark.parametrize("rate", [125.0, 500.0, 7.0])
def test_urscript_servoj_at_the_rate_and_gripper_at_its_switches(executable, tmp_path, rate):
    path = write_trajectory(executable, tmp_path / "arm.script", rate=rate)
    lines = [line.strip() for line in path.read_text().splitlines()]
    servo = [x for x in lines if x.startswith("servoj(")]
    duration = executable.t[-1] - executable.t[0]
    assert len(servo) == math.ceil(duration * rate) + 1
    assert all(f"t={1 / rate:.6g}," in x for x in servo)
    calls = [i for i, x in enumerate(lines) if x.startswith("skillbank_gripper(")]
    assert [lines[i] for i in calls] == [f"skillbank_gripper({v})" for v in (0, 1, 0)]
    # each call comes right before the servoj of the first control step at or after the recorded switch
    g = executable["gripper"][:, 0]
    switches = executable.t[np.flatnonzero(np.diff(g)) + 1]
    steps = [sum(x.startswith("servoj(") for x in lines[:i]) for i in calls[1:]]
    assert steps == [math.ceil((s - executable.t[0]) * rate - 1e-9) for s in switches]
    # the first and last servoj are the trajectory's first and last configurations; movej goes to the first
    first = np.array(servo[0][len("servoj(["):servo[0].index("]")].split(","), dtype=float)
    last = np.array(servo[-1][len("servoj(["):servo[-1].index("]")].split(","), dtype=float)
    np.testing.assert_allclose(first, executable["joints"][0], atol=1e-9)
    np.testing.assert_allclose(last, executable["joints"][-1], atol=1e-9)
    movej = next(x for x in lines if x.startswith("movej("))
    assert movej[len("movej("):movej.index("]") + 1] == servo[0][len("servoj("):servo[0].index("]") + 1]
    assert "set_tool_digital_out(0, value > 0.5)" in lines and lines[-1] == "skillbank_trajectory()"
    assert lines.index("def skillbank_gripper(value):") < calls[0]


def test_urscript_gripper_command_is_configurable(executable, tmp_path):
    path = write_trajectory(executable, tmp_path / "arm.urscript",
                            gripper_command="rq_move_norm(value * 100)  # Robotiq, threshold {threshold}")
    text = path.read_text()
    assert "    rq_move_norm(value * 100)  # Robotiq, threshold 0.5" in text
    assert "set_tool_digital_out" not in text


def test_rosbag_read_back_with_rosbags(executable, tmp_path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    path = write_trajectory(executable, tmp_path / "bag", format="rosbag", start_time=1700000000.25)
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
        assert topics == {"/joint_trajectory": "trajectory_msgs/msg/JointTrajectory",
                          "/pose": "geometry_msgs/msg/PoseStamped",
                          "/gripper/joint_states": "sensor_msgs/msg/JointState"}
        msgs = {topic: [] for topic in topics}
        for conn, stamp, raw in reader.messages():
            msgs[conn.topic].append((stamp, reader.deserialize(raw, conn.msgtype)))
    [(_, traj)] = msgs["/joint_trajectory"]
    assert list(traj.joint_names) == NAMES and len(traj.points) == executable.n_steps
    np.testing.assert_array_equal(np.array([p.positions for p in traj.points]), executable["joints"])
    from_start = np.array([p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in traj.points])
    np.testing.assert_allclose(from_start, executable.t - executable.t[0], atol=1e-9)
    poses = msgs["/pose"]
    assert len(poses) == executable.n_steps
    P = np.array([[m.pose.position.x, m.pose.position.y, m.pose.position.z] for _, m in poses])
    Q = np.array([[m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z, m.pose.orientation.w]
                  for _, m in poses])
    np.testing.assert_array_equal(P, executable["position"])
    np.testing.assert_array_equal(Q, executable["orientation"])
    stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for _, m in poses])
    np.testing.assert_allclose(stamps - 1700000000.25, executable.t - executable.t[0], atol=1e-6)
    assert {m.header.frame_id for _, m in poses} == {"base"}
    grips = msgs["/gripper/joint_states"]
    assert [list(m.name) for _, m in grips] == [["gripper"]] * executable.n_steps
    np.testing.assert_array_equal([m.position[0] for _, m in grips], executable["gripper"][:, 0])
    assert [s for s, _ in grips] == [s for s, _ in poses]


def _trapezoid(rate, t):
    """The running integral of ``rate (n, k)`` over ``t`` from 0, by the trapezoidal rule."""
    steps = 0.5 * (rate[1:] + rate[:-1]) * np.diff(t)[:, None]
    return np.vstack([np.zeros((1, rate.shape[1])), np.cumsum(steps, axis=0)])


def test_rosbag_points_carry_velocities_and_accelerations_that_integrate_to_the_positions(executable,
                                                                                         tmp_path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    path = write_trajectory(executable, tmp_path / "bag", format="rosbag")
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        [(conn, _, raw)] = [m for m in reader.messages() if m[0].topic == "/joint_trajectory"]
        traj = reader.deserialize(raw, conn.msgtype)
    Q, V, A = (np.array([getattr(p, k) for p in traj.points]) for k in ("positions", "velocities",
                                                                          "accelerations"))
    t = np.array([p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in traj.points])
    assert Q.shape == V.shape == A.shape == (executable.n_steps, 6)
    # the joints turn by up to ~1 rad over 40 uneven samples: the trapezoidal rule is good to ~1e-4 rad
    span = np.ptp(Q, axis=0).max()
    assert span > 0.3
    assert np.abs(Q[0] + _trapezoid(V, t) - Q).max() < 1e-3 * span
    assert np.abs(V[0] + _trapezoid(A, t) - V).max() < 1e-2 * np.abs(V).max()
    # the differences are convex combinations of the samples' (weights by the steps): within their peaks,
    # so a trajectory that meets the robot's limits sends rates that meet them
    speed, accel = _peaks(executable["joints"], executable.t)
    assert (np.abs(V).max(axis=0) <= speed * (1 + 1e-9) + 1e-12).all()
    assert (np.abs(A).max(axis=0) <= accel * (1 + 1e-9) + 1e-9).all()


def test_rosbag_topics_are_configurable_and_checked(executable, tmp_path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    path = write_trajectory(executable, tmp_path / "bag", format="rosbag", joint_topic="/arm/trajectory",
                            pose_topic="/arm/tool_pose", gripper_topic="/robotiq/joint_states")
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        assert sorted(c.topic for c in reader.connections) == ["/arm/tool_pose", "/arm/trajectory",
                                                               "/robotiq/joint_states"]
    for kwargs, match in [({"joint_topic": "arm"}, r"joint_topic: expected a ROS 2 topic name like"),
                          ({"pose_topic": "/arm/"}, r"pose_topic: expected a ROS 2 topic name"),
                          ({"gripper_topic": "/2f/state"}, r"gripper_topic: expected a ROS 2 topic name"),
                          ({"pose_topic": "/a//b"}, r"pose_topic: expected"),
                          ({"pose_topic": "/joint_trajectory"},
                           r"expected three different topics, got \['/joint_trajectory', '/joint_")]:
        with pytest.raises(ValueError, match=match):
            write_trajectory(executable, tmp_path / "other", format="rosbag", **kwargs)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag"]


def _servoj(path):
    lines = [x.strip() for x in path.read_text().splitlines() if x.strip().startswith("servoj(")]
    return np.array([x[len("servoj(["):x.index("]")].split(",") for x in lines], dtype=float)


def _peaks(J, t):
    """Per-joint peak speed and acceleration by the finite differences skillbank's limits use."""
    v = np.diff(J, axis=0) / np.diff(t)[:, None]
    a = np.diff(v, axis=0) / (0.5 * (t[2:] - t[:-2]))[:, None]
    return np.abs(v).max(axis=0), np.abs(a).max(axis=0)


@pytest.mark.parametrize("rate", [7.0, 125.0, 500.0])
def test_urscript_steps_keep_the_trajectorys_joint_speed_and_acceleration(executable, tmp_path, rate):
    """servoj steps average the blended velocity profile: neither peak grows with the control rate."""
    J, t = executable["joints"], executable.t
    speed, accel = _peaks(J, t)
    steps = _servoj(write_trajectory(executable, tmp_path / "arm.script", rate=rate))
    # the last step only holds the end; 9 printed decimals, and the drift correction (below)
    times = np.minimum(np.arange(len(steps)) / rate, t[-1] - t[0]) + t[0]
    written_v, written_a = _peaks(steps[:-1], times[:-1])
    drift = np.abs(blended_joints(t, t, J) - J).max()
    assert (written_v <= speed + drift / (t[-1] - t[0]) + 2e-9 * rate).all()
    assert (written_a <= accel * (1 + 1e-9) + 4e-9 * rate**2).all()
    # and the path stays within h^2 a / 4 of the samples (h the largest sample step)
    h = np.diff(t).max()
    assert drift <= h**2 * accel.max() / 4 * 1.01
    np.testing.assert_allclose(steps[[0, -1]], J[[0, -1]], atol=1e-9)


def test_blended_joints_against_linear_interpolation():
    """A corner at full speed: linear interpolation's acceleration grows with the rate, the blend's not."""
    t = np.array([0.0, 1.0, 2.0, 3.0])
    Q = np.array([[0.0], [1.0], [1.0], [1.0]])  # 1 rad/s, then stopped: sample-level acceleration 1 rad/s^2
    for rate in (10.0, 1000.0):
        times = np.arange(0.0, 3.0 + 1e-12, 1 / rate)
        lin = np.interp(times, t, Q[:, 0])[:, None]
        blend = blended_joints(times, t, Q)
        assert _peaks(lin, times)[1][0] == pytest.approx(rate * 1.0, rel=1e-6)
        assert _peaks(blend, times)[1][0] <= 1.0 + 1e-9
        assert _peaks(blend, times)[0][0] <= 1.0 + 1e-9
    # exact values: the velocity ramps from 1 to 0 between the midpoints 0.5 and 1.5
    np.testing.assert_allclose(blended_joints(np.array([0.5, 1.0, 1.5, 3.0]), t, Q).ravel(),
                               [0.5, 0.875, 1.0, 1.0], atol=1e-12)


def test_the_export_bound_is_checked_before_writing(executable, tmp_path, monkeypatch):
    long = Demonstration(executable.t * 1e6, executable.streams, executable.metadata)  # 15 days
    with pytest.raises(ValueError, match=r"^out: the export would write 6.5e\+08 servoj steps \(1.3e\+06 s "
                                         r"at 500 Hz\), more than the bound of 2097152 \(set "
                                         r"SKILLBANK_MAX_EXPORT_SAMPLES to a larger number to write it"):
        write_trajectory(long, tmp_path / "arm.script", rate=500)
    assert list(tmp_path.iterdir()) == []
    monkeypatch.setenv("SKILLBANK_MAX_EXPORT_SAMPLES", "100")
    with pytest.raises(ValueError, match=r"would write 164 servoj steps .* bound of 100"):
        write_trajectory(executable, tmp_path / "arm.script", rate=125)
    with pytest.raises(ValueError, match=r"would write 40 samples, more than the bound of 30"):
        monkeypatch.setenv("SKILLBANK_MAX_EXPORT_SAMPLES", "30")
        write_trajectory(executable, tmp_path / "out.csv")
    monkeypatch.setenv("SKILLBANK_MAX_EXPORT_SAMPLES", "many")
    with pytest.raises(ValueError, match=r"SKILLBANK_MAX_EXPORT_SAMPLES: expected a whole number of samples "
                                         r"> 0, got 'many'"):
        write_trajectory(executable, tmp_path / "out.csv")
    monkeypatch.setenv("SKILLBANK_MAX_EXPORT_SAMPLES", "200")
    assert len(_servoj(write_trajectory(executable, tmp_path / "arm.script", rate=125))) == 164


def test_formats_and_suffixes():
    assert TRAJECTORY_FORMATS == ("csv", "npz", "urscript", "rosbag")
    assert [trajectory_format(p) for p in ("a.csv", "a.TXT", "a.npz", "a.script", "a.urscript", "a.bag")] == [
        "csv", "csv", "npz", "urscript", "urscript", "rosbag"]


def _no_rosbags(monkeypatch):
    real = builtins.__import__

    def fake(name, *args, **kwargs):
        if name.startswith("rosbags"):
            raise ImportError(f"No module named {name!r}")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", fake)


@pytest.mark.parametrize(("change", "kwargs", "match"), [
    (None, {"format": "bag"}, r"format: expected one of \['csv', 'npz', 'urscript', 'rosbag'\], got 'bag'"),
    (None, {"path": "out.xlsx"}, r"out: expected a file name ending in .csv"),
    (None, {"path": "missing/out.csv"}, r"out: the folder '.*missing' of .* does not exist; create it first"),
    (None, {"path": "arm.script", "rate": 0}, r"rate: expected a number > 0"),
    (None, {"path": "arm.script", "rate": 1000},
     r"rate: expected servoj steps per second in \[1, 500\] Hz \(the e-Series controller runs at 500 Hz, the "
     r"CB3 at 125 Hz\), got 1000"),
    (None, {"path": "arm.script", "rate": float("inf")}, r"rate: expected a number > 0, got inf"),
    (None, {"path": "arm.script", "lookahead_time": 1.0},
     r"lookahead_time: expected a number in \[0.03, 0.2\] \(servoj's range\), got 1"),
    (None, {"path": "arm.script", "gain": float("nan")}, r"gain: expected a number > 0, got nan"),
    (None, {"path": "arm.script", "gain": 50}, r"gain: expected a number in \[100, 2000\]"),
    (None, {"path": "b", "format": "rosbag", "start_time": -1.0}, r"start_time: expected a number >= 0"),
    (None, {"path": "b", "format": "rosbag", "start_time": 2.2e9},
     r"start_time: expected seconds since the epoch with the last stamp before 2\^31 s \(a ROS 2 Time's "
     r"seconds are an int32\), got 2.2e\+09 \+ 1.3 s"),
    ("no joints", {"path": "arm.script"}, r"demo: a URScript export replays joints, and the trajectory"),
    ("no orientation", {"path": "b", "format": "rosbag"}, r"demo: a ROS bag holds the pose path"),
    ("bad metadata", {"path": "out.npz"}, r"demo.metadata: expected JSON-serialisable values"),
])
def test_errors_write_nothing(executable, tmp_path, change, kwargs, match):
    demo = executable
    if change == "no joints":
        demo = executable.select(["position", "orientation", "gripper"])
    elif change == "no orientation":
        demo = executable.select(["position", "joints"])
    elif change == "bad metadata":
        demo = Demonstration(executable.t, executable.streams, {"bad": object()})
    path = tmp_path / kwargs.pop("path", "out.csv")
    with pytest.raises(ValueError, match=match):
        write_trajectory(demo, path, **kwargs)
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no file, no temporary left


def test_a_failed_write_leaves_the_old_file(executable, tmp_path):
    path = tmp_path / "out.npz"
    path.write_bytes(b"old")
    with pytest.raises(ValueError, match=r"demo.metadata"):
        write_trajectory(Demonstration(executable.t, executable.streams, {"bad": object()}), path)
    assert path.read_bytes() == b"old" and [p.name for p in tmp_path.iterdir()] == ["out.npz"]


def test_rosbag_errors(executable, tmp_path, monkeypatch):
    (tmp_path / "taken").mkdir()
    with pytest.raises(ValueError, match=r"out: '.*taken' already exists; a ROS 2 bag is written to a new"):
        write_trajectory(executable, tmp_path / "taken", format="rosbag")
    _no_rosbags(monkeypatch)
    with pytest.raises(ImportError, match=r"^writing a ROS 2 bag needs the 'rosbags' package: "
                                          r"pip install skillbank\[ros\]$"):
        write_trajectory(executable, tmp_path / "bag", format="rosbag")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken"]


def test_a_written_reproduction_reads_back_stream_by_stream(tmp_path):
    from skillbank import Demonstration
    from skillbank.io import load, write_trajectory

    t = np.linspace(0.0, 1.0, 5)
    q = np.tile([0.0, 0.0, 0.0, 1.0], (5, 1))
    demo = Demonstration(t, {"position": np.c_[t, 2 * t, 3 * t], "orientation": q,
                             "gripper": (t > 0.5).astype(float), "joints": np.c_[t, t, t, t, t, -t]},
                         {"joint_names": ["a", "b", "c", "d", "e", "f"]})
    back = load(write_trajectory(demo, tmp_path / "r.csv"))
    assert back.stream_names == ["position", "orientation", "gripper", "joints"]
    for name in demo.stream_names:
        np.testing.assert_allclose(back[name], demo[name], atol=1e-12)
    assert back.metadata["joint_names"] == ["a", "b", "c", "d", "e", "f"]


def test_a_written_bag_reads_back_with_skillbanks_own_reader(executable, tmp_path):
    """The gripper's JointState on a topic named for the gripper comes back as the 'gripper' stream."""
    from skillbank.io import load

    back = load(write_trajectory(executable, tmp_path / "bag", format="rosbag", start_time=1.7e9))
    assert set(back.stream_names) == {"position", "orientation", "gripper"}
    np.testing.assert_allclose(back.t, executable.t - executable.t[0], atol=1e-6)
    np.testing.assert_array_equal(back["gripper"], executable["gripper"])
    np.testing.assert_array_equal(back["position"], executable["position"])
    assert back.metadata["topics"]["/gripper/joint_states"]["stream"] == "gripper"


@settings(max_examples=60, deadline=None)
@given(steps=st.lists(st.floats(1e-3, 0.1), min_size=1, max_size=30),
       values=st.lists(st.floats(-3.0, 3.0), min_size=2, max_size=31), rate=st.floats(1.0, 500.0))
def test_blended_joints_never_exceed_the_samples_peaks(steps, values, rate):
    """True by construction: servo differences average a velocity profile whose slopes are the samples'
    accelerations; the drift correction adds a constant velocity and no acceleration."""
    n = min(len(steps) + 1, len(values))
    t = np.concatenate([[0.0], np.cumsum(steps[:n - 1])])
    Q = np.array(values[:n])[:, None]
    times = np.arange(0.0, t[-1], 1.0 / rate)
    if len(times) < 3:
        return
    v = np.diff(Q[:, 0]) / np.diff(t)
    accel = np.abs(np.diff(v) / (0.5 * (t[2:] - t[:-2]))).max() if n > 2 else 0.0
    # the drift the correction removes: the profile's integral, by the trapezoidal rule on its knots (exact)
    knots = np.concatenate([[t[0]], 0.5 * (t[1:] + t[:-1]), [t[-1]]])
    w = np.concatenate([v[:1], v, v[-1:]])
    drift = Q[-1, 0] - Q[0, 0] - float(np.sum(0.5 * np.diff(knots) * (w[1:] + w[:-1])))
    written = blended_joints(times, t, Q)[:, 0]
    wv = np.abs(np.diff(written)) * rate
    wa = np.abs(np.diff(written, 2)) * rate**2
    assert wv.max() <= np.abs(v).max() + abs(drift) / t[-1] + 1e-9 * (1 + np.abs(v).max())
    # round-off of a second difference: ~1e-15 of the values, over the period squared
    assert wa.max() <= accel * (1 + 1e-9) + 1e-13 * rate**2
    np.testing.assert_allclose(blended_joints(t[[0, -1]], t, Q)[:, 0], Q[[0, -1], 0], atol=1e-12)


@pytest.fixture(scope="module")
def timed():
    """A 2 s reach on the UR5e asked for in 0.4 s with tighter joint limits: re-timed by the time law."""
    from skillbank import Constraints
    from skillbank.robots import tool_point
    from skillbank.selection import make_executable

    s = np.linspace(0.0, 1.0, 60)
    t = 0.4 * s
    P = np.c_[0.4 + 0.1 * s, -0.2 + 0.2 * s, 0.3 - 0.1 * np.sin(np.pi * s)]
    Q = exp_map(np.c_[0 * s, 0 * s, 0.8 * s], reference=[1.0, 0.0, 0.0, 0.0])
    source = Demonstration(t, {"position": P, "orientation": Q, "gripper": (s > 0.5).astype(float)},
                           {"pose_of": tool_point(UR5e())})
    limits = {"joint_velocity": [0.8, 0.8, 0.8, 1.2, 1.2, 1.2], "joint_acceleration": 2.0}
    done = make_executable(Demonstration(t, {"position": P}), [source], Constraints(), robot="ur5e",
                           limits=limits)
    assert done.trajectory.metadata["timing"]["law"] == "toppra" and done.time_scale > 1.0
    return done.trajectory


def _stated(timing):
    """Per-joint velocity and acceleration limits from a stated timing (JSON)."""
    limits = timing["limits"]
    return np.asarray(limits["joint_velocity"]), np.asarray(limits["joint_acceleration"])


def test_exports_state_the_limits_they_were_timed_for_and_keep_within_them(timed, tmp_path):
    """Each format read back: the law and limits it states, and its joint rates against them."""
    import json

    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore
    from ruamel.yaml import YAML

    from skillbank.io import load

    expected = {"law": "toppra", "limits": {"joint_velocity": [0.8, 0.8, 0.8, 1.2, 1.2, 1.2],
                                            "joint_acceleration": [2.0] * 6}}
    assert timed.metadata["timing"] == expected
    # CSV: the comment line before the header, read back by skillbank's reader; the samples within
    csv = write_trajectory(timed, tmp_path / "arm.csv")
    first, second, header = csv.read_text().splitlines()[:3]
    assert first == "# skillbank timing: " + json.dumps(expected, sort_keys=True)
    assert second.startswith("# timed by the toppra time law within: joint_velocity [0.8, 0.8, 0.8, 1.2, "
                             "1.2, 1.2] rad/s per joint; joint_acceleration [2.0, 2.0, 2.0, 2.0, 2.0, 2.0] "
                             "rad/s^2")
    assert header.startswith("t,position_0")
    back = load(csv)
    assert back.metadata["timing"] == expected
    vmax, amax = _stated(back.metadata["timing"])
    speed, accel = _peaks(back["joints"], back.t)
    assert (speed <= vmax).all() and (accel <= amax).all()
    assert max((speed / vmax).max(), np.sqrt((accel / amax).max())) > 0.999  # timed to the limits, not slower
    # URScript: the header states them; the servoj steps keep within them (up to blended_joints' drift
    # correction and the 9 printed decimals, as for any trajectory)
    for rate in (125.0, 500.0):
        script = write_trajectory(timed, tmp_path / f"arm{rate:g}.script", rate=rate)
        text = script.read_text()
        line = next(x for x in text.splitlines() if x.startswith("# skillbank timing: "))
        vmax, amax = _stated(json.loads(line[len("# skillbank timing: "):]))
        steps = _servoj(script)
        times = np.minimum(np.arange(len(steps)) / rate, timed.t[-1])
        written_v, written_a = _peaks(steps[:-1], times[:-1])
        drift = np.abs(blended_joints(timed.t, timed.t, timed["joints"]) - timed["joints"]).max()
        assert (written_v <= vmax + drift / timed.t[-1] + 2e-9 * rate).all()
        assert (written_a <= amax * (1 + 1e-9) + 4e-9 * rate**2).all()
    # NPZ: the metadata, as JSON
    assert read_npz(write_trajectory(timed, tmp_path / "arm.npz")).metadata["timing"] == expected
    # ROS 2 bag: custom_data holds the timing; every JointTrajectory point's velocities and accelerations
    bag = write_trajectory(timed, tmp_path / "bag", format="rosbag")
    # rosbag2's own metadata file, read as YAML (ruamel.yaml comes with rosbags)
    info = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert json.loads(info["custom_data"]["skillbank_timing"]) == expected
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        [(conn, _, raw)] = [m for m in reader.messages() if m[0].topic == "/joint_trajectory"]
        traj = reader.deserialize(raw, conn.msgtype)
    V = np.array([p.velocities for p in traj.points])
    A = np.array([p.accelerations for p in traj.points])
    vmax, amax = _stated(expected)
    assert (np.abs(V) <= vmax * (1 + 1e-12)).all() and (np.abs(A) <= amax * (1 + 1e-12)).all()
