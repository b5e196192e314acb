"""Poses that say which point of the robot they are of, on the command line (issue 41, item 1).

The three-button recording's poses are the flange's (UR's tool0); the UR5e's tool is its 2F-85's TCP,
163 mm further. Reused with ``--robot ur5e`` they are converted before they are adapted, so a press
reused to a moved button presses it with the fingertips, in MuJoCo.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.core import quaternion_to_matrix
from skillbank.io import load, write_npz
from skillbank.robots import robot_model, to_tool


@pytest.fixture(scope="module")
def press_library(data_dir, tmp_path_factory):
    """The README's press library: the three-button file added, its three presses labelled."""
    from skillbank.cli import _main

    folder = tmp_path_factory.mktemp("press")
    db = folder / "lib.sqlite"
    path = data_dir / "seed" / "three_button_pressing_demo.h5"
    for argv in (["library", "init", db], ["library", "add", db, path],
                 *[["library", "label", db, "--primitive", i, "press"] for i in (2, 3, 4)]):
        assert _main.main([str(a) for a in argv]) == 0
    return {"db": db, "file": path, "folder": folder}


def test_library_list_says_what_point_the_poses_are_of(cli, press_library):
    code, out, err = cli("library", "list", press_library["db"])
    assert code == 0, err
    assert "poses of the flange: demonstration(s) 1" in out
    doc = json.loads(cli("library", "list", press_library["db"], "--json")[1])
    assert doc["demonstrations"] == [{"id": 1, "pose_of": "flange", "arm_index": None}]
    assert {p["pose_of"] for p in doc["primitives"]} == {"flange"}


def test_the_point_survives_export_and_import(cli, press_library, tmp_path):
    assert cli("library", "export", press_library["db"], tmp_path / "exp")[0] == 0
    copy = tmp_path / "copy.sqlite"
    code, _, err = cli("library", "import", copy, tmp_path / "exp")
    assert code == 0, err
    doc = json.loads(cli("library", "list", copy, "--json")[1])
    assert doc["demonstrations"][0]["pose_of"] == "flange"


def test_pose_of_where_the_file_does_not_say_and_a_contradiction(cli, press_library, tmp_path):
    robot = robot_model("ur5e")
    q = robot.home + np.linspace(0.0, 0.3, 40)[:, None]
    p, quat = robot.fk(q)
    npz = write_npz(Demonstration(np.linspace(0.0, 2.0, 40), {"position": p, "orientation": quat}),
                    tmp_path / "tcp.npz")
    db = tmp_path / "lib.sqlite"
    assert cli("library", "init", db)[0] == 0
    # no point stated: stored as unknown, shown so, and a robot refuses it naming the option
    assert cli("library", "add", db, npz, "--whole", "--label", "reach")[0] == 0
    assert "poses of an unknown point (library add --pose-of says which; a robot needs it)" in cli(
        "library", "list", db)[1]
    code, out, err = cli("library", "reuse", db, "--skill", "reach", "--method", "ja", "--goal",
                         ",".join(map(str, p[-1])), "--robot", "ur5e")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "poses are of an unknown point of the robot" in err and "--pose-of" in err
    # stated on the command line: stored and used (these are the TCP's poses: nothing to convert)
    db2 = tmp_path / "lib2.sqlite"
    assert cli("library", "init", db2)[0] == 0
    assert cli("library", "add", db2, npz, "--whole", "--label", "reach", "--pose-of", "robotiq_2f85")[0] == 0
    assert "poses of the robotiq_2f85:tcp: demonstration(s) 1" in cli("library", "list", db2)[1]
    code, out, err = cli("library", "reuse", db2, "--skill", "reach", "--method", "ja", "--goal",
                         ",".join(map(str, p[-1])), "--robot", "ur5e", "--json")
    assert code == 0, err
    J = np.array(json.loads(out)["streams"]["joints"])
    assert np.linalg.norm(robot.fk(J[-1])[0] - p[-1]) < 1e-6
    # a file that states its point, and an option that says another: one line, nothing added
    before = json.loads(cli("library", "list", press_library["db"], "--json")[1])
    code, out, err = cli("library", "add", press_library["db"], press_library["file"], "--pose-of",
                         "robotiq_2f85")
    assert code == 2 and err.count("\n") == 1
    assert "states its poses are of 'flange', and --pose-of / pose_of says 'robotiq_2f85:tcp'" in err
    assert json.loads(cli("library", "list", press_library["db"], "--json")[1]) == before
    # a malformed point fails before the file is read
    code, out, err = cli("library", "add", db2, npz, "--pose-of", "tcp")
    assert code == 2 and "'tcp' alone does not say whose" in err and err.count("\n") == 1


