"""``library reuse`` and ``edit`` as executable reproductions: orientation, robot, timing, exports, errors."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.core import Sphere, exp_map, quaternion_angle
from skillbank.io import load, read_npz, write_csv, write_npz
from skillbank.robots import UR5e, clearance, rate_ratio, to_tool

KEYS = {"t", "streams", "joint_names", "trajectory", "used", "rejected", "constraint_error",
        "orientation_error", "collision", "peak_joint_velocity", "peaks", "notes", "clearance"}


def _q(q) -> str:
    return ",".join(f"{v:.12f}" for v in q)


@pytest.fixture(scope="module")
def buttons(data_dir, tmp_path_factory):
    """The three-button file in a library, every primitive labelled 'button'; a goal near primitive 3's."""
    from skillbank import Library

    path = data_dir / "seed" / "three_button_pressing_demo.h5"
    db = tmp_path_factory.mktemp("lib") / "lib.db"
    with Library(db) as lib:
        lib.add_files([path], label="button")
        prims = {p.id: p.demo for p in lib.primitives()}
    # the recording's poses are the flange's; with --robot ur5e the goal is its tool's, the 2F-85's TCP
    end = to_tool(prims[3], UR5e())[0]
    goal = end["position"][-1] + [0.03, -0.02, 0.0]
    goal_q = exp_map([0.0, 0.0, np.radians(10.0)], reference=end["orientation"][-1])
    return {"db": db, "file": path, "goal": goal, "goal_q": goal_q}


def _reuse(cli, buttons, *argv):
    return cli("library", "reuse", buttons["db"], "--skill", "button", "--method", "ja",
               "--goal", ",".join(f"{v:.6f}" for v in buttons["goal"]), *argv)


def test_reuse_json_contract_with_robot_and_csv(cli, buttons, tmp_path):
    out = tmp_path / "reach.csv"
    code, text, err = _reuse(cli, buttons, "--goal-orientation", _q(buttons["goal_q"]), "--robot", "ur5e",
                             "--max-joint-velocity", "0.8", "--out", out, "--json")
    assert code == 0, err
    doc = json.loads(text)
    assert set(doc) == KEYS
    assert set(doc["streams"]) == {"position", "orientation", "gripper", "joints", "force", "torque"}
    assert doc["joint_names"] == list(UR5e.joint_names) and doc["t"][0] == 0.0
    assert doc["trajectory"] == doc["streams"]["position"]
    assert doc["constraint_error"] < 1e-9 and doc["orientation_error"] < 1e-9 and doc["collision"] is False
    assert 0 < doc["peak_joint_velocity"] <= 0.8
    P, Q, J = (np.array(doc["streams"][k]) for k in ("position", "orientation", "joints"))
    np.testing.assert_allclose(P[-1], buttons["goal"], atol=1e-6)  # the goal as typed, 6 decimals
    assert quaternion_angle(Q[-1], buttons["goal_q"]) < 1e-9
    position, quaternion = UR5e().fk(J)
    assert np.abs(position - P).max() < 1e-9 and quaternion_angle(quaternion, Q).max() < 1e-9
    lines = out.read_text().splitlines()
    # the limits the trajectory was timed for come first, as comments (docs/robots.md, "Time law")
    at = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    assert lines[0].startswith('# skillbank timing: {"law": "toppra", "limits": {"joint_acceleration": [')
    header = lines[at].split(",")
    assert header[:8] == ["t", "position_0", "position_1", "position_2", "orientation_x", "orientation_y",
                          "orientation_z", "orientation_w"]
    assert [f"joints_{n}" for n in UR5e.joint_names] == [h for h in header if h.startswith("joints_")]
    table = np.loadtxt(out, delimiter=",", skiprows=at + 1)
    np.testing.assert_array_equal(table[:, 0], doc["t"])
    np.testing.assert_array_equal(table[:, [header.index(f"joints_{n}") for n in UR5e.joint_names]], J)


