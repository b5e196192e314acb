"""robomimic HDF5 datasets, written here with h5py in robomimic's layout."""

from __future__ import annotations

import json
import re

import h5py
import numpy as np
import pytest

from skillbank.core import Demonstration
from skillbank.io import FormatError, detect_format, load, load_all, read_robomimic, read_robot_h5
from skillbank.segmentation import MultimodalSegmenter


def write_robomimic(path, demos: dict, *, env_args=None, masks=None):
    """Write ``{N: {"obs": {key: array}, "actions": array}}`` as ``data/demo_N``; ``masks``: filter keys."""
    with h5py.File(path, "w") as h5:
        data = h5.create_group("data")
        if env_args is not None:
            data.attrs["env_args"] = env_args if isinstance(env_args, str) else json.dumps(env_args)
        for number, demo in demos.items():
            group = data.create_group(f"demo_{number}")
            for key, value in demo["obs"].items():
                group[f"obs/{key}"] = value
            if "actions" in demo:
                group["actions"] = demo["actions"]
                group["rewards"] = np.zeros(len(demo["actions"]))
            group.attrs["num_samples"] = len(next(iter(demo["obs"].values())))
        for name, members in (masks or {}).items():
            h5[f"mask/{name}"] = np.array([m.encode() for m in members])
    return path


def _demo(n, offset):
    t = np.arange(n, dtype=float)
    return {"obs": {"robot0_eef_pos": np.column_stack([t + offset, -t, 0 * t]),
                    "robot0_gripper_qpos": np.column_stack([t / n, -t / n]),
                    "agentview_image": np.zeros((n, 8, 8, 3), dtype=np.uint8)},
            "actions": np.column_stack([t, t + 1])}


LIFT = {"env_name": "Lift", "type": 1, "env_kwargs": {"control_freq": 25, "has_renderer": False}}


def raises_format(path, match: str):
    return pytest.raises(FormatError, match=f"^cannot read '{re.escape(str(path))}': {match}")


def test_demos_read_back(tmp_path):
    path = write_robomimic(tmp_path / "lift.hdf5", {10: _demo(4, 100), 0: _demo(6, 0), 1: _demo(5, 10)},
                           env_args=LIFT, masks={"train": ["demo_0", "demo_10"], "valid": ["demo_1"]})
    assert detect_format(path) == "robomimic-h5"
    demos = read_robomimic(path)
    assert [d.metadata["episode"] for d in demos] == [0, 1, 10]
    assert [d.n_steps for d in demos] == [6, 5, 4]
    demo = demos[1]
    # the tool pose under skillbank's name, once, so a library takes the file as it is
    assert demo.stream_names == ["actions", "position", "gripper"]
    assert demo.metadata["renamed"] == {"robot0_eef_pos": "position", "robot0_gripper_qpos": "gripper"}
    np.testing.assert_array_equal(demo["position"][:, 0], 10 + np.arange(5))
    np.testing.assert_array_equal(demo["actions"], np.column_stack([np.arange(5), np.arange(5) + 1]))
    np.testing.assert_allclose(demo.t, np.arange(5) / 25)
    meta = demo.metadata
    assert meta["label"] == "Lift" and meta["demo"] == "demo_1" and meta["format"] == "robomimic-h5"
    assert meta["rate_hz"] == 25 and meta["rate_from"] == "env_args"
    assert meta["skipped_obs"] == {"agentview_image": [5, 8, 8, 3]}
    assert json.loads(json.dumps(meta, allow_nan=False)) == meta
    assert [d.metadata["episode"] for d in load_all(path, reader_options={"episodes": "1:11"})] == [1, 10]
    assert load(path, index=2).metadata["demo"] == "demo_10"
    assert [d.metadata["demo"] for d in read_robomimic(path, filter_key="train")] == ["demo_0", "demo_10"]
    only = read_robomimic(path, episodes=[10], obs_keys=["robot0_eef_pos"], control_freq=50)
    assert only[0].stream_names == ["actions", "position"]
    assert only[0].metadata["rate_from"] == "argument"
    np.testing.assert_allclose(only[0].t, np.arange(4) / 50)


