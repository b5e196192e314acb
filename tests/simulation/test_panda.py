"""The Panda end to end: recorded in robosuite, FK and IK against the recording, a skill reused in physics."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from skillbank.core import quaternion_angle
from skillbank.io import read_npz
from skillbank.robots import robot_model

pytest.importorskip("robosuite")  # the extra skillbank[sim]


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """Two scripted Lift episodes on robosuite's Panda (``sim record --robot Panda``)."""
    from skillbank.simulation import record

    out = tmp_path_factory.mktemp("panda") / "lift_panda.h5"
    report = record("robosuite:Lift", episodes=2, out=out, seed=3, robot="Panda")
    assert report["robot"] == "Panda" and report["episodes"] == 2
    with h5py.File(out) as h5:
        frames = json.loads(h5["data"].attrs["robot"])
        demos = [{k: h5[f"data/demo_{i}/obs/{k}"][:] for k in
                  ("robot0_joint_pos", "robot0_eef_pos", "robot0_eef_quat")} for i in range(2)]
    return {"path": out, "frames": frames, "demos": demos}


def _model(recording):
    frames = recording["frames"]
    assert frames["name"] == "Panda" and frames["flange"] == "right_hand"
    return robot_model("panda", base=np.array(frames["base"]), tool=np.array(frames["tool"]))


def test_the_recording_says_its_poses_are_of_the_hands_grip_site(recording):
    from skillbank.io import read_robomimic

    assert recording["frames"]["pose_of"] == "panda_hand:grip_site"
    assert {d.metadata["pose_of"] for d in read_robomimic(recording["path"])} == {"panda_hand:grip_site"}


def test_fk_of_the_recorded_joints_is_the_recorded_tool_pose(recording):
    model = _model(recording)
    # the registered Panda's default tool is the grip site robosuite reports
    np.testing.assert_allclose(np.array(recording["frames"]["tool"]), robot_model("panda").tool, atol=1e-6)
    for demo in recording["demos"]:
        position, quaternion = model.fk(demo["robot0_joint_pos"])
        assert np.linalg.norm(position - demo["robot0_eef_pos"], axis=1).max() < 1e-3
        assert np.degrees(quaternion_angle(quaternion, demo["robot0_eef_quat"])).max() < 0.5


def test_ik_of_the_recorded_poses_reproduces_them_and_with_the_joints_as_reference_the_joints(recording):
    model = _model(recording)
    for demo in recording["demos"]:
        q, P, Q = demo["robot0_joint_pos"], demo["robot0_eef_pos"], demo["robot0_eef_quat"]
        seeded = model.ik(P, Q, q_seed=q[0])
        p, qt = model.fk(seeded)
        assert np.linalg.norm(p - P, axis=1).max() < 2e-6
        assert np.abs(np.diff(seeded, axis=0)).max() < model.max_step
        # the 7th joint leaves one degree of freedom per pose: robosuite's controller drifts along it, so
        # the recorded joints are what the null space follows when they are given
        followed = model.ik(P, Q, q_seed=q[0], q_reference=q)
        assert np.abs(followed - q).max() < 0.01


