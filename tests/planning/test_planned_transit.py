"""Planned transits (issue 43, item 1): a wall or a shelf the press skill cannot get past is planned over by
OMPL in joint space, every link, the gripper and the scene checked; ``--planner none`` refuses as before."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("ompl")  # the extra skillbank[plan]

from skillbank.planning import _chain, arm_clearance, plan_task, scene_from_dict  # noqa: E402
from skillbank.robots import robot_model  # noqa: E402

from .conftest import write_scene  # noqa: E402

DOWN = [0.0, 1.0, 0.0, 0.0]
#: A 40 cm wall between two buttons 60 cm apart on a table in front of the UR5e.
WALL = "box:-0.6,-0.02,0.0,-0.3,0.02,0.4"
#: A 30 cm wall with a shelf over it, 8 cm above its top.
SHELF = {"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.3", "shelf": "box:-0.75,-0.12,0.38,-0.35,0.12,0.41"}
NO_END = (r"^step 1 \(press b2\): .*; the motion planner found no clear move either \(the motion planner has "
          r"no end for the transit: robot ur5e has no configuration at the end of the transit \(tool point "
          r"\[-0.45, 0.3, 0.076\]\) clear of itself and of the scene .*hood.*\)$")
REFUSED = r"^step 1 \(press b2\): cannot keep the robot clear of (wall|shelf): "


def scene_doc(obstacles, **extra) -> dict:
    doc = {"objects": {"b1": {"type": "button", "position": [-0.45, -0.3, 0.03], "orientation": DOWN},
                       "b2": {"type": "button", "position": [-0.45, 0.3, 0.03], "orientation": DOWN}},
           "obstacles": obstacles, "table": {"height": 0.0},
           "init": ["(free b1)", "(free b2)"], "goal": ["(pressed b2)"],
           "start": {"position": [-0.45, -0.3, 0.08], "orientation": DOWN}}
    doc.update(extra)
    return doc


@pytest.fixture(scope="module")
def over_the_wall(button_library):
    scene = scene_from_dict(scene_doc({"wall": WALL}))
    return scene, plan_task(button_library.store, scene, robot="ur5e", random_state=0)


def test_the_wall_is_planned_over_with_every_link_clear(over_the_wall):
    scene, res = over_the_wall
    model = robot_model("ur5e")
    traj = res.trajectory
    check = arm_clearance(model, scene, list(scene.obstacles), traj["joints"], traj.t, objects=["b1"])
    assert check.min_distance >= _chain.CLEARANCE - 1e-9 and not res.collision
    step = res.steps[0]
    assert [s["kind"] for s in step.segments] == ["transit", "approach"]
    assert any("the motion planner (OMPL RRTConnect) carried the move" in n for n in step.notes)
    # the press is a straight line down onto the button, and the joints follow the tool
    a, b = step.segments[1]["start"], step.segments[1]["stop"]
    P = traj["position"][a:b]
    np.testing.assert_allclose(P[:, :2], np.tile([-0.45, 0.3], (b - a, 1)), atol=1e-6)
    np.testing.assert_allclose(P[-1], [-0.45, 0.3, 0.03 - 0.004], atol=1e-6)
    p, _ = model.fk(traj["joints"])
    assert np.linalg.norm(p - traj["position"], axis=1).max() < 1e-5
    assert np.abs(np.diff(traj["joints"], axis=0)).max() < 0.05  # continuous


def test_without_the_planner_the_wall_is_refused_as_before(button_library):
    scene = scene_from_dict(scene_doc({"wall": WALL}))
    with pytest.raises(ValueError, match=REFUSED):
        plan_task(button_library.store, scene, robot="ur5e", planner="none")


def test_a_transit_through_the_wall_is_planned_instead(button_library):
    """With a scene transit height under the wall's top, the hand-written transit passes through it."""
    scene = scene_from_dict(scene_doc({"wall": WALL}, transit={"height": 0.3}))
    with pytest.raises(ValueError, match=r"^step 1 \(press b2\): its transit passes through obstacle wall "):
        plan_task(button_library.store, scene, robot="ur5e", planner="none")
    res = plan_task(button_library.store, scene, robot="ur5e", random_state=0)
    assert res.clearance >= _chain.CLEARANCE - 1e-9 and not res.collision
    assert any("its transit passes through obstacle wall" in n for n in res.notes)