def test_reuse_text_npz_urscript_and_rosbag(cli, buttons, tmp_path):
    argv = ["--goal-orientation", _q(buttons["goal_q"]), "--robot", "ur5e", "--duration", "10"]
    code, text, err = _reuse(cli, buttons, *argv, "--out", tmp_path / "r.npz")
    assert code == 0, err
    assert "orientation error" in text and "over 10 s from t = 0" in text and "peak joint velocity" in text
    assert "note: gripper: from primitive" in text and f"wrote {tmp_path / 'r.npz'}" in text
    back = read_npz(tmp_path / "r.npz")
    assert back.t[-1] == 10.0 and back.metadata["joint_names"] == list(UR5e.joint_names)
    code, _, err = _reuse(cli, buttons, *argv, "--out", tmp_path / "r.script", "--control-rate", "500")
    assert code == 0, err
    lines = [x.strip() for x in (tmp_path / "r.script").read_text().splitlines()]
    assert sum(x.startswith("servoj(") for x in lines) == 10 * 500 + 1
    assert sum(x.startswith("skillbank_gripper(") for x in lines) >= 1
    code, _, err = _reuse(cli, buttons, *argv, "--out", tmp_path / "bag", "--format", "rosbag")
    assert code == 0, err
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    with AnyReader([tmp_path / "bag"], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    assert counts == {"/joint_trajectory": 1, "/pose": back.n_steps, "/gripper/joint_states": back.n_steps}


def test_edit_carries_the_streams_and_adds_joints(cli, buttons, tmp_path):
    demo = load(buttons["file"]).slice(1385, 2074)
    path = write_npz(demo, tmp_path / "move.npz")
    goal = demo["position"][-1] + [0.02, 0.0, 0.01]
    goal_q = exp_map([0.0, 0.1, 0.0], reference=demo["orientation"][-1])
    code, text, err = cli("edit", path, "--goal", ",".join(map(str, goal)), "--goal-orientation", _q(goal_q),
                          "--robot", "ur5e", "--json")
    assert code == 0, err
    doc = json.loads(text)
    assert set(doc) == KEYS and doc["used"] == [str(path)] and doc["rejected"] == {}
    # the recording's own timing asks more than the UR5e's pi rad/s^2 somewhere: re-timed by the time law
    # (or, were it slower, stretched), with a note
    assert doc["t"][0] == 0.0 and doc["t"][-1] > demo.duration
    note = next(n for n in doc["notes"] if n.startswith(("time law toppra", "time stretched")))
    assert f"(the ur5e's own limit): {demo.duration:.6g} s -> {doc['t'][-1]:.6g} s" in note, note
    assert doc["orientation_error"] < 1e-9 and doc["constraint_error"] < 1e-9
    J = np.array(doc["streams"]["joints"])
    position, _ = UR5e().fk(J)
    assert np.abs(position - np.array(doc["trajectory"])).max() < 1e-9


def test_via_orientations_are_met_where_they_are_asked_for(cli, buttons, tmp_path):
    """``--via-orientation PHASE:Q`` (repeatable) on reuse and edit: the pose turns through them."""
    from skillbank import Constraints

    demo = load(buttons["file"]).slice(1385, 2074)
    path = write_npz(demo, tmp_path / "move.npz")
    mid = exp_map([0.0, 0.0, np.radians(25.0)], reference=demo["orientation"][len(demo["orientation"]) // 2])
    late = exp_map([np.radians(-15.0), 0.0, 0.0], reference=demo["orientation"][-1])
    vias = ["--via-orientation", f"0.5:{_q(mid)}", "--via-orientation", f"0.8:{_q(late)}"]
    for argv in (("edit", path, "--method", "lte"),
                 ("library", "reuse", buttons["db"], "--skill", "button", "--method", "ja", "--goal",
                  ",".join(f"{v:.6f}" for v in buttons["goal"]))):
        code, text, err = cli(*argv, *vias, "--json")
        assert code == 0, err
        doc = json.loads(text)
        Q = np.array(doc["streams"]["orientation"])
        idx, wanted = Constraints(via_orientation=[(0.5, mid), (0.8, late)]).resolve_orientation(len(Q))
        assert quaternion_angle(Q[idx], wanted).max() < 1e-9 and doc["orientation_error"] < 1e-9, argv[0]
        assert np.abs(np.diff(Q, axis=0)).max() < 0.05  # a continuous turn, not a jump at the via-points
    code, _, err = cli("edit", path, "--via-orientation", "0.5:0,0,1")
    assert code == 2 and "via_orientation[0]: expected" in err and err.count("\n") == 1, err
    code, _, err = cli("edit", path, "--via-orientation", "0,0,0,1")
    assert code == 2 and "via-orientation: expected 'PHASE:QX,QY,QZ,QW', got '0,0,0,1'" in err, err

def _plain_library(tmp_path):
    from skillbank import Library

    s = np.linspace(0.0, 1.0, 60)
    db = tmp_path / "plain.db"
    with Library(db) as lib:
        for k in range(2):
            Y = np.c_[0.4 + 0.1 * s, -0.2 + 0.2 * s, 0.3 + 0.01 * k + 0.05 * np.sin(np.pi * s)]
            lib.add(Demonstration(s, {"position": Y}), segment=False, label="reach")
    return db


OUT = ["--out", "{tmp}/out.csv"]


@pytest.mark.parametrize(("argv", "match"), [
    (["--goal-orientation", "0,0,1", *OUT], r"goal_orientation: expected a quaternion of 4 components"),
    (["--start-orientation", "0,0,0,0", *OUT], r"start_orientation: expected unit quaternions .*zero norm"),
    (["--goal-orientation", "0,0,1,x", *OUT], r"goal_orientation: expected a number, got 'x'"),
    (["--goal-orientation", "0,0,0,1", *OUT],
     r"no usable candidate: \d+: no 'orientation' stream for the orientation"),
    (["--robot", "ur5e", *OUT], r"robot: ur5e inverse kinematics needs an 'orientation' stream"),
    (["--robot", "ur3", *OUT], r"robot: expected one of \['ur5e', 'panda'\] or a URDF / MJCF file, got 'u"),
    (["--max-joint-velocity", "1", *OUT], r"max-joint-velocity: a joint velocity limit needs joints"),
    (["--format", "csv", "--json"], r"format: --format csv needs --out FILE"),
    (["--duration", "-1", *OUT], r"duration: expected a number > 0"),
    (["--out", "{tmp}/r.xlsx"], r"out: expected a file name ending in \.csv"),
    (["--out", "{tmp}/bag", "--format", "rosbag"], r"out: '.*bag' exists; give --force to overwrite it"),
    (["--out", "{tmp}/bag", "--format", "rosbag", "--force"],
     r"out: '.*bag' already exists; a ROS 2 bag is written"),
])
def test_reuse_errors_exit_2_with_one_line(cli, tmp_path, argv, match):
    import re

    db = _plain_library(tmp_path)
    (tmp_path / "bag").mkdir()
    before = sorted(p.name for p in tmp_path.iterdir())
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    code, out, err = cli("library", "reuse", db, "--skill", "reach", "--goal", "0.5,0.0,0.3", *argv)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert err.startswith("skillbank library reuse: error: ") and re.search(match, err), err
    after = sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("plain.db-"))  # SQLite's WAL
    assert after == before and not any((tmp_path / "bag").iterdir())  # nothing written, not even half


@pytest.mark.parametrize(("goal", "argv", "match"), [
    ("1.6,0.0,0.2", ["--robot", "ur5e"], r"robot ur5e: position: sample \d+ is out"),
    ("0.08,-0.668,0.098", ["--robot", "ur5e", "--branch", "elbow-up"],
     r"branch: expected one of \['shoulder-left/elbow-up/wrist-up', 'shoulder-left/elbow-up/wrist-down', "
     r"'shoulder-left/elbow-down/wrist-up', 'shoulder-left/elbow-down/wrist-down', "
     r"'shoulder-right/elbow-up/wrist-up', 'shoulder-right/elbow-up/wrist-down', "
     r"'shoulder-right/elbow-down/wrist-up', 'shoulder-right/elbow-down/wrist-down'\] or an index below 8, "
     r"got 'elbow-up'"),
])
def test_robot_errors_exit_2_and_write_nothing(cli, buttons, tmp_path, goal, argv, match):
    import re

    goal = goal or ",".join(f"{v:.6f}" for v in buttons["goal"])
    code, out, err = cli("library", "reuse", buttons["db"], "--skill", "button", "--method", "ja",
                         "--goal", goal, "--goal-orientation", _q(buttons["goal_q"]), *argv,
                         "--out", tmp_path / "r.csv")
    assert code == 2 and out == "" and err.count("\n") == 1 and re.search(match, err), err
    assert list(tmp_path.iterdir()) == []


def test_edit_errors(cli, tmp_path):
    s = np.linspace(0.0, 1.0, 30)
    path = write_csv(Demonstration(s, {"position": np.c_[s, s]}), tmp_path / "a.csv")
    code, out, err = cli("edit", path, "--goal-orientation", "0,0,0,1", "--out", tmp_path / "o.csv")
    assert code == 2 and err == ("skillbank edit: error: constraints: orientation constraints need an "
                                 "'orientation' stream, and file(s) ['a.csv'] have none "
                                 "(streams ['position'])\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv"]


def _servoj(path):
    """The joint targets of a URScript's servoj steps, and their period."""
    lines = [x.strip() for x in path.read_text().splitlines() if x.strip().startswith("servoj(")]
    period = {float(x.split("t=")[1].split(",")[0]) for x in lines}
    assert len(period) == 1
    return np.array([x[len("servoj(["):x.index("]")].split(",") for x in lines], dtype=float), period.pop()


@pytest.mark.parametrize("rate", ["125", "500"])
def test_a_nanosecond_is_stretched_to_the_robots_limits_in_the_written_script(cli, buttons, tmp_path, rate):
    """Issue 23, item 7: --duration 1e-9 wrote 0.29 rad servoj steps in 8 ms; now the UR5e's limits hold."""
    out = tmp_path / "fast.script"
    code, text, err = _reuse(cli, buttons, "--goal-orientation", _q(buttons["goal_q"]), "--robot", "ur5e",
                             "--duration", "1e-9", "--control-rate", rate, "--out", out, "--json")
    assert code == 0, err
    doc = json.loads(text)
    end = doc["t"][-1]
    note = next(n for n in doc["notes"] if n.startswith(("time law toppra", "time stretched")))
    assert f"(the ur5e's own limit): 1e-09 s -> {end:.6g} s" in note, note
    assert 0.5 < end < 60.0
    steps, period = _servoj(out)
    assert period == pytest.approx(1 / float(rate))
    assert len(steps) == int(np.ceil(end * float(rate) - 1e-9)) + 1
    speed = np.abs(np.diff(steps[:-1], axis=0)) / period  # the last step only holds the end
    # the JSON trajectory keeps pi rad/s and pi rad/s^2, one of them exactly (the stretch is no longer
    # than needed); the servoj steps follow it (blended_joints), no faster than its samples
    J, t = np.array(doc["streams"]["joints"]), np.array(doc["t"])
    v = np.diff(J, axis=0) / np.diff(t)[:, None]
    a = np.diff(v, axis=0) / (0.5 * (t[2:] - t[:-2]))[:, None]
    assert max(np.abs(v).max() / np.pi, np.sqrt(np.abs(a).max() / np.pi)) <= 1.0
    # exactly as the exports measure them (finite differences and a ROS 2 bag's numpy.gradient)
    assert rate_ratio(t, J, velocity=np.pi, acceleration=np.pi) == pytest.approx(1.0, abs=1e-9)
    assert speed.max() <= np.abs(v).max() * (1 + 1e-6) + 1e-9 * float(rate)  # 9 printed decimals
    assert speed.max() <= np.pi
    # and their acceleration too, at 125 and at 500 Hz (9 printed decimals: 2e-9 rad per second difference)
    accel = np.abs(np.diff(steps[:-1], 2, axis=0)) / period**2
    assert accel.max() <= np.pi * (1 + 1e-9) + 2e-9 / period**2


def test_a_million_seconds_of_urscript_is_refused_before_the_work(buttons, tmp_path, limited):
    """Issue 23, item 4: 14.8 GB and growing; now one line naming the bound and how to go past it."""
    out = tmp_path / "x.script"
    code, text, err = limited("library", "reuse", buttons["db"], "--skill", "button", "--goal",
                              ",".join(f"{v:.6f}" for v in buttons["goal"]), "--goal-orientation",
                              _q(buttons["goal_q"]), "--robot", "ur5e", "--duration", "1e6", "--out", out,
                              memory=1 << 30, timeout=60)
    assert code == 2 and text == "" and err.count("\n") == 1, err
    assert err == ("skillbank library reuse: error: out: the export would write 1.25e+08 servoj steps "
                   "(1e+06 s at 125 Hz), more than the bound of 2097152 (set SKILLBANK_MAX_EXPORT_SAMPLES to "
                   "a larger number to write it, or shorten the motion or lower the rate)\n")
    assert list(tmp_path.iterdir()) == []


def test_the_branch_is_chosen_on_the_command_line(cli, buttons, tmp_path):
    robot = UR5e()
    argv = ["--goal-orientation", _q(buttons["goal_q"]), "--robot", "ur5e", "--json"]
    code, text, err = _reuse(cli, buttons, *argv)
    assert code == 0, err
    doc = json.loads(text)
    P, Q = np.array(doc["streams"]["position"]), np.array(doc["streams"]["orientation"])
    recorded = set(robot.branch_of(np.array(doc["streams"]["joints"])).tolist())
    whole = np.flatnonzero(~np.isnan(robot.ik_all(P, Q)).any(axis=2).any(axis=0))
    other = next(int(b) for b in whole if b not in recorded)
    code, text, err = _reuse(cli, buttons, *argv, "--branch", robot.branch_names[other])
    assert code == 0, err
    J = np.array(json.loads(text)["streams"]["joints"])
    assert set(robot.branch_of(J).tolist()) == {other}
    code, text, err = _reuse(cli, buttons, *argv, "--branch", str(other))  # or its index
    assert code == 0, err
    # the same joints to round-off (numpy's SIMD results can differ in the last bit between two runs)
    np.testing.assert_allclose(np.array(json.loads(text)["streams"]["joints"]), J, rtol=0, atol=1e-12)
    position, _ = robot.fk(J)
    assert np.abs(position - P).max() < 1e-9  # the same pose path, on the other branch
    # edit takes it too
    path = write_npz(load(buttons["file"]).slice(1385, 2074), tmp_path / "move.npz")
    code, text, err = cli("edit", path, "--robot", "ur5e", "--json")
    assert code == 0, err
    doc = json.loads(text)
    P, Q = np.array(doc["streams"]["position"]), np.array(doc["streams"]["orientation"])
    recorded = set(robot.branch_of(np.array(doc["streams"]["joints"])).tolist())
    whole = np.flatnonzero(~np.isnan(robot.ik_all(P, Q)).any(axis=2).any(axis=0))
    other = next(int(b) for b in whole if b not in recorded)
    code, text, err = cli("edit", path, "--robot", "ur5e", "--branch", robot.branch_names[other], "--json")
    assert code == 0, err
    assert set(robot.branch_of(np.array(json.loads(text)["streams"]["joints"])).tolist()) == {other}


def test_ros_topics_and_acceleration_limit_on_the_command_line(cli, buttons, tmp_path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    code, text, err = _reuse(cli, buttons, "--goal-orientation", _q(buttons["goal_q"]), "--robot", "ur5e",
                             "--max-joint-acceleration", "0.5", "--out", tmp_path / "bag", "--format",
                             "rosbag",
                             "--joint-topic", "/ur/scaled_joint_trajectory_controller/joint_trajectory",
                             "--pose-topic", "/ur/tool_pose", "--gripper-topic", "/gripper/state", "--json")
    assert code == 0, err
    doc = json.loads(text)
    assert doc["peaks"]["joints"]["acceleration"] <= 0.5 * (1 + 1e-9)
    with AnyReader([tmp_path / "bag"], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
    assert topics == {"/ur/scaled_joint_trajectory_controller/joint_trajectory":
                      "trajectory_msgs/msg/JointTrajectory", "/ur/tool_pose": "geometry_msgs/msg/PoseStamped",
                      "/gripper/state": "sensor_msgs/msg/JointState"}


@pytest.mark.parametrize(("argv", "match"), [
    (["--duration", "nan", *OUT], r"duration: expected a number > 0, got nan"),
    (["--duration", "inf", *OUT], r"duration: expected a number > 0, got inf"),
    (["--duration", "1e-12", *OUT], r"duration: expected seconds in \[1e-09, 1e\+09\], got 1e-12"),
    (["--max-joint-acceleration", "1", *OUT], r"max-joint-acceleration: a joint acceleration limit needs "
                                               r"joints: give --robot too"),
    (["--robot", "ur5e", "--max-joint-acceleration", "-1", *OUT],
     r"max-joint-acceleration: expected a number > 0, got -1"),
    (["--branch", "shoulder-left/elbow-up/wrist-up", *OUT],
     r"branch: --branch .* needs joints: give --robot"),
    (["--control-rate", "100", *OUT], r"control-rate: --control-rate is the servoj rate of a URScript export "
                                      r"\(--out arm.script\), got a csv --out"),
    (["--control-rate", "1000", "--out", "{tmp}/a.script"], r"rate: expected servoj steps per second in "
                                                            r"\[1, 500\] Hz"),
    (["--joint-topic", "/a", *OUT], r"joint-topic: topics are for a ROS 2 bag export"),
    (["--pose-topic", "tool pose", "--out", "{tmp}/new.bag"], r"pose-topic: expected a ROS 2 topic name"),
    (["--tool-frame", "tool0", *OUT], r"tool-frame: --tool-frame names a link of a robot's description: "
                                      r"give --robot FILE too"),
    (["--robot-base", "0,0,0.9", *OUT], r"robot-base: --robot-base places a robot: give --robot too"),
    (["--robot", "ur5e", "--robot-base", "0,0", *OUT], r"robot-base: expected X,Y,Z or X,Y,Z,QX,QY,QZ,QW, "
                                                       r"got 2 numbers"),
    (["--robot", "ur5e", "--robot-base", "0,0,x", *OUT], r"robot-base: expected a number, got 'x'"),
    (["--robot", "ur5e", "--tool-frame", "tool0", *OUT], r"tool frame: ur5e is a built-in model"),
    (["--tool", "tcp", *OUT], r"tool: --tool names a point of a robot: give --robot too"),
    (["--robot", "ur5e", "--tool", "wrist", *OUT], r"tool: expected a 4 x 4 transform, 'flange', 'tcp' or a "
                                                    r"gripper's name"),
    (["--robot", "ur5e", "--tool", "0,0.1", *OUT], r"tool: expected 'tcp', 'flange', a gripper's name or "
                                                   r"X,Y,Z in the flange frame \(metres\), got 2 numbers"),
    (["--robot", "{tmp}/missing.urdf", *OUT], r"robot: .*missing.urdf is neither a registered robot nor a "
                                              r"description file"),
    (["--duration", "1e5", "--out", "{tmp}/a.script", "--control-rate", "500"],
     r"out: the export would write 5e\+07 servoj steps \(100000 s at 500 Hz\), more than the bound of "
     r"2097152 \(set SKILLBANK_MAX_EXPORT_SAMPLES"),
])
def test_execution_option_errors_exit_2_before_the_work(cli, tmp_path, argv, match):
    import re

    db = _plain_library(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    for command in (["library", "reuse", db, "--skill", "reach"], ["edit", tmp_path / "d.csv"]):
        if command[0] == "edit":
            s = np.linspace(0.0, 1.0, 30)
            write_csv(Demonstration(s, {"position": np.c_[s, s, s]}), tmp_path / "d.csv")
            before = sorted(p.name for p in tmp_path.iterdir())
        code, out, err = cli(*command, "--goal", "0.5,0.0,0.3", *argv)
        assert code == 2 and out == "" and err.count("\n") == 1, err
        assert re.search(match, err), err
        after = sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("plain.db-"))
        assert after == before


# --- issue 24: the whole robot, and the reuse replayed in physics -------------------------------------


def _forearm_ball(buttons):
    """A ball round the forearm's middle at the reuse's last sample (the tool point never comes near)."""
    code, text, _ = _reuse(cli_main, buttons, "--robot", "ur5e", "--json")
    assert code == 0
    J = np.array(json.loads(text)["streams"]["joints"])
    robot = UR5e()
    forearm = next(c for c in robot.bodies if c.name == "forearm")
    F = robot.link_frames(J[-1])[0, forearm.frame]
    m = F[:3, :3] @ (0.5 * (np.asarray(forearm.a) + np.asarray(forearm.b))) + F[:3, 3]
    return "sphere:" + ",".join(f"{v:.6f}" for v in m) + ",0.03"


def cli_main(*argv):
    import contextlib
    import io

    from skillbank.cli import _main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = _main.main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def test_a_reuse_whose_forearm_meets_an_obstacle_is_refused_naming_it(cli, buttons, tmp_path):
    """The ball sits at the forearm at the goal, where every candidate's reuse ends: each candidate is
    rejected for the whole robot (its tool point is clear), in one line, and nothing is written."""
    ball = _forearm_ball(buttons)
    out = tmp_path / "reach.csv"
    code, text, err = _reuse(cli, buttons, "--robot", "ur5e", "--obstacle", ball, "--out", out)
    assert code == 2 and len(err.strip().splitlines()) == 1 and not out.exists()
    assert re.search(r"no usable candidate: \d+: the robot's forearm comes [\d.]+ mm into obstacle 0 "
                     r"\(sphere:[-\d.,]+\) at t = [\d.]+ s \(its tool point is clear; clearance margin "
                     r"5 mm\); at its goal, which no repair moves", err)


def test_reuse_clearance_is_the_whole_robots(cli, buttons):
    code, text, err = _reuse(cli, buttons, "--robot", "ur5e", "--obstacle", "sphere:0.0,0.0,1.5,0.05",
                             "--json")
    assert code == 0, err
    doc = json.loads(text)
    assert doc["collision"] is False and doc["clearance"]["min_distance"] > 0
    assert doc["clearance"]["body"] in {c.name for c in UR5e().bodies}


def test_reuse_simulate_replays_it_in_physics(cli, buttons):
    pytest.importorskip("mujoco")
    code, text, err = _reuse(cli, buttons, "--robot", "ur5e", "--simulate", "--json")
    assert code == 0, err
    sim = json.loads(text)["simulation"]
    assert sim["contacts"] == [] and sim["tracking"]["tool_max"] < 0.005 and sim["duration"] > 0


def test_simulate_needs_a_robot_in_one_line(cli, buttons):
    code, text, err = _reuse(cli, buttons, "--simulate")
    assert code == 2 and err.strip() == ("skillbank library reuse: error: simulate: a simulation replays "
                                         "joints: give --robot too (--robot ur5e)")


def _ball_beside(J, name, direction, overlap=0.01, radius=0.03):
    """A ball overlapping body ``name`` by ``overlap`` where it is furthest from its start and goal."""
    robot = UR5e()
    body = next(c for c in robot.bodies if c.name == name)
    F = robot.link_frames(J)[:, body.frame]
    M = np.einsum("nij,j->ni", F[:, :3, :3], 0.5 * (np.asarray(body.a) + np.asarray(body.b))) + F[:, :3, 3]
    i = int(np.argmax(np.minimum(np.linalg.norm(M - M[0], axis=1), np.linalg.norm(M - M[-1], axis=1))))
    u = np.asarray(direction, float)
    return Sphere(M[i] + u * (body.radius + radius - overlap), radius)


def test_a_reuse_whose_upper_arm_meets_an_obstacle_midway_is_repaired_with_via_points(cli, buttons):
    """The ball overlaps the upper arm halfway along the reuse, 0.4 m from the tool: the tool point's
    edit never sees it; the repair adds via points that move the upper arm away, and every body then
    keeps the 5 mm margin, the goal still met."""
    code, text, err = _reuse(cli, buttons, "--robot", "ur5e", "--json")
    assert code == 0, err
    plain = json.loads(text)
    # beside the upper arm along y: the side the repair can move it away from (the tool's goal is the TCP's)
    ball = _ball_beside(np.array(plain["streams"]["joints"]), "upper_arm", (0, 1, 0))
    robot = UR5e()
    assert clearance(robot, np.array(plain["streams"]["joints"]), [ball]).min_distance < -0.005
    # the upper arm barely moves on this reuse, so the ball meets it at the start too: the start is then the
    # nearest clear configuration at the start pose (issue 43, item 3), from which no repair is needed
    code, text, err = _reuse(cli, buttons, "--robot", "ur5e", "--obstacle", ball.spec(), "--json")
    assert code == 0, err
    doc = json.loads(text)
    assert [n for n in doc["notes"] if n.startswith("start: ")] and doc["clearance"]["min_distance"] >= 0.005
    # on the recorded branch (given), the first candidates are refused at their start and the next ones
    # repaired with via points, as before
    recorded = ("--branch", "shoulder-left/elbow-up/wrist-up")
    code, text, err = _reuse(cli, buttons, "--robot", "ur5e", "--obstacle", ball.spec(), *recorded, "--json")
    assert code == 0, err
    doc = json.loads(text)
    repairs = [n for n in doc["notes"] if n.startswith("repair: via point")]
    assert repairs and all("upper_arm clear of obstacles[0]" in n for n in repairs)
    J = np.array(doc["streams"]["joints"])
    kept = clearance(robot, J, [ball], self_collision=False)
    assert kept.min_distance >= 0.005 - 1e-9
    assert doc["collision"] is False and doc["clearance"]["min_distance"] > 0
    P = np.array(doc["streams"]["position"])
    assert np.linalg.norm(P[-1] - buttons["goal"]) < 1e-6
    # a larger margin asks for more: repaired further, or refused naming the body
    code, text, err = _reuse(cli, buttons, "--robot", "ur5e", "--obstacle", ball.spec(), *recorded,
                             "--clearance", "0.03", "--json")
    if code == 0:
        J = np.array(json.loads(text)["streams"]["joints"])
        assert clearance(robot, J, [ball], self_collision=False).min_distance >= 0.03 - 1e-9
    else:
        assert code == 2 and re.search(r"no usable candidate: .*clearance margin 30 mm", err)


@pytest.mark.parametrize("argv, match", [
    (["--clearance", "0.01"], r"clearance: the whole robot's clearance needs joints: give --robot too"),
    (["--robot", "ur5e", "--clearance", "-0.01"], r"clearance"),
    (["--robot", "ur5e", "--clearance", "nan"], r"clearance"),
])
def test_bad_clearance_is_one_line(cli, buttons, argv, match):
    code, text, err = _reuse(cli, buttons, *argv)
    assert code == 2 and len(err.strip().splitlines()) == 1 and re.search(match, err), err


def test_an_edit_whose_forearm_meets_an_obstacle_at_its_goal_is_refused(cli, buttons, tmp_path):
    path = write_npz(load(buttons["file"]).slice(1385, 2074), tmp_path / "move.npz")
    code, text, err = cli("edit", path, "--robot", "ur5e", "--json")
    assert code == 0, err
    J = np.array(json.loads(text)["streams"]["joints"])
    robot = UR5e()
    forearm = next(c for c in robot.bodies if c.name == "forearm")
    F = robot.link_frames(J[-1])[0, forearm.frame]
    m = F[:3, :3] @ (0.5 * (np.asarray(forearm.a) + np.asarray(forearm.b))) + F[:3, 3]
    out = tmp_path / "edited.csv"
    code, text, err = cli("edit", path, "--robot", "ur5e", "--obstacle", Sphere(m, 0.03).spec(), "--out", out)
    assert code == 2 and len(err.strip().splitlines()) == 1 and not out.exists()
    assert re.search(r"edit: the robot's forearm comes [\d.]+ mm into obstacle 0 .* at its goal, which no "
                     r"repair moves; nothing was written", err), err


# --- issue 43, item 3: the start a reuse or an edit takes with a robot ------------------------------------


def _ball_at(J0, body, radius=0.03):
    """A ball round ``body``'s middle at the configuration ``J0``."""
    robot = UR5e()
    capsule = next(c for c in robot.bodies if c.name == body)
    F = robot.link_frames(J0)[0, capsule.frame]
    return Sphere(F[:3, :3] @ (0.5 * (np.asarray(capsule.a) + np.asarray(capsule.b))) + F[:3, 3], radius)


START_NOTE = (r"^start: the recorded joints' branch shoulder-left/elbow-up/wrist-up puts the robot's {body} "
              r"[\d.]+ mm into obstacle 0 \(sphere:[-\d.,]+\) at the start; started on (?P<branch>[a-z/-]+), "
              r"the nearest configuration clear of the obstacles and of itself \(clearance margin 5 mm\)$")


@pytest.mark.parametrize("body", ["forearm", "upper_arm"])
def test_an_edit_whose_recorded_start_meets_an_obstacle_starts_on_the_nearest_clear_branch(cli, buttons,
                                                                                          tmp_path, body):
    """Before, refused (`... at its start, which no repair moves`); now the start is the clear configuration
    at the start pose nearest the recorded one, the same choice as a plan's start (clear_configurations)."""
    path = write_npz(load(buttons["file"]).slice(1385, 2074), tmp_path / "move.npz")
    code, text, err = cli("edit", path, "--robot", "ur5e", "--json")
    assert code == 0, err
    robot = UR5e()
    J = np.array(json.loads(text)["streams"]["joints"])
    ball = _ball_at(J[0], body)
    code, text, err = cli("edit", path, "--robot", "ur5e", "--obstacle", ball.spec(), "--json")
    assert code == 0, err
    doc = json.loads(text)
    [note] = [n for n in doc["notes"] if n.startswith("start:")]
    match = re.match(START_NOTE.format(body=body), note)
    assert match, note
    J2 = np.array(doc["streams"]["joints"])
    recorded = "shoulder-left/elbow-up/wrist-up"
    assert robot.branch_names[robot.branch_of(J2[0])[0]] == match["branch"] != recorded
    p, _ = robot.fk(J2)  # the same tool path, from another configuration
    np.testing.assert_allclose(p, np.array(doc["streams"]["position"]), atol=1e-6)
    assert doc["clearance"]["min_distance"] >= 0.005 - 1e-9
    assert clearance(robot, J2, [ball], self_collision=False).min_distance >= 0.005 - 1e-9
    # a branch given is the user's: still refused there
    code, _, err = cli("edit", path, "--robot", "ur5e", "--obstacle", ball.spec(), "--branch", recorded)
    assert code == 2 and "at its start, which no repair moves" in err


def test_a_reuse_whose_recorded_start_meets_an_obstacle_starts_on_the_nearest_clear_branch(cli, buttons):
    code, text, _ = _reuse(cli, buttons, "--robot", "ur5e", "--json")
    assert code == 0
    J = np.array(json.loads(text)["streams"]["joints"])
    ball = _ball_at(J[0], "forearm")
    code, text, err = _reuse(cli, buttons, "--robot", "ur5e", "--obstacle", ball.spec(), "--json")
    assert code == 0, err
    doc = json.loads(text)
    [note] = [n for n in doc["notes"] if n.startswith("start:")]
    assert re.match(START_NOTE.format(body="forearm"), note), note
    assert doc["collision"] is False and doc["clearance"]["min_distance"] >= 0.005 - 1e-9
