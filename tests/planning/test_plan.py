"""Planning and chained reproduction: minimal plans, continuous joins, goals met, obstacles avoided."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.core import quaternion_angle
from skillbank.planning import plan_task, scene_from_dict, solve

from .conftest import DOWN, button_scene, press_motion

ORDERED = """(define (domain ordered) (:requirements :strips :typing) (:types button)
  (:predicates (ready ?b - button) (next ?a ?b - button) (pressed ?b - button))
  (:action press :parameters (?b ?n - button)
    :precondition (and (ready ?b) (next ?b ?n))
    :effect (and (pressed ?b) (ready ?n) (not (ready ?b)))))
"""
BUTTONS = [[0.2, 0.0, 0.0], [0.2, 0.2, 0.0], [0.0, 0.2, 0.0], [0.1, 0.1, 0.0]]


def _problem(init, goal):
    return (f"(define (problem p) (:domain ordered) (:objects b1 b2 b3 b4 - button) (:init {init}) "
            f"(:goal (and {goal})))")


def test_the_plan_is_the_shortest_and_follows_the_order_the_facts_impose():
    init = "(ready b3) (next b3 b1) (next b1 b4) (next b4 b2) (next b2 b2)"
    assert solve(ORDERED, _problem(init, "(pressed b4)")) == [
        ("press", ("b3", "b1")), ("press", ("b1", "b4")), ("press", ("b4", "b2"))]
    assert solve(ORDERED, _problem(init, "(pressed b3)")) == [("press", ("b3", "b1"))]


def test_an_unreachable_goal_names_the_facts_no_action_can_make_true():
    init = "(ready b3) (next b3 b1)"
    # pressing b3 readies b1, but nothing follows b1: b1, b2 and b4 can never be pressed
    with pytest.raises(ValueError, match=r"goal: no plan reaches \(pressed b1\), \(pressed b2\), "
                                         r"\(pressed b4\): no sequence"):
        solve(ORDERED, _problem(init, "(pressed b3) (pressed b1) (pressed b4) (pressed b2)"))


def test_facts_reachable_alone_but_not_together_are_reported_as_such():
    # pressing b1 readies b2 or b3, never both: each can be pressed, not both
    init = "(ready b1) (next b1 b2) (next b1 b3) (next b2 b4) (next b3 b4)"
    goal = "(pressed b2) (pressed b3)"
    with pytest.raises(ValueError, match=r"no plan reaches \(pressed b2\), \(pressed b3\) together"):
        solve(ORDERED, _problem(init, goal))


def _plan(lib, doc, **kw):
    return plan_task(lib.store, scene_from_dict(doc), **kw)


def test_pressing_four_buttons_chains_continuous_steps_that_end_on_each_button(described_library):
    doc = button_scene(BUTTONS, goal=["b1", "b2", "b3", "b4"])
    res = _plan(described_library, doc)
    assert len(res.plan) == 4 and sorted(a for _, (a,) in res.plan) == ["b1", "b2", "b3", "b4"]
    traj = res.trajectory
    P, Q = traj["position"], traj["orientation"]
    assert np.all(np.diff(traj.t) > 0) and traj.t[0] == 0.0
    scene = scene_from_dict(doc)
    for k, step in enumerate(res.steps):
        button = scene.objects[step.args[0]].position
        # each press ends on its button, pushed in by its travel along the tool (down here)
        np.testing.assert_allclose(step.goal, button - [0.0, 0.0, 0.004], atol=1e-12)
        assert np.linalg.norm(P[step.stop - 1] - step.goal) < 2e-3
        if k:
            assert step.start == res.steps[k - 1].stop - 1  # the join sample is shared
    assert res.join_error["position"] < 1e-12 and res.join_error["orientation"] < 1e-9
    assert float(quaternion_angle(Q, np.array(DOWN)).max()) < 1e-9
    assert np.linalg.norm(P[0] - [0.0, 0.0, 0.0]) < 1e-12
    # zero velocity at every join: the samples either side of it do not move
    for step in res.steps[:-1]:
        j = step.stop - 1
        assert np.linalg.norm(P[j] - P[j - 1]) < 1e-9 and np.linalg.norm(P[j + 1] - P[j]) < 1e-9
    assert traj["gripper"].ravel().tolist() == [1.0] * traj.n_steps


def test_an_obstacle_between_two_buttons_is_avoided(described_library):
    free = _plan(described_library, button_scene(BUTTONS[:2], goal=["b2"], start=BUTTONS[0]))
    mid = free.trajectory["position"][len(free.trajectory.t) // 2]
    spec = f"sphere:{mid[0]},{mid[1]},{mid[2]},0.02"  # right on the unobstructed path
    doc = button_scene(BUTTONS[:2], goal=["b2"], start=BUTTONS[0], obstacles=[spec])
    res = _plan(described_library, doc)
    assert not res.collision and not scene_from_dict(doc).constraints().collides(res.trajectory["position"])
    assert np.linalg.norm(res.trajectory["position"][-1] - res.steps[-1].goal) < 2e-3


def test_a_goal_inside_an_obstacle_names_the_step_and_the_obstacle(described_library):
    doc = button_scene(BUTTONS, goal=["b2"], obstacles={"lamp": "sphere:0.2,0.2,0.0,0.05"})
    with pytest.raises(ValueError, match=r"step 1 \(press b2\): cannot avoid obstacle lamp \(sphere:0.2,0.2,"
                                         r"0.0,0.05\): its goal"):
        _plan(described_library, doc)


def test_an_obstacle_no_primitive_can_be_edited_around_names_the_step_and_the_obstacle(described_library):
    # a wall between the start and the button, wider and higher than any edit can go round
    wall = "box:0.08,-5,-5,0.12,5,5"
    doc = button_scene(BUTTONS, goal=["b1"], obstacles={"wall": wall})
    with pytest.raises(ValueError, match=r"step 1 \(press b1\): cannot avoid obstacle wall \(box:"):
        _plan(described_library, doc)


def test_a_skill_with_no_primitive_names_the_step(described_library):
    described_library.describe("push", "(:action push :parameters (?b - button) :precondition (pressed ?b) "
                                       ":effect (pushed ?b))")
    doc = button_scene(BUTTONS, goal=["b1"])
    doc["goal"] = ["(pushed b1)"]
    with pytest.raises(ValueError, match=r"step 2 \(push b1\): skill 'push' has no usable primitive: no "
                                         r"primitive is labelled 'push' "
                                         r"\(labels in the library: \['press'\]\)"):
        _plan(described_library, doc)


def test_a_skill_whose_primitives_cannot_meet_the_step_names_the_step_and_the_reasons(described_library):
    for p in described_library.primitives(label="press"):
        described_library.label(None, primitive=p.id)
    # two samples cannot start and end at rest on new end points
    described_library.add(press_motion(np.array([0.2, 0, 0]), n=2), segment=False, label="press")
    with pytest.raises(ValueError, match=r"step 1 \(press b1\): skill 'press' has no usable primitive: 4: "
                                         r"cannot be edited: constraints: start_velocity"):
        _plan(described_library, button_scene(BUTTONS, goal=["b1"]))


def test_a_binding_picks_the_goal_argument_and_adds_its_offset(synthetic_library):
    action = "(:action " + ORDERED.split("(:action ", 1)[1].rstrip().removesuffix(")")
    synthetic_library.describe("press", action, {"goal": "?b", "offset": [0.0, 0.0, 0.01]})
    doc = button_scene(BUTTONS, goal=["b1"])
    doc["init"] = ["(ready b3)", "(next b3 b1)", "(next b1 b4)"]
    res = _plan(synthetic_library, doc)
    assert res.plan == [("press", ("b3", "b1")), ("press", ("b1", "b4"))]
    ends = [res.trajectory["position"][s.stop - 1] for s in res.steps]
    assert np.allclose(ends, [np.add(BUTTONS[2], [0, 0, 0.01]), np.add(BUTTONS[0], [0, 0, 0.01])], atol=1e-9)


def test_the_gripper_is_carried_and_set_by_the_binding(synthetic_library):
    synthetic_library.describe("press", "(:action press :parameters (?b - button) :precondition (free ?b) "
                                        ":effect (and (pressed ?b) (not (free ?b))))",
                               {"gripper": {"end": 0.0}})
    res = _plan(synthetic_library, button_scene(BUTTONS[:2], goal=["b1", "b2"]))
    G = res.trajectory["gripper"].ravel()
    first, second = res.steps
    assert G[0] == 1.0 and G[first.stop - 1] == 0.0  # recorded 1 until the binding's end value
    assert np.all(G[second.start:second.stop] == 0.0)  # carried into the next step, then held


def test_a_library_without_descriptions_or_domain_says_what_to_do(synthetic_library):
    with pytest.raises(ValueError, match=r"domain: the library has no skill descriptions; attach one with"):
        _plan(synthetic_library, button_scene(BUTTONS, goal=["b1"]))


def test_a_domain_given_is_used_as_it_is(synthetic_library):
    doc = button_scene(BUTTONS, goal=["b4"])
    doc["init"] = ["(ready b1)", "(next b1 b4)", "(next b4 b4)"]
    synthetic_library.describe("press", "(:action " + ORDERED.split("(:action ", 1)[1].rstrip()[:-1],
                               {"goal": "?n"})
    res = plan_task(synthetic_library.store, scene_from_dict(doc), domain=ORDERED)
    assert res.plan == [("press", ("b1", "b4")), ("press", ("b4", "b4"))]
    # the press pushes b4 in by its default travel (4 mm) along the tool, here straight down
    assert np.linalg.norm(res.trajectory["position"][res.steps[0].stop - 1] - BUTTONS[3]
                          - [0.0, 0.0, -0.004]) < 1e-9


def test_two_positioned_parameters_and_no_goal_is_an_error_that_shows_the_fix(synthetic_library):
    """Issue 24: with (?b ?n - button) the old default (the last positioned argument) pressed b2 for
    (press b3 b2) and reported it reached. Now no guess is made."""
    doc = button_scene(BUTTONS, goal=["b3"])
    doc["init"] = ["(ready b3)", "(next b3 b2)"]
    with pytest.raises(ValueError, match=r"^step 1 \(press b3 b2\): action press has 2 parameters that are "
                                         r"objects with a position \(\?b = b3, \?n = b2\) and its binding "
                                         r"names no goal; give one, e.g. skillbank library describe DB press "
                                         r"--action FILE\.pddl --binding '\{\"goal\": \"\?b\"\}'$"):
        plan_task(synthetic_library.store, scene_from_dict(doc), domain=ORDERED)
    doc["goal"], doc["init"] = ["(pressed b4)"], ["(ready b4)", "(next b4 b4)"]  # the same object twice: no
    # ambiguity
    res = plan_task(synthetic_library.store, scene_from_dict(doc), domain=ORDERED)
    assert res.plan == [("press", ("b4", "b4"))]


#: A post on the path the unobstructed press from b2 to b3 takes, where the whole UR5e (links and gripper)
#: can pass it: half-way along that press.
POST = "sphere:0.194,-0.648,0.168,0.02"


def test_the_three_button_skill_presses_four_new_buttons_with_one_continuous_joint_path(button_library):
    q = [0.0, 0.94, -0.33, 0.08]
    buttons = [[-0.3, -0.45, 0.12], [0.0, -0.6, 0.1], [0.25, -0.55, 0.11], [0.35, -0.4, 0.13]]
    doc = button_scene(buttons, goal=["b4", "b2", "b1", "b3"], orientation=q,
                       obstacles={"post": POST}, start=[-0.356, -0.416, 0.176])
    doc["start"]["orientation"] = [0.038, 0.955, -0.283, 0.078]
    res = plan_task(button_library.store, scene_from_dict(doc), robot="ur5e", limits={"joint_velocity": 1.0})
    traj = res.trajectory
    assert len(res.steps) == 4 and not res.collision
    for step in res.steps:  # each press 4 mm (its travel) into its button, along the tool's z
        button = np.array(buttons[int(step.args[0][1]) - 1])
        assert np.linalg.norm(step.goal - button) == pytest.approx(0.004, abs=1e-12)
        assert np.linalg.norm(traj["position"][step.stop - 1] - step.goal) < 2e-3
    assert res.clearance >= 0.005  # every link and the gripper, every sample, against the post and itself
    J = traj["joints"]
    assert res.join_error["joints"] < 1e-9 and np.abs(np.diff(J, axis=0)).max() < 0.05
    peak = np.abs(np.diff(J, axis=0) / np.diff(traj.t)[:, None]).max()
    assert peak <= 1.0 + 1e-9
    assert set(res.to_dict()) >= {"plan", "steps", "t", "streams", "collision", "constraint_error"}


@pytest.mark.parametrize("branch", [1, 4, 7])  # wrist down; shoulder right; both, with the elbow down
def test_a_start_on_another_ik_branch_is_followed_through_every_step(button_library, branch):
    """The recorded presses are shoulder-left/elbow-up/wrist-up; a robot that starts on another branch
    stays on it: each step's inverse kinematics is seeded with the joints the last one ended on."""
    from skillbank.robots import robot_model

    robot = robot_model("ur5e")
    q = [0.0, 0.94, -0.33, 0.08]
    buttons = [[-0.3, -0.45, 0.12], [0.0, -0.6, 0.1], [0.25, -0.55, 0.11], [0.35, -0.4, 0.13]]
    recorded = {robot.branch_of(p.demo["joints"])[0] for p in button_library.skill("press")}
    assert recorded == {0} and branch not in recorded
    start_q = np.array([0.038, 0.955, -0.283, 0.078]) / np.linalg.norm([0.038, 0.955, -0.283, 0.078])
    start = robot.ik_all(np.array([[-0.356, -0.416, 0.176]]), start_q[None])[0, branch]
    doc = button_scene(buttons, goal=["b4", "b2", "b1", "b3"], orientation=q,
                       obstacles={"post": POST})
    doc["start"] = {"joints": start.tolist()}
    res = plan_task(button_library.store, scene_from_dict(doc), robot="ur5e", limits={"joint_velocity": 1.0})
    J = res.trajectory["joints"]
    np.testing.assert_allclose(J[0], start, atol=1e-12)
    assert res.join_error["joints"] < 1e-9 and np.abs(np.diff(J, axis=0)).max() < 0.05
    assert set(robot.branch_of(J).tolist()) == {branch}