def test_edit_converts_a_files_flange_poses_to_the_tool(cli, data_dir, tmp_path):
    """``edit --robot ur5e`` of the recording: its goal is the TCP's, and FK of its joints meets it."""
    demo = to_tool(load(data_dir / "seed" / "three_button_pressing_demo.h5"), robot_model("ur5e"))[0]
    goal = demo["position"][1400]
    code, out, err = cli("edit", data_dir / "seed" / "three_button_pressing_demo.h5", "--goal",
                         ",".join(map(str, goal + [0.02, 0.0, 0.0])), "--robot", "ur5e",
                         "--duration", "30", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert "pose_of: poses of the flange converted to ur5e's tool robotiq_2f85:tcp (163 mm)" in doc["notes"]
    J = np.array(doc["streams"]["joints"])
    assert np.linalg.norm(robot_model("ur5e").fk(J[-1])[0] - (goal + [0.02, 0.0, 0.0])) < 1e-6


def test_the_readmes_press_reused_on_the_ur5e_presses_the_moved_button(cli, press_library, tmp_path):
    """The README's press (primitive 2), its button moved 5 cm: reused on the UR5e and simulated, the
    button is pressed and the fingertips end within 2 mm of the cap's centre line. Before the poses said
    which point they are of, the TCP followed the flange's path and stopped 163 mm short (2.5 N, never
    pressed)."""
    pytest.importorskip("mujoco")
    from skillbank import Library

    with Library(press_library["db"]) as lib:
        prim = next(p.demo for p in lib.primitives(label="press") if p.id == 2)
    tcp = to_tool(prim, robot_model("ur5e"))[0]
    q = tcp["orientation"][-1]
    axis = quaternion_to_matrix(q)[:, 2]           # the tool's z: the way the fingertips push
    goal = tcp["position"][-1] + [0.05, 0.0, 0.0]  # the recorded press's end, moved 5 cm
    travel = 0.004                                 # the default button's: the press ends at its bottom
    cap = goal - travel * axis                     # the cap's top face at rest, its axis the tool's
    scene = tmp_path / "moved.json"
    scene.write_text(json.dumps({"objects": {"b2": {"type": "button", "position": cap.tolist(),
                                                    "orientation": q.tolist()}}, "goal": ["(pressed b2)"]}))
    code, out, err = cli("library", "reuse", press_library["db"], "--skill", "press", "--method", "ja",
                         "--goal", ",".join(map(str, goal)), "--goal-orientation", ",".join(map(str, q)),
                         "--robot", "ur5e", "--scene", scene, "--simulate", "--json")
    assert code == 0, err
    doc = json.loads(out)
    sim = doc["simulation"]
    assert sim["buttons"]["b2"]["pressed"] is True and sim["facts"] == {"(pressed b2)": True}
    assert sim["contacts"] == []
    J = np.array(doc["streams"]["joints"])
    tips = robot_model("ur5e").fk(J)[0]
    off_axis = np.linalg.norm(np.cross(tips[-1] - cap, axis))
    assert off_axis < 0.002
    assert np.linalg.norm(tips[-1] - goal) < 1e-6
