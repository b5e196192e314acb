"""A start the arm can take (issue 41, item 2): a scene's start given as a tool position alone takes the
inverse-kinematics branch (or seed) nearest the recorded joints that is clear of the robot itself and of
the scene; with none clear, one line names every branch tried and why."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("mujoco")  # the extra skillbank[sim]: the plan is simulated, and the Panda is read

from skillbank.planning import CLEARANCE, arm_clearance, scene_from_dict  # noqa: E402
from skillbank.planning._start import clear_starts  # noqa: E402
from skillbank.robots import robot_model  # noqa: E402
from skillbank.robots._base import wrap_angle  # noqa: E402

from .conftest import write_scene  # noqa: E402

DOWN = [0.0, 1.0, 0.0, 0.0]
#: The TCP of the UR5e's 2F-85 beyond its flange (m): a scene for the flange is the same scene raised by it.
TCP = 0.163


def three_buttons(lift=0.0, start=(-0.45, 0.0, 0.3)) -> dict:
    """Three buttons in a row on a table in front of the UR5e, the tool down; the start a position alone.

    Before issue 41 the start took the recorded presses' branch (shoulder-left/elbow-up/wrist-up) at
    this pose, whose forearm lies in its own wrist: ``the robot starts inside its own wrist_3
    (self-collision): its forearm is 16 mm deep at the start``.
    """
    names = ["b1", "b2", "b3"]
    return {"objects": {n: {"type": "button", "position": [-0.45, y, 0.03 + lift], "orientation": DOWN}
                        for n, y in zip(names, (-0.2, 0.0, 0.2), strict=True)},
            "table": {"height": 0.0},
            "init": [f"(free {n})" for n in names], "goal": [f"(pressed {n})" for n in names],
            "start": {"position": [start[0], start[1], start[2] + lift]}}


def _start_is_clear(doc, joints, tool=None) -> float:
    """The whole robot's clearance at the plan's first configuration (obstacles, table, itself)."""
    scene = scene_from_dict(doc)
    model = robot_model("ur5e", tool=tool)
    return arm_clearance(model, scene, list(scene.obstacles), np.asarray(joints)[:1]).min_distance


def test_a_plan_whose_start_is_a_position_alone_starts_clear_and_presses_every_button(cli, button_library,
                                                                                   tmp_path):
    doc = three_buttons()
    scene = write_scene(tmp_path, doc)
    code, out, err = cli("plan", str(button_library.path), "--scene", str(scene), "--robot", "UR5e",
                         "--simulate", "--json")
    assert code == 0, err
    res = json.loads(out)
    assert res["robot"] == res["simulation"]["robot"] == "ur5e"  # the arm it drove (issue 41, item 6)
    J = np.asarray(res["streams"]["joints"])
    assert _start_is_clear(doc, J) >= CLEARANCE
    np.testing.assert_allclose(robot_model("ur5e").fk(J[0])[0], doc["start"]["position"], atol=1e-9)
    assert res["collision"] is False and res["clearance"] >= CLEARANCE
    assert [a["args"] for a in res["plan"]] == [["b1"], ["b2"], ["b3"]]
    assert res["agree"] is True
    assert res["facts"] == {f"(pressed b{k})": {"planned": True, "achieved": True} for k in (1, 2, 3)}
    assert res["simulation"]["contacts"] == []


def test_a_start_at_the_flange_takes_a_clear_branch_too(cli, button_library, tmp_path):
    doc = three_buttons(lift=TCP)
    scene = write_scene(tmp_path, doc)
    code, out, err = cli("plan", str(button_library.path), "--scene", str(scene), "--robot", "ur5e",
                         "--tool", "flange", "--json")
    assert code == 0, err
    res = json.loads(out)
    J = np.asarray(res["streams"]["joints"])
    assert _start_is_clear(doc, J, tool="flange") >= CLEARANCE
    assert res["collision"] is False and res["clearance"] >= CLEARANCE and len(res["plan"]) == 3


def test_the_recorded_branch_is_kept_where_it_is_clear(button_library):
    """Nearest the recorded joints first: where the recorded presses' branch is clear it is the start's."""
    from skillbank.planning import plan_task

    doc = three_buttons(start=(-0.45, -0.2, 0.1))
    res = plan_task(button_library.store, scene_from_dict(doc), robot="ur5e")
    model = robot_model("ur5e")
    assert model.branch_names[int(model.branch_of(res.trajectory["joints"][:1])[0])] == \
        "shoulder-left/elbow-up/wrist-up"


def test_a_start_no_branch_can_take_is_one_line_naming_every_branch(cli, button_library, tmp_path):
    """The flange 10 cm over the table: the gripper below it is in the table on every branch."""
    doc = three_buttons(lift=TCP)
    doc["start"]["position"][2] = 0.1
    scene = write_scene(tmp_path, doc)
    code, out, err = cli("plan", str(button_library.path), "--scene", str(scene), "--robot", "ur5e",
                         "--tool", "flange")
    assert code == 2 and len(err.strip().splitlines()) == 1 and out == ""
    assert "skillbank plan: error: start: robot ur5e has no configuration at the start pose (tool point " \
           "[-0.45, 0.0, 0.1]) clear of itself and of the scene (clearance margin 5 mm; --clearance sets " \
           "it); every branch tried: shoulder-left/elbow-up/wrist-up: its " in err
    model = robot_model("ur5e")
    for name in model.branch_names:
        assert f"{name}: its " in err
    assert "into the table (top at z = 0 m)" in err
    assert err.strip().endswith("move the start, or give it as joints (start.joints)")


def test_unreachable_branches_are_named_as_such():
    """A pose near the edge of the workspace, where the wrist-up branches cannot reach it, and a margin
    no configuration keeps: each branch says which of the two it failed on."""
    model = robot_model("ur5e")
    q = np.array([0.3, -0.4, 0.15, -1.0, -1.2, 0.4])  # nearly stretched
    p, r = model.fk(q)
    sols = model.ik_all(p, r)
    assert np.isnan(sols).any() and not np.isnan(sols).all()
    scene = scene_from_dict(three_buttons())
    with pytest.raises(ValueError, match=r"^start: robot ur5e has no configuration .* \(clearance margin "
                                         r"1000 mm; .*every branch tried: ") as info:
        clear_starts(model, scene, p, r, reference=q, margin=1.0, label=str)
    message = str(info.value)
    for b, name in enumerate(model.branch_names):
        why = "unreachable" if np.isnan(sols[b]).any() else "its "
        assert f"{name}: {why}" in message


def test_a_numerical_arm_tries_seeds_and_keeps_the_clear_solutions():
    """The Panda (numerical IK, one "branch"): a ball beside the elbow of the solution from home leaves the
    solutions from other seeds, the elbow turned away; each kept one is clear, and none is home's."""
    model = robot_model("panda")
    p, r = model.fk(model.home)
    doc = three_buttons()
    doc.pop("table")
    doc["obstacles"] = {"ball": "sphere:0.043,0.1,0.627,0.02"}  # 11 mm into the elbow of home's solution
    scene = scene_from_dict(doc)
    assert arm_clearance(model, scene, ["ball"], np.asarray(model.home)[None]).min_distance < 0
    starts = clear_starts(model, scene, p, r, names=["ball"], margin=CLEARANCE, label=str)
    assert starts
    for q0 in starts:
        assert np.abs(wrap_angle(q0 - np.asarray(model.home))).max() > 0.1
        np.testing.assert_allclose(model.fk(q0)[0], p, atol=1e-5)
        assert arm_clearance(model, scene, ["ball"], q0[None]).min_distance >= CLEARANCE
    # a ball round the whole wrist: the line names each seed and why
    doc["obstacles"]["ball"] = "sphere:0.35,0,0.3,0.2"
    with pytest.raises(ValueError, match=r"^start: robot panda has no configuration .* every seed tried: "
                                         r"seed home: its \w+ [\d.]+ mm into ball; seed 1: "):
        clear_starts(model, scene_from_dict(doc), p, r, names=["ball"], margin=CLEARANCE, label=str)


def test_plan_simulate_says_which_arm_it_drove(cli, button_library, tmp_path):
    """Issue 41, item 6: the text names the arm, and --robot is taken in any case."""
    scene = write_scene(tmp_path, three_buttons())
    code, out, err = cli("plan", str(button_library.path), "--scene", str(scene), "--robot", "Ur5E",
                         "--simulate")
    assert code == 0, err
    assert any(line.startswith("  simulated ") and " s on ur5e at " in line for line in out.splitlines())