def test_the_default_rate_without_env_args(tmp_path):
    path = write_robomimic(tmp_path / "bare.hdf5", {0: _demo(3, 0)})
    demo, = read_robomimic(path)
    assert demo.metadata["rate_hz"] == 20.0 and demo.metadata["rate_from"] == "default"
    assert "label" not in demo.metadata


def test_what_is_not_a_robomimic_file(tmp_path, robot_h5):
    text = tmp_path / "notes.hdf5"
    text.write_text("hello\n")
    with raises_format(text, "expected HDF5 content, found a text file$"):
        read_robomimic(text)
    robot = robot_h5("robot.h5")
    with raises_format(robot, r"expected a robomimic dataset \(group 'data' with demo_N groups\), found "
                              r"\['gripper_info', "):
        read_robomimic(robot)
    empty = tmp_path / "empty.hdf5"
    with h5py.File(empty, "w") as h5:
        h5.create_group("data/not_a_demo")
    with raises_format(empty, r"expected a robot recording \(group 'joint_state_info'\), handwriting "
                              r"\(groups \['normalized', 'smoothed', 'unsmoothed'\]\) or robomimic \(group "
                              r"'data' with demo_N groups\), found groups \['data'\]$"):
        load_all(empty)


@pytest.mark.parametrize(("env_args", "message"), [
    ("{not json", r"invalid JSON in data.attrs\['env_args'\]: "),
    ({"env_kwargs": {"control_freq": 0}}, r"expected a positive env_args\['env_kwargs'\]\['control_freq'\], "
                                          r"found 0$"),
])
def test_bad_env_args(tmp_path, env_args, message):
    path = write_robomimic(tmp_path / "bad.hdf5", {0: _demo(3, 0)}, env_args=env_args)
    with raises_format(path, message):
        read_robomimic(path)


def test_bad_demos_and_options(tmp_path):
    uneven = _demo(5, 0)
    uneven["actions"] = uneven["actions"][:4]
    path = write_robomimic(tmp_path / "uneven.hdf5", {0: _demo(3, 0), 1: uneven}, env_args=LIFT,
                           masks={"train": ["demo_0"]})
    with raises_format(path, r"expected the streams of 'demo_1' to have one non-zero length, found "
                             r"\{'robot0_eef_pos': 5, 'robot0_gripper_qpos': 5, 'actions': 4\}$"):
        read_robomimic(path)
    assert len(read_robomimic(path, episodes=0)) == 1
    with pytest.raises(ValueError, match=r"filter_key: expected one of \['train'\], got 'test'"):
        read_robomimic(path, filter_key="test")
    with pytest.raises(ValueError, match=r"obs_keys: expected names among \['agentview_image', "
                                         r"'robot0_eef_pos', 'robot0_gripper_qpos'\] \(in demo_0\), got "
                                         r"\['eef'\]"):
        read_robomimic(path, obs_keys=["eef"])
    with pytest.raises(ValueError, match=r"obs_keys: expected a list of observation names, got \[\]"):
        read_robomimic(path, obs_keys=[])
    with pytest.raises(ValueError, match=r"control_freq: expected a number > 0, got -5"):
        read_robomimic(path, control_freq=-5)
    with pytest.raises(ValueError, match=r"episodes: expected numbers among \[0, 1\], got missing \[7\]"):
        read_robomimic(path, episodes=[7])
    images = write_robomimic(tmp_path / "images.hdf5", {0: {"obs": {"image": np.zeros((3, 4, 4, 3))}}})
    with raises_format(images, r"expected numeric observations or actions in 'demo_0', found none$"):
        read_robomimic(images)


