"""Say which robot ran (issue 41, item 6): every command that simulates names the arm it drove, in its text
and its ``--json``; a library recorded on another arm gets a note; robot names are case-insensitive."""

from __future__ import annotations

import json
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from skillbank.core import Demonstration
from skillbank.io import write_npz
from skillbank.robots import registered_name, robot_model

# ------------------------------------------------------------------ names in any case (no simulator needed)


@pytest.mark.parametrize(("given", "name"), [("ur5e", "ur5e"), ("UR5e", "ur5e"), ("UR5E", "ur5e"),
                                             ("Ur5E", "ur5e"), ("panda", "panda"), ("Panda", "panda"),
                                             ("PANDA", "panda")])
def test_registered_names_are_case_insensitive(given, name):
    assert registered_name(given) == name
    if name == "ur5e":  # the Panda's description needs the sim extra; its name is the same rule
        assert robot_model(given).name == "ur5e"


def test_a_path_or_an_unknown_name_is_left_alone_and_refused_as_before(tmp_path):
    assert registered_name("arm.URDF") == "arm.URDF" and registered_name(tmp_path) == tmp_path
    with pytest.raises(ValueError, match=r"^robot: expected one of \['ur5e', 'panda'\] or a URDF / MJCF "
                                         r"file, got 'Kuka'$"):
        robot_model("Kuka")


@pytest.mark.parametrize("given", ["UR5E", "Ur5e"])
def test_the_command_line_takes_the_robot_in_any_case(cli, tmp_path, given):
    """``library reuse``, ``plan``, ``simulate``: --robot goes through the one registry rule."""
    pytest.importorskip("mujoco")
    home = np.array(robot_model("ur5e").home)
    t = np.linspace(0.0, 0.5, 11)
    traj = tmp_path / "still.npz"
    write_npz(Demonstration(t, {"joints": np.tile(home, (len(t), 1))}), traj)
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({"objects": {"p": {"type": "spot", "position": [0.4, 0.0, 0.1]}},
                                 "goal": ["(pressed p)"]}))
    code, out, err = cli("simulate", str(traj), "--scene", str(scene), "--robot", given, "--json")
    assert code == 0, err
    assert json.loads(out)["robot"] == "ur5e"
    code, out, err = cli("simulate", str(traj), "--scene", str(scene), "--robot", given)
    assert code == 0, err
    assert out.splitlines()[0].startswith(f"{traj}: simulated 0.5 s on ur5e at ")


def test_library_reuse_takes_the_robot_in_any_case(cli, data_dir, tmp_path):
    from skillbank import Library

    db = tmp_path / "lib.db"
    with Library(db) as lib:
        lib.add_files([data_dir / "seed" / "three_button_pressing_demo.h5"], label="button")
        goal = next(p.demo for p in lib.primitives() if p.id == 3)["position"][-1] + [0.03, -0.02, 0.0]
    joints = {}
    for given in ("ur5e", "UR5E", "Ur5e"):
        code, out, err = cli("library", "reuse", db, "--skill", "button", "--method", "ja", "--goal",
                             ",".join(f"{v:.6f}" for v in goal), "--robot", given, "--json")
        assert code == 0, err
        joints[given] = json.loads(out)["streams"]["joints"]
    for given in ("UR5E", "Ur5e"):  # the same arm: the same joints (to round-off)
        np.testing.assert_allclose(joints[given], joints["ur5e"], atol=1e-12)


# ------------------------------------------------------------------ robosuite's arms


def test_robosuites_arm_names_are_case_insensitive_too():
    from skillbank.simulation._robosuite import RECORD_ROBOTS, robosuite_robot

    assert [robosuite_robot(r.lower()) for r in RECORD_ROBOTS] == list(RECORD_ROBOTS)
    assert robosuite_robot("UR5E") == "UR5e" and robosuite_robot(" panda ") == "Panda"
    with pytest.raises(ValueError, match=r"^robot: expected one of robosuite's single arms \['UR5e', "
                                         r"'Panda', .*\] \(any case\), got 'Kuka'$"):
        robosuite_robot("Kuka")


def test_the_arm_a_demonstration_was_recorded_on_is_read_where_it_is_said(tmp_path):
    from skillbank.simulation._robosuite import recorded_robot

    demo = Demonstration([0.0, 1.0], {"x": [[0.0], [1.0]]})
    assert recorded_robot(demo) is None
    demo.metadata["robot"] = "Panda"
    assert recorded_robot(demo) == "Panda"
    demo.metadata["robot"] = json.dumps({"name": "Sawyer", "base": [0, 0, 0]})
    assert recorded_robot(demo) == "Sawyer"
    del demo.metadata["robot"]
    demo.metadata["env_args"] = {"env_name": "Lift", "env_kwargs": {"robots": ["IIWA"]}}
    assert recorded_robot(demo) == "IIWA"
    # the readers keep the arm their file names (sim record's data.attrs["robot"], else env_args)
    demo = Demonstration([0.0, 1.0], {"x": [[0.0], [1.0]]}, {"arm": "Panda"})
    assert recorded_robot(demo) == "Panda"
    # a path in the metadata is never opened: a library's rows do not make a command read files
    path = tmp_path / "rec.hdf5"
    with h5py.File(path, "w") as h5:
        h5.create_group("data").attrs["robot"] = json.dumps({"name": "Panda"})
    demo = Demonstration([0.0, 1.0], {"x": [[0.0], [1.0]]}, {"format": "robomimic-h5", "source": str(path)})
    assert recorded_robot(demo) is None


