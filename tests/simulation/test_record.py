"""``skillbank sim record``: scripted robosuite episodes on the UR5e, in robomimic's layout, read back.

Real robosuite episodes (short ones): Lift and Stack, the environment's own success check keeping each.
"""

from __future__ import annotations

import json
import re

import h5py
import numpy as np
import pytest

pytest.importorskip("robosuite")  # the extra skillbank[sim]

from skillbank.cli import main  # noqa: E402
from skillbank.io import read_robomimic  # noqa: E402
from skillbank.pipeline import Library  # noqa: E402
from skillbank.selection import acted_on, compose  # noqa: E402
from skillbank.simulation import record  # noqa: E402


@pytest.fixture(scope="module")
def lift(tmp_path_factory):
    out = tmp_path_factory.mktemp("lift") / "lift.hdf5"
    report = record("robosuite:Lift", episodes=2, out=out, seed=3)
    return out, report


def test_a_lift_recording_has_robomimics_layout_and_every_object_pose(lift):
    out, report = lift
    assert report["episodes"] == 2 and report["tried"] >= 2 and report["out"] == str(out)
    with h5py.File(out, "r") as h5:
        args = json.loads(h5["data"].attrs["env_args"])
        assert args["env_name"] == "Lift" and args["env_kwargs"]["control_freq"] == 20
        assert args["env_kwargs"]["robots"] == ["UR5e"] and args["env_kwargs"]["seed"] == 3
        assert sorted(h5["data"].keys()) == ["demo_0", "demo_1"]
        total = 0
        for name in ("demo_0", "demo_1"):
            g = h5["data"][name]
            n = int(g.attrs["num_samples"])
            total += n
            assert sorted(g["obs"].keys()) == ["cube_pos", "cube_quat", "robot0_eef_pos", "robot0_eef_quat",
                                               "robot0_gripper_qpos", "robot0_joint_pos"]
            assert g["actions"].shape == (n, 7) and np.abs(g["actions"][()]).max() <= 1.0
            assert g["states"].shape[0] == n and g["rewards"].shape == (n,) and g["dones"].shape == (n,)
            # the episode did what the environment counted as success: the cube went up with the tool
            cube = g["obs"]["cube_pos"][()]
            assert cube[-1, 2] - cube[0, 2] > 0.1
            assert np.linalg.norm(cube[-1] - g["obs"]["robot0_eef_pos"][-1]) < 0.05
        assert h5["data"].attrs["total"] == total == report["samples"]


def test_the_episodes_vary_as_a_person_would(lift):
    out, _ = lift
    with h5py.File(out, "r") as h5:
        lengths = [int(h5["data"][k].attrs["num_samples"]) for k in ("demo_0", "demo_1")]
        starts = [h5["data"][k]["obs"]["cube_pos"][0] for k in ("demo_0", "demo_1")]
    assert lengths[0] != lengths[1]  # pace and pauses drawn per episode
    assert np.linalg.norm(starts[0] - starts[1]) > 1e-3  # robosuite's own placement, seeded


def test_the_recording_reads_back_into_a_library_with_the_tool_pose(lift, tmp_path):
    out, _ = lift
    demos = read_robomimic(out)
    assert [d.metadata["label"] for d in demos] == ["Lift", "Lift"]
    d = demos[0]
    assert d.metadata["renamed"] == {"robot0_eef_pos": "position", "robot0_eef_quat": "orientation",
                                     "robot0_gripper_qpos": "gripper"}
    with h5py.File(out, "r") as h5:
        np.testing.assert_array_equal(d["position"], h5["data"]["demo_0"]["obs"]["robot0_eef_pos"][()])
        np.testing.assert_array_equal(d["orientation"], h5["data"]["demo_0"]["obs"]["robot0_eef_quat"][()])
    np.testing.assert_allclose(np.diff(d.t), 1 / 20)
    assert "cube_pos" in d.streams and "cube_quat" in d.streams
    with Library(tmp_path / "lib.db") as lib:
        report = lib.add_files([out])
        assert len(report["demonstrations"]) == 2 and lib.primitives()


def test_each_primitive_knows_the_cube_it_acts_on_and_its_pose_on_it(lift, tmp_path):
    """From the library (the store's copy of the samples), found from the data alone: the primitive that
    lifts the cube moves with it, and the relative end pose put back on the cube's end pose is the
    recorded tool pose to well under a millimetre."""
    out, _ = lift
    with Library(tmp_path / "lib.db") as lib:
        lib.add_files([out])
        prims = lib.primitives()
    relations = [(p, acted_on(p.demo)) for p in prims]
    assert all(r is None or r.object == "cube" for _, r in relations)
    carried = [(p, r) for p, r in relations if r is not None and r.moves_with]
    assert carried, [(p.start, p.stop, r) for p, r in relations]
    for p, r in carried:
        position, orientation = compose(r, p.demo["cube_pos"][-1], p.demo["cube_quat"][-1])
        assert np.linalg.norm(position - p.demo["position"][-1]) < 1e-9
        assert abs(abs(float(orientation @ p.demo["orientation"][-1])) - 1.0) < 1e-9
        assert r.distance < 0.05  # held between the fingers
        # from where the cube was picked up: the lift's end, as a pose relative to the cube's start
        position, _ = compose(r, p.demo["cube_pos"][0], p.demo["cube_quat"][0], at="start")
        assert np.linalg.norm(position - p.demo["position"][-1]) < 1e-9


