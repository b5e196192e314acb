"""Any arm (issue 42, item 4): composed tasks recorded on one of robosuite's arms run on another.

Real robosuite episodes, short ones: a library of three scripted Stack demonstrations recorded on the
UR5e (robosuite's default) stacks three cubes on the Panda through ``plan --scene robosuite:Stack3
--simulate --robot panda``; ``experiment stack3`` records on the Panda (``--record-robot``) and runs on
the UR5e (``--robot``). The arm robosuite built is read from the environment itself, not from what the
report says; the error paths cost no simulation.
"""

from __future__ import annotations

import json
import re
from types import SimpleNamespace

import pytest

import skillbank.simulation._compose as compose
from skillbank.experiments._composition import _label_one_each
from skillbank.pipeline import Library
from skillbank.simulation import evaluate, execute_plan, record
from skillbank.simulation._arms import pose_points
from skillbank.simulation._evaluate import _sources, running_arm

TOWER = "(on cubeC cubeA) (on cubeA cubeB)"  # C on A on B: the demonstrations only put A on B
UR5E_TO_PANDA = ("pose_of: poses of the robotiq_2f85's grip site (recorded on UR5e) taken as Panda's grip "
                 "site (panda_hand:grip_site): where the hand holds is kept, not its flange")


@pytest.fixture(scope="module")
def ur5e_library(tmp_path_factory):
    """Three scripted Stack episodes recorded on robosuite's UR5e, labelled and described as the
    experiments do."""
    folder = tmp_path_factory.mktemp("any_arm")
    data = folder / "stack.hdf5"
    assert record("robosuite:Stack", episodes=3, out=data, seed=0)["robot"] == "UR5e"
    db = folder / "stack.db"
    with Library(db) as lib:
        lib.add_files([data], assign="recluster")
        _label_one_each(lib)
    return db


@pytest.fixture
def built(monkeypatch):
    """The arm, gripper and arm joints of each robosuite environment a composed task builds, as robosuite
    made them."""
    seen = []
    make = compose._make

    def spy(*args, **kwargs):
        env = make(*args, **kwargs)
        gripper = env.robots[0].gripper
        gripper = gripper["right"] if isinstance(gripper, dict) else gripper
        seen.append((env.robots[0].name, type(gripper).__name__, len(env.robots[0].arm_joint_indexes)))
        return env

    monkeypatch.setattr(compose, "_make", spy)
    return seen


def test_a_tower_recorded_on_the_ur5e_stands_on_the_panda(cli, ur5e_library, built):
    code, out, err = cli("plan", ur5e_library, "--scene", "robosuite:Stack3", "--simulate", "--seed", "101",
                         "--goal", TOWER, "--robot", "PANDA", "--json")
    assert code == 0, err
    doc = json.loads(out)
    # robosuite built the Panda with its own hand (seven joints), not the UR5e the library was recorded on
    assert built == [("Panda", "PandaGripper", 7)]
    assert doc["robot"] == "Panda" and doc["recorded_on"] == ["UR5e"]
    assert doc["notes"] == ["library recorded on UR5e; driven on Panda", UR5E_TO_PANDA]
    row = doc["per_episode"][0]
    assert row["plan"] == ["(pick cubeA)", "(place cubeA cubeB)", "(pick cubeC)", "(place cubeC cubeA)"]
    # robosuite's own check: C on A on B, standing, let go
    assert doc["successes"] == 1 and row["success"] and all(step["ok"] for step in row["steps"])
    assert {"(on cubeC cubeA)", "(on cubeA cubeB)", "(handempty)"} <= set(row["facts"]["end"])