def test_a_skill_reused_on_the_panda_runs_in_physics_without_a_link_collision(cli, recording, tmp_path):
    db = tmp_path / "lib.db"
    assert cli("library", "init", db)[0] == 0
    assert cli("library", "add", db, recording["path"], "--label", "lift")[0] == 0
    base = recording["frames"]["base"]
    where = ",".join(f"{v:.6f}" for v in np.array(base)[:3, 3])
    out = tmp_path / "reach.npz"
    code, text, err = cli("library", "reuse", db, "--skill", "lift", "--method", "ja",
                          "--goal", "0.02,0.03,0.86", "--robot", "panda", "--robot-base", where,
                          "--out", out, "--simulate", "--json")
    assert code == 0, err
    doc = json.loads(text)
    assert doc["joint_names"] == [f"joint{i}" for i in range(1, 8)]
    assert doc["simulation"]["ok"] and doc["simulation"]["contacts"] == []
    assert doc["clearance"]["min_distance"] > 0
    assert doc["simulation"]["tracking"]["tool_max"] < 2e-3
    back = read_npz(out)
    assert back.metadata["robot"] == "panda"
    # the same file replayed by `skillbank simulate` on the same robot
    code, text, err = cli("simulate", out, "--scene", _empty_scene(tmp_path), "--robot", "panda",
                          "--robot-base", where, "--json")
    assert code == 0, err
    assert json.loads(text)["contacts"] == []
    # URScript is for Universal Robots' controllers only
    reuse = ("library", "reuse", db, "--skill", "lift", "--method", "ja", "--goal", "0.02,0.03,0.86",
             "--robot", "panda", "--robot-base", where)
    code, _, err = cli(*reuse, "--out", tmp_path / "r.script")
    assert code == 2 and "URScript runs on Universal Robots arms only" in err
    assert not (tmp_path / "r.script").exists()
    # a ROS 2 bag carries the Panda's joint names
    code, _, err = cli(*reuse, "--out", tmp_path / "bag", "--format", "rosbag")
    assert code == 0, err
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    with AnyReader([tmp_path / "bag"], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        conn = next(c for c in reader.connections if c.topic == "/joint_trajectory")
        _, _, raw = next(reader.messages(connections=[conn]))
        msg = reader.deserialize(raw, conn.msgtype)
    assert list(msg.joint_names) == [f"joint{i}" for i in range(1, 8)]


def _empty_scene(tmp_path):
    path = tmp_path / "empty.json"
    # a goal the simulation cannot judge: the replay's own facts (contacts, tracking) decide
    mark = {"type": "place", "position": [2.0, 2.0, 0.0]}  # out of reach: nothing to touch
    path.write_text(json.dumps({"objects": {"mark": mark}, "goal": ["(marked mark)"]}))
    return path


def test_record_names_robosuites_arms_when_the_robot_is_unknown(tmp_path):
    from skillbank.simulation import record

    with pytest.raises(ValueError, match=r"robot: expected one of robosuite's single arms \['UR5e', 'Panda'"):
        record("robosuite:Lift", episodes=1, out=tmp_path / "x.h5", robot="Kuka")


def test_edit_on_the_panda_writes_joints_whose_fk_is_the_edited_path(cli, tmp_path):
    """`skillbank edit --robot panda`: the edited pose path and its joints agree to the IK's tolerance."""
    import skillbank
    from skillbank.io import write_npz

    model = robot_model("panda")
    s = np.linspace(0.0, 1.0, 400)[:, None]
    q = np.asarray(model.home) + 0.3 * np.sin(np.pi * s * np.arange(1, 8) / 4)
    position, quaternion = model.fk(q)
    demo = skillbank.Demonstration(4.0 * s[:, 0], {"position": position, "orientation": quaternion})
    path = write_npz(demo, tmp_path / "demo.npz")
    goal = position[-1] + [0.03, -0.02, 0.01]
    # FK of the registered Panda: the poses are its hand's grip site's, which the file does not say
    code, _, err = cli("edit", path, "--robot", "panda", "--goal", ",".join(f"{v:.6f}" for v in goal),
                       "--pose-of", "panda_hand:grip_site", "--out", tmp_path / "edited.npz")
    assert code == 0, err
    back = read_npz(tmp_path / "edited.npz")
    assert back.metadata["robot"] == "panda" and back.metadata["pose_of"] == "panda_hand:grip_site"
    np.testing.assert_allclose(back["position"][-1], goal, atol=1e-6)
    p, quat = model.fk(back["joints"])
    assert np.linalg.norm(p - back["position"], axis=1).max() < 2e-6
    assert np.degrees(quaternion_angle(quat, back["orientation"])).max() < 1e-3
    assert np.abs(np.diff(back["joints"], axis=0)).max() < model.max_step
    # the joints keep the limits the description gives
    assert (back["joints"] >= np.asarray(model.lower) - 1e-9).all()
    assert (back["joints"] <= np.asarray(model.upper) + 1e-9).all()


def test_the_recorded_lift_is_clear_of_itself_with_the_hand(recording):
    """robosuite's Panda did not hit itself lifting the cube; its envelopes with the hand do not either."""
    from skillbank.robots import clearance

    model = _model(recording)
    assert model.gripper_.name == "panda_hand"
    for demo in recording["demos"]:
        result = clearance(model, demo["robot0_joint_pos"])
        assert result.min_distance > 0 and result.first_contact() is None
        hand = [v for k, v in result.per_pair.items() if {"hand", "finger_left", "finger_right"} & set(k)]
        assert min(hand) > 0