def test_a_stack_episode_puts_cube_a_on_cube_b(tmp_path):
    out = tmp_path / "stack.hdf5"
    assert record("robosuite:Stack", episodes=1, out=out, seed=1)["episodes"] == 1
    with h5py.File(out, "r") as h5:
        obs = h5["data"]["demo_0"]["obs"]
        a, b = obs["cubeA_pos"][-1], obs["cubeB_pos"][-1]
    assert np.linalg.norm((a - b)[:2]) < 0.02 and 0.03 < a[2] - b[2] < 0.06
    # the primitive that carries cube A knows it puts it on cube B, and where the tool ends on B
    with Library(tmp_path / "lib.db") as lib:
        lib.add_files([out])
        relations = [(p, acted_on(p.demo)) for p in lib.primitives()]
    puts = [(p, r) for p, r in relations if r is not None and r.moves_with and r.object == "cubeA"]
    assert puts and all(r.target == "cubeB" for _, r in puts), relations
    p, r = puts[-1]
    position, _ = compose(r, p.demo["cubeB_pos"][-1], p.demo["cubeB_quat"][-1], at="target")
    assert np.linalg.norm(position - p.demo["position"][-1]) < 1e-9


def test_a_can_goes_into_its_own_bin(tmp_path):
    out = tmp_path / "can.hdf5"
    assert record("robosuite:PickPlaceCan", episodes=1, out=out, seed=2)["episodes"] == 1
    with h5py.File(out, "r") as h5:
        can = h5["data"]["demo_0"]["obs"]["Can_pos"][()]
    assert can[-1, 1] - can[0, 1] > 0.3  # carried from the first bin to the second, where the can's place is


def test_a_tall_box_is_approached_straight_down_past_its_top(tmp_path):
    """The approach's heights are measured from the object's top: below a cereal box's top (15 cm tall,
    3 cm across the fingers' closing) the tool is over the grasp, not slanting in from the side."""
    out = tmp_path / "cereal.hdf5"
    assert record("robosuite:PickPlaceCereal", episodes=1, out=out, seed=4)["episodes"] == 1
    with h5py.File(out, "r") as h5:
        demo = h5["data"]["demo_0"]
        tool, box = demo["obs"]["robot0_eef_pos"][()], demo["obs"]["Cereal_pos"][()]
        closed = int(np.argmax(demo["actions"][:, 6] > 0))
    top = box[closed, 2] + 0.075  # the box's half height
    high = np.flatnonzero(tool[:closed, 2] >= top + 0.02)
    assert len(high)  # it came from above the top (the robot starts lower, beside it) ...
    low = np.arange(high[-1] + 1, closed)
    lateral = np.linalg.norm(tool[low, :2] - tool[closed, :2], axis=1)
    assert lateral.max() < 0.015  # ... over where it grasps


def test_a_square_nut_goes_round_its_peg(tmp_path):
    out = tmp_path / "nut.hdf5"
    assert record("robosuite:NutAssemblySquare", episodes=1, out=out, seed=7)["episodes"] == 1
    with h5py.File(out, "r") as h5:
        obs = h5["data"]["demo_0"]["obs"]
        nut, q = obs["SquareNut_pos"][()], obs["SquareNut_quat"][-1]
    assert nut[:, 2].max() - nut[0, 2] > 0.1  # lifted over the peg's top
    np.testing.assert_allclose(nut[-1, :2], [0.23, 0.1], atol=0.01)  # round robosuite's square peg
    yaw = np.arctan2(2 * (q[3] * q[2] + q[0] * q[1]), 1 - 2 * (q[1] ** 2 + q[2] ** 2))
    assert abs((yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4) < 0.05  # turned to the square


def test_the_command_records_and_says_so(tmp_path, capsys):
    out = tmp_path / "lift.hdf5"
    assert main(["sim", "record", "robosuite:Lift", "--episodes", "1", "--seed", "5", "--out", str(out),
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["episodes"] == 1 and doc["env"] == "robosuite:Lift" and out.exists()
    assert doc["out"] == str(out)
    # --force: recorded beside it and put in its place when whole (--env names the task as elsewhere)
    out.write_bytes(b"old")
    assert main(["sim", "record", "--env", "robosuite:Lift", "--episodes", "1", "--seed", "5", "--out",
                 str(out), "--force"]) == 0
    assert out.read_bytes()[:8] == b"\x89HDF\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["lift.hdf5"]


@pytest.mark.parametrize("argv, match", [
    (["Lift"], r"env: expected robosuite:TASK \(TASK one of \['Door', 'Lift', 'NutAssemblySquare', "
               r"'PickPlaceBread', 'PickPlaceCan', 'PickPlaceCereal', 'PickPlaceMilk', "
               r"'Stack', 'TwoArmHandover', 'TwoArmLift'\]\), got 'Lift'"),
    (["robosuite:Wipe"], r"env: the recorder knows robosuite tasks \['Door', 'Lift', 'NutAssemblySquare', "
                         r"'PickPlaceBread', 'PickPlaceCan', 'PickPlaceCereal', 'PickPlaceMilk', 'Stack', "
                         r"'TwoArmHandover', 'TwoArmLift'\], "
                         r"got 'Wipe'"),
    (["robosuite:Lift", "--episodes", "0"], r"episodes"),
    (["robosuite:Lift", "--out", "/nonexistent/folder/x.hdf5"],
     r"out: expected a file in an existing folder"),
])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, argv, match):
    args = ["sim", "record", *argv]
    if "--out" not in argv:
        args += ["--out", str(tmp_path / "x.hdf5")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and re.search(match, err), err
    assert not (tmp_path / "x.hdf5").exists()


def test_an_existing_file_is_not_overwritten(tmp_path, capsys):
    out = tmp_path / "x.hdf5"
    out.write_bytes(b"keep")
    assert main(["sim", "record", "robosuite:Lift", "--out", str(out)]) == 2
    assert "exists; give --force to overwrite it" in capsys.readouterr().err and out.read_bytes() == b"keep"