def test_the_experiment_records_on_one_arm_and_runs_on_another(cli, built):
    code, out, err = cli("experiment", "stack3", "--episodes", "1", "--demos", "1", "--seed", "900",
                         "--record-robot", "panda", "--robot", "ur5e", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert [b[0] for b in built] == ["UR5e"] and built[0][2] == 6
    # the arm that recorded is read from the recording, not from the option
    assert doc["robot"] == "UR5e" and doc["recorded_on"] == ["Panda"]
    assert doc["notes"][0] == "library recorded on Panda; driven on UR5e"
    assert doc["notes"][1].startswith("pose_of: poses of the panda_hand's grip site (recorded on Panda) "
                                      "taken as UR5e's grip site (robotiq_2f85:grip_site)")
    assert doc["episodes"] == 1 and len(doc["per_episode"]) == 1


@pytest.mark.parametrize(("args", "message"), [
    (["--robot", "Kuka"], r"^robot: expected one of robosuite's single arms \['UR5e', 'Panda', "),
    (["--robot", "arm.urdf"], r"^robot: with a robosuite scene --robot names robosuite's arm .* not a "
                              r"description file \('arm\.urdf'\)"),
    (["--robot", "panda", "--tool-frame", "tool0"], r"^--tool-frame: a robosuite scene runs robosuite's arm"),
    (["--branch", "elbow-up"], r"^--branch: a robosuite scene runs robosuite's arm"),
    # robosuite 1.5.2's own XArm7 gripper names pad geoms its model lacks: refused as robosuite builds it
    (["--robot", "xarm7"], r"^robot: robosuite's XArm7 comes with a gripper \(XArm7Gripper\) whose finger "
                           r"pads name geoms its model lacks \(gripper0_right_finger1_pad_collision, "),
])
def test_plan_on_a_robosuite_scene_refuses_what_is_no_robosuite_arm(cli, ur5e_library, built, args, message):
    code, out, err = cli("plan", ur5e_library, "--scene", "robosuite:Stack3", "--simulate", *args)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert re.search(message, err.strip().split(": error: ", 1)[1]), err
    assert built == []  # refused before robosuite built anything


def test_a_description_file_with_a_robosuite_scene_is_refused(cli, ur5e_library, tmp_path):
    urdf = tmp_path / "arm"  # a file by its existence, whatever its name
    urdf.write_text("<robot name='arm'/>")
    code, out, err = cli("plan", ur5e_library, "--scene", "robosuite:Stack3", "--simulate", "--robot", urdf)
    assert code == 2 and out == "" and "not a description file" in err


@pytest.mark.parametrize(("args", "message"), [
    (["--robot", "kuka"], "robot: expected one of robosuite's single arms"),
    (["--record-robot", "KUKA"], "record_robot: expected one of robosuite's single arms"),
])
def test_the_experiment_refuses_an_arm_before_recording(cli, args, message):
    code, out, err = cli("experiment", "stack3", "--episodes", "1", *args)
    assert code == 2 and out == "" and message in err and len(err.strip().splitlines()) == 1


@pytest.fixture(scope="module")
def unknown_point(ur5e_library, tmp_path_factory):
    """The UR5e library's demonstrations without ``pose_of`` (they still say their arm), described."""
    db = tmp_path_factory.mktemp("unknown_point") / "bare.db"
    with Library(ur5e_library, readonly=True) as lib:
        demos = [lib.demonstration(d) for d in lib.demonstration_ids()]
    for demo in demos:
        del demo.metadata["pose_of"]
        assert demo.metadata["arm"] == "UR5e"
    with Library(db) as new:
        new.add_many(demos, assign="recluster")
        _label_one_each(new)
    return db


UNKNOWN = (r"^pose_of: demonstration \d+ was recorded on UR5e and its poses are of an unknown point of the "
           r"robot; Panda, which runs it, needs its grip site's: say which point .* with --pose-of")


def test_an_unknown_point_on_another_arm_is_the_same_error_everywhere(cli, unknown_point, built):
    with pytest.raises(ValueError, match=UNKNOWN):
        execute_plan(unknown_point, "robosuite:Stack3", robot="panda")
    with pytest.raises(ValueError, match=UNKNOWN):
        evaluate(unknown_point, "robosuite:Stack", episodes=1, robot="Panda")
    code, out, err = cli("plan", unknown_point, "--scene", "robosuite:Stack3", "--simulate", "--robot",
                         "panda")
    assert code == 2 and out == "" and "was recorded on UR5e and its poses are of an unknown point" in err
    assert built == []
    # on the arm that recorded it the unknown point is robosuite's own: accepted, without a note
    with Library(unknown_point, readonly=True) as lib:
        sources = _sources(lib.store)
    assert running_arm(sources, "UR5e") == {"robot": "UR5e", "recorded_on": ["UR5e"], "notes": []}


def test_which_points_an_arm_takes():
    def src(robot, pose_of):
        return SimpleNamespace(id=4, robot=robot, pose_of=pose_of)

    # each arm's own grip site: nothing to say
    assert pose_points([src("UR5e", "robotiq_2f85:grip_site")], "UR5e") == []
    assert pose_points([src(None, "panda_hand:grip_site")], "Panda") == []
    assert pose_points([src("Sawyer", "0,0,0.12")], "Sawyer") == []
    # another arm's grip site, named or as robosuite reports it: taken as this arm's, one note per kind
    assert pose_points([src("UR5e", "robotiq_2f85:grip_site")] * 2, "Panda") == [UR5E_TO_PANDA]
    assert pose_points([src("Sawyer", "0,0,0.12")], "Jaco") == [
        "pose_of: poses of Sawyer's grip site as robosuite reports it (0,0,0.12,0,0,0,1) taken as Jaco's "
        "grip site: where the hand holds is kept, not its flange"]
    # never a guess: no grip site, or an offset of an arm nobody named
    with pytest.raises(ValueError, match=r"^pose_of: demonstration 4's poses are of the flange; robosuite "
                                         r"drives Panda by its gripper's grip site, which a flange is not"):
        pose_points([src("UR5e", "flange")], "Panda")
    with pytest.raises(ValueError, match=r"which a tcp is not"):
        pose_points([src("UR5e", "robotiq_2f85:tcp")], "UR5e")
    with pytest.raises(ValueError, match=r"^pose_of: demonstration 4's poses are of the offset "
                                         r"0,0,0.12,0,0,0,1 of an arm it does not name"):
        pose_points([src(None, "0,0,0.12")], "UR5e")


def test_the_experiment_text_says_both_arms(cli, monkeypatch):
    """The command line hands both arms to the experiment as given and prints what its report says."""
    import skillbank.experiments as experiments

    asked = {}
    report = {"experiment": "unload", "scene": "robosuite:PickPlace", "robot": "Panda",
              "recorded_on": ["Sawyer"], "notes": ["library recorded on Sawyer; driven on Panda"],
              "method": "lte", "seed": 0, "demos": 1, "episodes": 1, "successes": 0, "success_rate": 0.0,
              "interval": [0.0, 0.8],
              "failures": {"not held": 1}, "labelled": {"pick": 1, "place": 2},
              "library": {"demonstrations": 4, "primitives": 16, "skills": 3},
              "per_episode": [{"seed": 1000, "plan": ["(pick Milk)"], "success": False,
                               "failure": {"step": 1, "reason": "not held"}}]}

    def experiment(name, **options):
        asked.update(options)
        return report

    monkeypatch.setattr(experiments, "composition_experiment", experiment)
    code, out, err = cli("experiment", "unload", "--episodes", "1", "--robot", "PANDA", "--record-robot",
                         "sawyer")
    assert code == 0, err
    assert asked["robot"] == "PANDA" and asked["record_robot"] == "sawyer"  # spelled by the experiment
    lines = out.splitlines()
    assert "robosuite:PickPlace (lte, on Panda): 0/1 = 0 % [0.0, 80.0] (Wilson 95 %)" in lines
    assert "  note: library recorded on Sawyer; driven on Panda" in lines
