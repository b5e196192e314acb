"""What people record through robosuite: raw collection files (states, no observations), replayed."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from skillbank.io import FormatError, detect_format, load_all, read_robosuite_raw

pytest.importorskip("robosuite")  # the extra skillbank[sim]: the states are replayed in robosuite


@pytest.fixture(scope="module")
def human(data_dir):
    return data_dir / "human" / "lift_panda_teleop.hdf5"


@pytest.fixture(scope="module")
def demos(human):
    return read_robosuite_raw(human)


def test_three_real_human_lift_demonstrations_read_as_a_recorders(human, demos):
    assert detect_format(human) == "robosuite-raw"
    assert [d.n_steps for d in demos] == [482, 510, 392]
    for d in demos:
        assert {"position", "orientation", "gripper", "robot0_joint_pos", "cube_pos", "cube_quat",
                "actions"} == set(d.stream_names)
        assert d.metadata["label"] == "Lift" and d.metadata["arm"] == "Panda"
        assert d.metadata["pose_of"] == "panda_hand:grip_site" and d.metadata["format"] == "robosuite-raw"
        assert d.metadata["robosuite_version"] == "1.4.0"
        # the recorded world (robosuite 1.4.0's MJCF, compiled without a file) and today's put the tool
        # at the same place at every state
        check = d.metadata["world_check"]
        assert check["checked"] and check["agrees"] and check["max_tool_gap"] < 1e-6
        assert np.allclose(d.t[1] - d.t[0], 0.05)
    # the person lifted the cube: its last height is above its first
    assert all(d["cube_pos"][-1, 2] > d["cube_pos"][0, 2] + 0.03 for d in demos)


def test_the_tool_pose_is_the_simulators_by_forward_kinematics_of_the_joints(demos):
    """Independently of robosuite's observables: the registered Panda model, placed where robosuite's
    Lift puts its base, gives the replayed tool pose from the replayed joints."""
    from skillbank.core import quaternion_angle
    from skillbank.robots import robot_model
    from skillbank.simulation._robosuite import _env_args, import_robosuite, robot_frames

    suite = import_robosuite()
    env = suite.make("Lift", **_env_args("Lift", 10, 0, "Panda")["env_kwargs"])
    try:
        env.reset()
        frames = robot_frames(env)
    finally:
        env.close()
    model = robot_model("panda", base=np.array(frames["base"]))
    for d in demos:
        p, q = model.fk(d["robot0_joint_pos"])
        assert np.linalg.norm(p - d["position"], axis=1).max() < 1e-3
        assert np.degrees(quaternion_angle(q, d["orientation"])).max() < 0.5


def test_episodes_and_a_library_add(human, cli, tmp_path):
    assert [d.metadata["episode"] for d in load_all(human, reader_options={"episodes": "2,3"})] == [2, 3]
    db = tmp_path / "lib.sqlite"
    assert cli("library", "init", db)[0] == 0
    code, out, err = cli("library", "add", db, human, "--json")
    assert code == 0, err
    assert len(json.loads(out)["demonstrations"]) == 3
    assert "robosuite" not in err  # robosuite's set-up log is not the command's output


def _copy(human, path, *, env_info=None, states=None, model_file=None, drop=()):
    """The first demonstration of the real file, with parts replaced."""
    with h5py.File(human) as src, h5py.File(path, "w") as dst:
        data = dst.create_group("data")
        for key, value in src["data"].attrs.items():
            if key not in drop:
                data.attrs[key] = value
        if env_info is not None:
            data.attrs["env_info"] = json.dumps(env_info)
        g = data.create_group("demo_1")
        g["states"] = src["data/demo_1/states"][:40] if states is None else states
        g["actions"] = src["data/demo_1/actions"][:40]
        g.attrs["model_file"] = src["data/demo_1"].attrs["model_file"] if model_file is None else model_file
    return path


def test_a_robomimic_file_with_states_only_reads_the_same(human, demos, tmp_path):
    path = tmp_path / "states.hdf5"
    with h5py.File(human) as src, h5py.File(path, "w") as dst:
        data = dst.create_group("data")
        data.attrs["env_args"] = json.dumps({"env_name": "Lift", "type": 1,
                                             "env_kwargs": {"robots": ["Panda"], "control_freq": 20}})
        dst["data/demo_0/states"] = src["data/demo_1/states"][:40]
    (demo,) = read_robosuite_raw(path)
    np.testing.assert_allclose(demo["position"], demos[0]["position"][:40], atol=1e-12)
    assert demo.metadata["world_check"] == {"checked": False, "why": "the file records no model_file"}


def test_a_recorded_world_that_names_files_opens_none_of_them(human, demos, tmp_path):
    """The recorded MJCF is the user's: its meshes and textures are dropped before MuJoCo compiles it, so a
    path outside (or a FIFO that would hang) is never opened; the check still compares the frames."""
    import os

    fifo = tmp_path / "outside.fifo"
    os.mkfifo(fifo)
    with h5py.File(human) as src:
        xml = src["data/demo_1"].attrs["model_file"]
    xml = xml.replace("<asset>", f'<asset><mesh name="evil" file="{fifo}"/><texture name="e2" type="cube" '
                                 f'fileright="{fifo}" fileleft="/etc/shadow"/>', 1)
    (demo,) = read_robosuite_raw(_copy(human, tmp_path / "f.hdf5", model_file=xml))
    assert demo.metadata["world_check"]["agrees"]
    np.testing.assert_allclose(demo["position"], demos[0]["position"][:40], atol=1e-12)


@pytest.mark.parametrize(("change", "match"), [
    ({"env_info": {"env_name": "Lift", "robots": "UR5e"}},
     r"'demo_1/states' holds 32 values a step, and robosuite's Lift with \['UR5e'\] has \d+: recorded in "
     r"another world"),
    ({"env_info": {"env_name": "NoSuchTask", "robots": "Panda"}},
     r"the environment 'NoSuchTask' is not one of robosuite's"),
    ({"env_info": {"env_name": "Lift"}}, r"expected the recorded robot\(s\) in the environment's 'robots'"),
    ({"drop": ("env_info", "env")}, r"expected data.attrs\['env_info'\] \(robosuite's raw format\) or "
                                    r"data.attrs\['env_args'\] \(robomimic\)"),
    ({"states": np.zeros((3, 32, 2))}, r"expected 'demo_1/states' of shape \(steps, state size\)"),
    ({"model_file": '<!DOCTYPE x [<!ENTITY e SYSTEM "/etc/passwd">]><mujoco/>'},
     r"the recorded model_file declares a DOCTYPE or entities; refused"),
])
def test_what_cannot_be_replayed_is_one_line(human, tmp_path, change, match):
    path = _copy(human, tmp_path / "bad.hdf5", **change)
    with pytest.raises(FormatError, match=f"^cannot read '{path}': {match}"):
        read_robosuite_raw(path)


def test_each_real_persons_lift_is_one_halting_reach_and_one_lift(human, demos, cli):
    """The people's approaches stop a dozen times; each is one reach ending where the fingers close on
    the cube, then one carry: the phases, not the pauses, cut them (`segment --no-phases`: the pauses)."""
    from skillbank.segmentation import demonstration_phases

    for d in demos:
        phases = demonstration_phases(d)
        assert [(p.kind, p.object) for p in phases] == [("reach", "cube"), ("carry", "cube")]
        reach = phases[0]
        # the cut is where the command to close is given (a switch, mid-way through the closing)
        closing = np.flatnonzero(d["actions"][:, 6] > 0)
        assert 0 <= reach.stop - closing[0] <= 10
    code, out, _ = cli("segment", human, "--demo", "0", "--json")
    assert code == 0 and json.loads(out)["n_segments"] == 2
    assert [p["kind"] for p in json.loads(out)["phases"]] == ["reach", "carry"]
    code, out, _ = cli("segment", human, "--demo", "0", "--json", "--no-phases")
    assert code == 0 and json.loads(out)["n_segments"] > 4 and json.loads(out)["phases"] == []


def test_a_persons_lift_runs_to_success_in_a_new_scene_on_another_arm(human, tmp_path):
    """One real person's Lift (Panda, halting, off centre), learned and run on the UR5e in a scene its
    demonstration did not show: the environment's own check holds."""
    from skillbank.pipeline import Library
    from skillbank.simulation import evaluate

    db = tmp_path / "person.sqlite"
    with Library(db, create=True) as lib:
        lib.add_files([human], index=0)
    report = evaluate(db, "robosuite:Lift", episodes=1, seed=31, placement=0.1, robot="UR5e")
    row = report["per_episode"][0]
    assert report["robot"] == "UR5e" and report["recorded_on"] == ["Panda"]
    assert row["success"], row.get("failure")
    # the cube stood elsewhere than in the demonstration
    start = read_robosuite_raw(human)[0]["cube_pos"][0]
    assert np.linalg.norm(np.asarray(row["objects"]["cube"][:2]) - start[:2]) > 0.03