def test_three_button_reads_as_the_hdf5_file_of_the_same_samples(uniform_three_button, tmp_path):
    # robomimic keeps samples at the control rate: the same numbers as the uniform HDF5 recording.
    u = uniform_three_button
    s = u["streams"]
    obs = {"robot0_joint_pos": s["joints"], "robot0_eef_pos": s["position"],
           "robot0_eef_quat": s["orientation"], "ft_force": s["force"], "ft_torque": s["torque"],
           "robot0_gripper_qpos": s["gripper"]}
    actions = np.vstack([s["joints"][1:], s["joints"][-1:]])
    path = write_robomimic(tmp_path / "three_button.hdf5", {0: {"obs": obs, "actions": actions}},
                           env_args={"env_name": "ThreeButtons", "env_kwargs": {"control_freq": u["rate"]}})
    demo, = read_robomimic(path)
    h5 = read_robot_h5(u["h5"])
    np.testing.assert_allclose(demo.t, h5.t, atol=1e-9)
    keys = {"joints": "robot0_joint_pos", "position": "position", "orientation": "orientation",
            "force": "ft_force", "torque": "ft_torque", "gripper": "gripper"}
    as_h5 = Demonstration(demo.t, {name: demo[key] for name, key in keys.items()})
    for name in h5.stream_names:
        np.testing.assert_allclose(as_h5[name], h5[name], atol=1e-9, err_msg=name)
    ours, theirs = MultimodalSegmenter().fit(as_h5).result_, MultimodalSegmenter().fit(h5).result_
    assert ours.n_segments == theirs.n_segments > 1 and ours.bounds == theirs.bounds


@pytest.mark.parametrize(("env_kwargs", "attrs", "point"), [
    ({"robots": ["Panda"]}, None, "panda_hand:grip_site"),
    ({"robots": "UR5e"}, None, "robotiq_2f85:grip_site"),
    ({"robots": ["Panda"], "gripper_types": "Robotiq85Gripper"}, None, None),  # another gripper: unknown
    ({"robots": ["Sawyer"]}, None, None),
    ({}, None, None),
    ({"robots": ["Panda"]}, {"pose_of": "flange"}, "flange"),  # what the recorder wrote wins
    ({}, {"tool": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.12], [0, 0, 0, 1]]}, "0,0,0.12,0,0,0,1"),
])
def test_the_point_the_poses_are_of_is_what_the_file_says(tmp_path, env_kwargs, attrs, point):
    path = write_robomimic(tmp_path / "d.hdf5", {0: _demo(4, 0)},
                           env_args={**LIFT, "env_kwargs": {**LIFT["env_kwargs"], **env_kwargs}})
    if attrs is not None:
        with h5py.File(path, "a") as h5:
            h5["data"].attrs["robot"] = json.dumps(attrs)
    assert read_robomimic(path)[0].metadata.get("pose_of") == point


def test_a_malformed_stated_point_is_one_line(tmp_path):
    path = write_robomimic(tmp_path / "d.hdf5", {0: _demo(4, 0)}, env_args=LIFT)
    with h5py.File(path, "a") as h5:
        h5["data"].attrs["robot"] = json.dumps({"pose_of": "tcp"})
    with pytest.raises(ValueError, match=r"data.attrs\['robot'\]\['pose_of'\]: expected 'flange', .*'tcp' "
                                         r"alone does not say whose"):
        read_robomimic(path)


@pytest.mark.parametrize(("env_kwargs", "attrs", "arm"), [
    ({"robots": ["Panda"]}, None, "Panda"), ({"robots": "UR5e"}, None, "UR5e"), ({}, None, None),
    ({"robots": ["Panda", "Panda"]}, None, None), ({"robots": ["UR5e"]}, {"name": "Panda"}, "Panda"),
])
def test_the_arm_the_file_was_recorded_on(tmp_path, env_kwargs, attrs, arm):
    path = write_robomimic(tmp_path / "d.hdf5", {0: _demo(4, 0)},
                           env_args={**LIFT, "env_kwargs": {**LIFT["env_kwargs"], **env_kwargs}})
    if attrs is not None:
        with h5py.File(path, "a") as h5:
            h5["data"].attrs["robot"] = json.dumps(attrs)
    assert read_robomimic(path)[0].metadata.get("arm") == arm
