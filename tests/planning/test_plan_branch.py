"""The inverse-kinematics branch of a plan: the scene's "branch" key and ``skillbank plan --branch``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from skillbank.planning import plan_task, scene_from_dict
from skillbank.robots import robot_model

from .conftest import button_scene, write_scene

Q = [0.0, 0.94, -0.33, 0.08]
BUTTONS = [[-0.3, -0.45, 0.12], [0.0, -0.6, 0.1], [0.25, -0.55, 0.11], [0.35, -0.4, 0.13]]


def _scene(**extra):
    doc = button_scene(BUTTONS, goal=["b4", "b2"], orientation=Q, start=[-0.356, -0.416, 0.176], **extra)
    doc["start"]["orientation"] = [0.038, 0.955, -0.283, 0.078]
    return doc


@pytest.mark.parametrize("branch", [1, 4])  # wrist down; shoulder right (the recorded presses: 0)
def test_the_scenes_branch_is_followed_through_every_step(button_library, branch):
    robot = robot_model("ur5e")
    name = robot.branch_names[branch]
    res = plan_task(button_library.store, scene_from_dict(_scene(branch=name)), robot="ur5e")
    J = res.trajectory["joints"]
    assert set(robot.branch_of(J).tolist()) == {branch}
    assert res.join_error["joints"] < 1e-9
    # the branch's names are the signs of the determinant's factors: the wrist's sin(theta5) R
    t2, t23, t234 = J[:, 1], J[:, 1] + J[:, 2], J[:, 1] + J[:, 2] + J[:, 3]
    R = -0.425 * np.cos(t2) - 0.3922 * np.cos(t23) + 0.0997 * np.sin(t234)
    assert set(np.sign(np.sin(J[:, 4]) * R) > 0) == {"wrist-down" in name}
    assert set(R > 0) == {"shoulder-left" in name}
    # the robot's own limits hold on every step
    v = np.diff(J, axis=0) / np.diff(res.trajectory.t)[:, None]
    assert np.abs(v).max() <= np.pi * (1 + 1e-9)


def test_plan_branch_on_the_command_line(button_library, tmp_path, cli):
    robot = robot_model("ur5e")
    db = button_library.store.path
    scene = write_scene(tmp_path, _scene(branch=robot.branch_names[1]))
    code, out, err = cli("plan", db, "--scene", scene, "--robot", "ur5e", "--branch", robot.branch_names[4],
                         "--json")
    assert code == 0, err
    J = np.array(json.loads(out)["streams"]["joints"])
    assert set(robot.branch_of(J).tolist()) == {4}  # the option over the scene's key
    code, out, err = cli("plan", db, "--scene", scene, "--robot", "ur5e", "--branch", "up", "--out",
                         tmp_path / "p.csv")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith("skillbank plan: error: branch: expected one of "
                          "['shoulder-left/elbow-up/wrist-up', 'shoulder-left/elbow-up/wrist-down', ")
    assert err.endswith("or an index below 8, got 'up'\n")
    code, out, err = cli("plan", db, "--scene", scene, "--max-joint-acceleration", "1", "--out",
                         tmp_path / "p.csv")
    assert code == 2 and "max-joint-acceleration: a joint acceleration limit needs joints" in err
    code, out, err = cli("plan", db, "--scene", scene, "--out", tmp_path / "p.csv")
    assert code == 2 and err == (f"skillbank plan: error: branch: the scene's branch "
                                 f"'{robot.branch_names[1]}' needs a robot (robot='ur5e', --robot ur5e)\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.json"]


def test_an_unknown_scene_branch_lists_the_names_before_the_first_step(button_library):
    with pytest.raises(ValueError, match=r"^branch: expected one of \['shoulder-left/elbow-up/wrist-up', .* "
                                         r"or an index below 8, got 'elbow-up'$"):
        plan_task(button_library.store, scene_from_dict(_scene(branch="elbow-up")), robot="ur5e")


@pytest.mark.parametrize("value", [3, "", ["a"]])
def test_a_scene_branch_is_a_name(value):
    with pytest.raises(ValueError, match=r"^branch: expected the name of an inverse-kinematics branch like "
                                         r"'shoulder-left/elbow-up/wrist-up', got "):
        scene_from_dict(_scene(branch=value))