def test_a_note_only_when_the_library_was_recorded_on_another_arm():
    from skillbank.simulation._evaluate import driven_robot

    def sources(*names):
        return [SimpleNamespace(id=i, robot=n) for i, n in enumerate(names)]

    assert driven_robot(sources("UR5e", "ur5e")) == {"robot": "UR5e", "recorded_on": ["UR5e"], "notes": []}
    assert driven_robot(sources(None)) == {"robot": "UR5e", "recorded_on": [], "notes": []}
    assert driven_robot(sources("panda", "Kuka"))["recorded_on"] == ["Kuka", "Panda"]
    assert driven_robot(sources("Panda", None))["notes"] == [
        "library recorded on Panda; driven on UR5e", "1 of the library's 2 demonstrations say no arm"]


def test_experiment_text_names_the_arm(cli, monkeypatch):
    import skillbank.experiments as experiments

    report = {"experiment": "unload", "scene": "robosuite:PickPlace", "robot": "UR5e", "method": "lte",
              "seed": 0, "demos": 1, "episodes": 1, "successes": 1, "success_rate": 1.0,
              "interval": [0.2, 1.0], "failures": {}, "labelled": {"pick": 1, "place": 2},
              "library": {"demonstrations": 1, "primitives": 4, "skills": 2},
              "per_episode": [{"seed": 1000, "plan": ["(pick milk)"], "success": True}]}
    monkeypatch.setattr(experiments, "composition_experiment", lambda *a, **k: report)
    code, out, err = cli("experiment", "unload", "--episodes", "1")
    assert code == 0, err
    assert "robosuite:PickPlace (lte, on UR5e): 1/1 = 100 %" in out
    code, out, err = cli("experiment", "unload", "--episodes", "1", "--json")
    assert code == 0 and json.loads(out)["robot"] == "UR5e"


@pytest.fixture(scope="module")
def panda_library(tmp_path_factory):
    """One scripted Lift episode recorded on robosuite's Panda, asked for as ``panda``, in a library."""
    pytest.importorskip("robosuite")
    from skillbank.pipeline import Library
    from skillbank.simulation import record

    folder = tmp_path_factory.mktemp("panda_lift")
    out = folder / "lift.hdf5"
    report = record("robosuite:Lift", episodes=1, out=out, seed=3, robot="panda")
    assert report["robot"] == "Panda"
    with h5py.File(out) as h5:
        assert json.loads(h5["data"].attrs["robot"])["name"] == "Panda"
    db = folder / "lift.db"
    with Library(db) as lib:
        lib.add_files([out])
    return db


def test_sim_evaluate_says_it_drove_the_ur5e_a_library_recorded_on_the_panda(cli, panda_library):
    argv = ("sim", "evaluate", str(panda_library), "--env", "robosuite:Lift", "--episodes", "1",
            "--horizon", "20")
    code, out, err = cli(*argv, "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["robot"] == "UR5e" and doc["recorded_on"] == ["Panda"]
    # and how its poses are taken on the UR5e (issue 42, item 4): the Panda hand's grip site as the 2F-85's
    assert doc["notes"] == [
        "library recorded on Panda; driven on UR5e",
        "pose_of: poses of the panda_hand's grip site (recorded on Panda) taken as UR5e's grip site "
        "(robotiq_2f85:grip_site): where the hand holds is kept, not its flange"]
    code, out, err = cli(*argv)
    assert code == 0, err
    assert out.splitlines()[0].endswith(", on UR5e")
    assert "  note: library recorded on Panda; driven on UR5e" in out.splitlines()


def test_sim_evaluate_runs_on_the_arm_asked_for(cli, panda_library):
    """`sim evaluate --robot panda` drives robosuite's Panda: the arm that recorded the library, so no note;
    the lift succeeds on it (the scripted episode's own arm)."""
    code, out, err = cli("sim", "evaluate", str(panda_library), "--env", "robosuite:Lift", "--episodes", "2",
                         "--seed", "40", "--robot", "panda", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["robot"] == "Panda" and doc["recorded_on"] == ["Panda"] and doc["notes"] == []
    assert doc["successes"] >= 1
    code, out, err = cli("sim", "evaluate", str(panda_library), "--env", "robosuite:Lift", "--robot", "Kuka")
    assert code == 2 and out == "" and "robot: expected one of robosuite's single arms" in err
