"""Plans safe for the whole robot, checked in physics (issue 24): the UR5e's links and gripper against a
wall and the table, a repair that keeps them clear, and ``plan --simulate`` reporting what MuJoCo saw."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("mujoco")  # the extra skillbank[sim]

from skillbank.io import read_npz  # noqa: E402
from skillbank.planning import (  # noqa: E402
    _chain,  # noqa: E402
    arm_clearance,
    plan_task,
    scene_from_dict,
)
from skillbank.robots import robot_model  # noqa: E402
from skillbank.simulation import PRESS_FORCE, simulate  # noqa: E402

from .conftest import write_scene  # noqa: E402

DOWN = [0.0, 1.0, 0.0, 0.0]
#: Two buttons on a table in front of the UR5e, a wall between them reaching 25 cm up from the table.
WALL = "box:-0.6,-0.02,0.0,-0.3,0.02,0.25"


def wall_scene(**extra) -> dict:
    doc = {"objects": {"b1": {"type": "button", "position": [-0.45, -0.2, 0.03], "orientation": DOWN},
                       "b2": {"type": "button", "position": [-0.45, 0.2, 0.03], "orientation": DOWN}},
           "obstacles": {"wall": WALL}, "table": {"height": 0.0},
           "init": ["(free b1)", "(free b2)"], "goal": ["(pressed b2)"],
           "start": {"position": [-0.45, -0.2, 0.08], "orientation": DOWN}}
    doc.update(extra)
    return doc


@pytest.fixture(scope="module")
def around_the_wall(button_library):
    scene = scene_from_dict(wall_scene())
    return scene, plan_task(button_library.store, scene, robot="ur5e")


def test_a_plan_past_the_wall_keeps_every_link_clear_and_the_physics_agrees(around_the_wall):
    scene, res = around_the_wall
    model = robot_model("ur5e")
    check = arm_clearance(model, scene, list(scene.obstacles), res.trajectory["joints"], res.trajectory.t)
    # every body (links, gripper), every sample, against the wall, the table and itself
    assert check.min_distance >= _chain.CLEARANCE - 1e-9
    assert res.clearance == pytest.approx(check.min_distance) and not res.collision
    step = res.steps[0]
    assert step.clearance["min_distance"] >= _chain.CLEARANCE - 1e-9 and step.clearance["body"]
    # the press pushes the button in by PRESS_DEPTH of its travel, along the tool's z (down here)
    np.testing.assert_allclose(res.trajectory["position"][-1], [-0.45, 0.2, 0.03 - 0.004], atol=1e-6)
    sim = simulate(res.trajectory, scene, targets=res.targets())
    assert sim.facts == {"(pressed b2)": True}
    assert sim.contacts == []  # nothing touched the wall, the table or b1
    assert sim.buttons["b2"]["pressed"] and not sim.buttons["b1"]["pressed"]


def test_the_fingers_would_touch_the_wall_without_the_repair(button_library, monkeypatch):
    """The tool point alone clears the wall; the gripper around it does not, and that is what is named."""
    monkeypatch.setattr(_chain, "MAX_REPAIRS", 0)
    monkeypatch.setattr(_chain, "MAX_VIA_POINTS", 0)
    with pytest.raises(ValueError, match=r"^step 1 \(press b2\): the robot's finger_(left|right) comes "
                                         r"within [\d.]+ mm of obstacle wall \(box:-0.6,-0.02,0.0,-0.3,0.02,"
                                         r"0.25\) at t = [\d.]+ s \(clearance margin 5 mm; --clearance "
                                         r"sets it\)$"):
        # without the motion planner (issue 43), which would plan the move instead
        plan_task(button_library.store, scene_from_dict(wall_scene()), robot="ur5e", planner="none")


def test_the_repair_is_said(around_the_wall):
    _, res = around_the_wall
    assert any("kept the whole robot clear by keeping the tool further from wall" in n for n in res.notes)


def test_a_start_inside_an_obstacle_is_refused(button_library):
    # a ball round the start tool point's gripper
    doc = wall_scene(obstacles={"wall": WALL, "ball": "sphere:-0.45,-0.2,0.16,0.04"})
    # the start is a pose: no branch's gripper is clear of the ball (issue 41), and every branch says why
    with pytest.raises(ValueError, match=r"^start: robot ur5e has no configuration at the start pose .*: its "
                                         r"gripper_body [\d.]+ mm into obstacle ball \(sphere:"):
        plan_task(button_library.store, scene_from_dict(doc), robot="ur5e")


def test_plan_simulate_json_reports_clearance_and_the_simulation_side_by_side(cli, button_library, tmp_path):
    scene = write_scene(tmp_path, wall_scene())
    code, out, err = cli("plan", str(button_library.path), "--scene", str(scene), "--robot", "ur5e",
                         "--simulate", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["agree"] is True and doc["facts"] == {"(pressed b2)": {"planned": True, "achieved": True}}
    assert doc["clearance"] >= 0.005 and doc["steps"][0]["clearance"]["min_distance"] >= 0.005
    sim = doc["simulation"]
    assert set(sim) >= {"duration", "real_time_factor", "tracking", "contacts", "buttons", "objects", "facts"}
    assert sim["contacts"] == [] and sim["tracking"]["tool_max"] < 0.005


def test_a_crate_left_over_the_button_is_an_object_the_whole_robot_check_sees(cli, button_library, tmp_path):
    """Objects with a shape are solid for the robot's bodies unless the step acts on them: the press
    under the crate is refused naming the crate, the body and the time, in one line, exit 2."""
    doc = wall_scene()
    doc["objects"]["crate"] = {"type": "crate", "shape": "box", "size": [0.06, 0.06, 0.06], "mass": 0.3,
                               "position": [-0.45, 0.2, 0.1]}
    scene = write_scene(tmp_path, doc)
    code, out, err = cli("plan", str(button_library.path), "--scene", str(scene), "--robot", "ur5e",
                         "--simulate")
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert __import__("re").search(r"step 1 \(press b2\): the robot's finger_(left|right) comes "
                                   r"within [\d.]+ mm of object crate \(a box the step does not act on\) "
                                   r"at t = ", err)


def test_the_object_the_robot_starts_on_may_be_left(button_library):
    """The start rests on b1 (the step presses b2): the first step may leave it, and says so."""
    doc = wall_scene(start={"position": [-0.45, -0.2, 0.03], "orientation": DOWN})
    res = plan_task(button_library.store, scene_from_dict(doc), robot="ur5e")
    assert res.steps[0].touches == ["b1"] and res.targets()[0][2] == ["b2", "b1"]


@pytest.mark.parametrize(("extra", "match"), [
    ((), r"^skillbank plan: error: simulate: a simulation replays the plan's joints: give --robot too"),
    (("--robot", "ur5e", "--clearance", "-1"), r"^skillbank plan: error: clearance: expected a number >= 0"),
])
def test_bad_simulate_and_clearance_options_are_one_line(cli, button_library, tmp_path, extra, match):
    scene = write_scene(tmp_path, wall_scene())
    code, out, err = cli("plan", str(button_library.path), "--scene", str(scene), "--simulate", *extra)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert __import__("re").match(match, err)


#: A post beside the wrist halfway along the wall plan, 0.1 m from the tool point's path (found by
#: benchmarks/bench_whole_arm_repair.py, seed 0, case 1): growing it for the tool path cannot clear it.
WRIST_POST = "sphere:-0.62933,0.12237,0.51591,0.03715"


def test_a_link_that_growing_cannot_clear_is_repaired_with_via_points(button_library, monkeypatch):
    # on the recorded branch, where the post stands by the wrist (free to choose, the start would take a
    # branch whose path passes the post: issue 41)
    scene = scene_from_dict(wall_scene(obstacles={"wall": WALL, "post": WRIST_POST},
                                       branch="shoulder-left/elbow-up/wrist-up"))
    res = plan_task(button_library.store, scene, robot="ur5e")
    vias = [n for n in res.notes if "repair: via point at phase" in n]
    assert vias and all("off post" in n for n in vias)
    assert any("keeping the tool further from wall" in n for n in res.notes)  # the wall's growth stays
    model = robot_model("ur5e")
    check = arm_clearance(model, scene, list(scene.obstacles), res.trajectory["joints"], res.trajectory.t)
    assert check.min_distance >= _chain.CLEARANCE - 1e-9
    np.testing.assert_allclose(res.trajectory["position"][-1], [-0.45, 0.2, 0.03 - 0.004], atol=1e-6)
    sim = simulate(res.trajectory, scene, targets=res.targets())
    assert sim.facts == {"(pressed b2)": True} and sim.contacts == []
    # without the via points (the repair before): refused, naming what growing the post did
    monkeypatch.setattr(_chain, "clearing_move", lambda *a, **k: None)
    with pytest.raises(ValueError, match=r"^step 1 \(press b2\): .*growing wall by [\d.]+ mm, post by "
                                         r"[\d.]+ mm for the tool path\); via points in the primitive did "
                                         r"not clear it either: .*\(moving the tool cannot clear it\)$"):
        plan_task(button_library.store, scene, robot="ur5e", planner="none")


def test_plan_on_the_panda_keeps_its_links_clear_of_the_wall(cli, button_library, tmp_path):
    """`skillbank plan --robot panda`: the same task on a 7-joint arm read from its description, its
    joints checked against the wall and the table link by link (issue 28). The base is turned to face the
    buttons (they lie on its -x side)."""
    scene = write_scene(tmp_path, wall_scene())
    out = tmp_path / "plan.npz"
    code, text, err = cli("plan", str(button_library.path), "--scene", str(scene), "--robot", "panda",
                          "--robot-base", "0,0,0,0,0,1,0", "--out", out, "--json")
    assert code == 0, err
    doc = json.loads(text)
    assert doc["joint_names"] == [f"joint{i}" for i in range(1, 8)]
    assert doc["collision"] is False and doc["clearance"] >= _chain.CLEARANCE - 1e-9
    back = read_npz(out)
    turned = np.diag([-1.0, -1.0, 1.0, 1.0])  # the quaternion (0, 0, 1, 0): half a turn about z
    model = robot_model("panda", base=turned)
    sc = scene_from_dict(wall_scene())
    check = arm_clearance(model, sc, list(sc.obstacles), back["joints"], back.t)
    assert check.min_distance == pytest.approx(doc["clearance"], abs=1e-6)
    p, _ = model.fk(back["joints"])
    assert np.linalg.norm(p - back["position"], axis=1).max() < 2e-6
    np.testing.assert_allclose(back["position"][-1], [-0.45, 0.2, 0.03 - 0.004], atol=1e-6)


def test_plan_simulate_on_the_panda_presses_the_button_with_its_hand(cli, button_library, tmp_path):
    """`plan --robot panda --simulate`: the Franka hand is checked and simulated, and its fingers press b2.

    The Panda's default tool point is robosuite's grip site, 9 mm above the fingertips (its recordings
    report that point): the plan takes the grip site 4 mm into the button, one travel, so the fingertips
    would go 9 mm past the bottomed cap. The servos push the arm against it: pressed, hard, the arm held
    millimetres short of its command (docs/robots.md, "The Panda's hand").
    """
    scene = write_scene(tmp_path, wall_scene())
    code, text, err = cli("plan", str(button_library.path), "--scene", str(scene), "--robot", "panda",
                          "--robot-base", "0,0,0,0,0,1,0", "--simulate", "--json")
    assert code == 0, err
    doc = json.loads(text)
    assert doc["collision"] is False and doc["clearance"] >= _chain.CLEARANCE - 1e-9
    sim = doc["simulation"]
    assert doc["facts"] == {"(pressed b2)": {"planned": True, "achieved": True}}, sim
    assert sim["buttons"]["b2"]["pressed"] and not sim["buttons"]["b1"]["pressed"]
    assert sim["contacts"] == []  # the hand touched neither the wall, the table nor b1
    assert sim["buttons"]["b2"]["peak_force"] > 5 * PRESS_FORCE and sim["tracking"]["tool_max"] > 2e-3


def test_the_panda_planned_for_its_fingertips_presses_gently(button_library):
    """With the hand's TCP as the tool point the fingertips go one travel in: a button's force, tracked."""
    scene = scene_from_dict(wall_scene())
    model = robot_model("panda", base=np.diag([-1.0, -1.0, 1.0, 1.0]), tool="tcp")
    res = plan_task(button_library.store, scene, robot=model)
    assert res.clearance >= _chain.CLEARANCE - 1e-9
    sim = simulate(res.trajectory, scene, robot=model, targets=res.targets())
    assert sim.facts == {"(pressed b2)": True} and sim.contacts == []
    # timed by the time law at the Panda's own limits (up to 20 rad/s^2): 4.94 s where the uniform stretch
    # took 9.16 s, and its servos track the tool within 1.07 mm (0.60 mm at the stretch's pace)
    assert sim.buttons["b2"]["peak_force"] < 2 * PRESS_FORCE and sim.tool_max < 1.5e-3


def test_plan_simulate_on_the_panda_for_its_fingertips_from_the_command_line(cli, button_library, tmp_path):
    """`plan --robot panda --tool tcp --simulate`: planned for where the fingertips meet, b2 takes a button's
    force and the tool is tracked, as the API's ``tool="tcp"`` does; the written joints' FK is the TCP."""
    scene = write_scene(tmp_path, wall_scene())
    out = tmp_path / "press.npz"
    code, text, err = cli("plan", str(button_library.path), "--scene", str(scene), "--robot", "panda",
                          "--robot-base", "0,0,0,0,0,1,0", "--tool", "tcp", "--simulate", "--out", str(out),
                          "--json")
    assert code == 0, err
    sim = json.loads(text)["simulation"]
    assert sim["buttons"]["b2"]["pressed"] and not sim["buttons"]["b1"]["pressed"] and sim["contacts"] == []
    # within 1.07 mm at the time law's pace (the test above)
    assert sim["buttons"]["b2"]["peak_force"] < 2 * PRESS_FORCE and sim["tracking"]["tool_max"] < 1.5e-3
    back = read_npz(out)
    model = robot_model("panda", base=np.diag([-1.0, -1.0, 1.0, 1.0]), tool="tcp")
    p, _ = model.fk(back["joints"])
    assert np.linalg.norm(p - back["position"], axis=1).max() < 2e-6