def test_the_shelf_is_planned_past(button_library):
    scene = scene_from_dict(scene_doc(SHELF))
    with pytest.raises(ValueError, match=REFUSED):
        plan_task(button_library.store, scene, robot="ur5e", planner="none")
    res = plan_task(button_library.store, scene, robot="ur5e", random_state=0)
    model = robot_model("ur5e")
    check = arm_clearance(model, scene, list(scene.obstacles), res.trajectory["joints"], objects=["b1"])
    assert check.min_distance >= _chain.CLEARANCE - 1e-9 and not res.collision
    assert res.steps[0].segments[0]["kind"] == "transit"


@pytest.mark.parametrize("obstacles, y", [
    ({"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.32", "post": "sphere:-0.2,0.0,0.45,0.04"}, 0.3),
    ({"wall": WALL}, 0.25)], ids=["wall and post", "buttons 50 cm apart"])
def test_a_transit_that_turns_the_wrist_the_other_way_round(button_library, obstacles, y):
    """No clear configuration over b2 is on the start's branch: the transit changes branch, with the wrist
    turned the way that does not fold the gripper onto the forearm (a whole turn from the recorded one)."""
    doc = scene_doc(obstacles)
    for k, obj in (("b1", -y), ("b2", y)):
        doc["objects"][k]["position"][1] = obj
    doc["start"]["position"][1] = -y
    scene = scene_from_dict(doc)
    with pytest.raises(ValueError, match=r"^step 1 \(press b2\): cannot keep the robot clear of "):
        plan_task(button_library.store, scene, robot="ur5e", planner="none")
    res = plan_task(button_library.store, scene, robot="ur5e", random_state=0)
    model = robot_model("ur5e")
    check = arm_clearance(model, scene, list(scene.obstacles), res.trajectory["joints"], objects=["b1"])
    assert check.min_distance >= _chain.CLEARANCE - 1e-9 and not res.collision
    J = res.trajectory["joints"]
    assert model.branch_of(J[0])[0] != model.branch_of(J[-1])[0]


def test_the_same_seed_gives_the_same_plan(button_library, over_the_wall):
    scene, res = over_the_wall
    again = plan_task(button_library.store, scene, robot="ur5e", random_state=0)
    np.testing.assert_array_equal(again.trajectory["joints"], res.trajectory["joints"])


def test_a_goal_the_planner_cannot_reach_either_is_one_line(button_library):
    """A hood over b2, open below: the press cannot get in, and the planner has no clear end above it."""
    scene = scene_from_dict(scene_doc({"wall": WALL, "hood": "box:-0.52,0.23,0.06,-0.38,0.37,0.5"}))
    with pytest.raises(ValueError, match=NO_END):
        plan_task(button_library.store, scene, robot="ur5e", random_state=0, motion_time_limit=0.5)


def test_plan_cli_plans_over_the_wall_where_planner_none_refuses(cli, button_library, tmp_path):
    scene = write_scene(tmp_path, scene_doc({"wall": WALL}), name="wall.json")
    code, text, err = cli("plan", button_library.path, "--scene", scene, "--robot", "ur5e", "--seed", "0",
                          "--json")
    assert code == 0, err
    doc = json.loads(text)
    assert doc["collision"] is False and doc["clearance"] >= _chain.CLEARANCE - 1e-9
    assert [s["kind"] for s in doc["steps"][0]["segments"]] == ["transit", "approach"]
    code, text, err = cli("plan", button_library.path, "--scene", scene, "--robot", "ur5e", "--planner",
                          "none")
    assert code == 2 and text == ""
    assert err.startswith("skillbank plan: error: step 1 (press b2): cannot keep the robot clear of wall: ")
    assert len(err.strip().splitlines()) == 1


def test_the_planned_press_presses_the_button_in_physics(over_the_wall):
    pytest.importorskip("mujoco")  # the extra skillbank[sim]
    from skillbank.simulation import simulate

    scene, res = over_the_wall
    sim = simulate(res.trajectory, scene, targets=res.targets())
    assert sim.facts == {"(pressed b2)": True}
    assert sim.contacts == []  # nothing touched the wall, the table or b1
    assert sim.buttons["b2"]["pressed"] and not sim.buttons["b1"]["pressed"]
