"""Planning at the edges (issue 23, items 7-9): an empty plan, start joints beyond the limits, a dict scene.

Before: a goal already true in ``init`` ended in an IndexError (the planner's answer, no steps, is a
valid one); start joints outside the robot's limits were shifted by 2π without a word; and
``Library.plan(dict)`` raised a TypeError from ``pathlib``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from skillbank.planning import EMPTY_PLAN, plan_task, scene_from_dict
from skillbank.planning import _plan as plan_module
from skillbank.planning._chain import _start_joints

from .conftest import BUTTONS_DOC, DOWN, PRESS, button_scene, write_scene

BUTTONS = [[0.2, 0.0, 0.0], [0.2, 0.2, 0.0]]


def _already_pressed():
    doc = button_scene(BUTTONS, goal=["b1"])
    doc["init"] = ["(pressed b1)", "(free b2)"]
    return doc


def test_a_goal_that_holds_in_init_is_an_empty_plan(described_library):
    res = plan_task(described_library.store, scene_from_dict(_already_pressed()))
    assert res.plan == [] and res.steps == [] and res.trajectory is None
    assert res.notes == [EMPTY_PLAN] and not res.collision and res.constraint_error == 0.0
    assert "(pressed b1)" in res.problem and "(:action press" in res.domain
    doc = res.to_dict()
    assert (doc["plan"], doc["steps"], doc["t"], doc["streams"]) == ([], [], [], {})
    json.dumps(doc, allow_nan=False)


def test_cli_plan_of_a_goal_already_true_prints_zero_steps_and_writes_nothing(described_library, synthetic_db,
                                                                               tmp_path, cli):
    described_library.close()
    folder = tmp_path / "task"
    folder.mkdir()
    scene = write_scene(folder, _already_pressed())
    code, out, err = cli("plan", synthetic_db, "--scene", scene, "--json", "--out", folder / "plan.csv",
                         "--plot", folder / "plan.png")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["plan"] == [] and doc["steps"] == [] and doc["written"] == [] and doc["t"] == []
    assert doc["notes"] == [EMPTY_PLAN, "--out and --plot: nothing written (a plan of no steps has no "
                                        "trajectory)"]
    assert sorted(p.name for p in folder.iterdir()) == ["scene.json"]
    code, out, err = cli("plan", synthetic_db, "--scene", scene)
    assert code == 0 and err == ""
    head, note = out.splitlines()
    assert head.endswith(": plan of 0 step(s) for 1 goal fact(s)") and note == f"  note: {EMPTY_PLAN}"


def test_library_plan_takes_a_dict_a_scene_or_a_path_and_says_what_else(described_library, tmp_path):
    from skillbank.planning import load_scene  # the same scene three ways

    path = write_scene(tmp_path, BUTTONS_DOC)
    plans = [described_library.plan(s).plan for s in (BUTTONS_DOC, load_scene(path), path, str(path))]
    assert plans[0] == [("press", ("b1",)), ("press", ("b2",))] or plans[0] == [("press", ("b2",)),
                                                                               ("press", ("b1",))]
    assert all(p == plans[0] for p in plans)
    for bad, what in ((5, "the number 5"), ([BUTTONS_DOC], "a list of 1 item"), (None, "null")):
        with pytest.raises(ValueError, match=r"^scene: expected a Scene, a dict \(a scene's content, as in a "
                                             rf"scene file\) or the path of a scene file, got {what}"):
            described_library.plan(bad)
    with pytest.raises(ValueError, match=r"^objects\['b1'\]\.type: expected a PDDL type name"):
        described_library.plan(dict(BUTTONS_DOC, objects={"b1": {"type": 5}}))


def test_a_domain_file_is_read_up_to_its_bound(described_library, tmp_path, monkeypatch):
    scene = scene_from_dict(BUTTONS_DOC)
    path = tmp_path / "d.pddl"
    path.write_text("(define (domain d) (:requirements :strips :typing) (:types button) "
                    "(:predicates (free ?b - button) (pressed ?b - button))" + PRESS + ")")
    assert len(plan_task(described_library.store, scene, domain=path).plan) == 2
    monkeypatch.setattr(plan_module, "MAX_DOMAIN_BYTES", path.stat().st_size - 1)
    with pytest.raises(ValueError, match=rf"^domain: expected a file of at most {path.stat().st_size - 1} "
                                         r"bytes, got a larger one"):
        plan_task(described_library.store, scene, domain=path)
    path.write_bytes(b"(define \xff)")
    monkeypatch.undo()
    with pytest.raises(ValueError, match=r"^domain '.*d\.pddl': expected UTF-8 text, got invalid start byte "
                                         r"at byte 8$"):
        plan_task(described_library.store, scene, domain=path)


def test_start_joints_outside_the_limits_are_refused_and_inside_them_kept_exactly():
    from skillbank.robots import robot_model  # the robot layer, for its limits

    robot = robot_model("ur5e")
    q = np.array([0.5, -1.2, 1.0, -1.4, 1.57, 0.0])
    for k, value, shown in ((0, 0.5 + 2 * np.pi, r"shoulder_pan_joint = 6\.78319 rad, outside \[-2π, 2π\]"),
                            (5, -7.0, r"wrist_3_joint = -7 rad, outside \[-2π, 2π\]"),
                            (2, 3.5, r"elbow_joint = 3\.5 rad, outside \[-π, π\]")):
        bad = q.copy()
        bad[k] = value
        with pytest.raises(ValueError, match=r"^start\.joints: expected joint angles within the limits of "
                                             rf"robot ur5e, got {shown} \(1 joint\(s\) outside\); wrap "
                                             r"it by a multiple of 2π into the limits if that is the "
                                             r"configuration meant$"):
            _start_joints(robot, bad)
    edge = np.array([2 * np.pi, -2 * np.pi, np.pi, 0.5 - 2 * np.pi, 0.0, -2 * np.pi])
    np.testing.assert_array_equal(_start_joints(robot, edge), edge)  # the limits themselves: kept as given


def test_plan_refuses_start_joints_outside_the_limits_before_any_step(described_library):
    doc = button_scene(BUTTONS, goal=["b1"], orientation=DOWN)
    doc["start"] = {"joints": [7.0, -1.2, 1.0, -1.4, 1.57, 0.0]}
    with pytest.raises(ValueError, match=r"^start\.joints: expected joint angles within the limits of robot "
                                         r"ur5e, got shoulder_pan_joint = 7 rad"):
        plan_task(described_library.store, scene_from_dict(doc), robot="ur5e")
    doc["init"] = ["(pressed b1)"]  # refused even when there is no step to take
    with pytest.raises(ValueError, match=r"^start\.joints: expected joint angles within the limits"):
        plan_task(described_library.store, scene_from_dict(doc), robot="ur5e")


def test_a_start_shifted_by_2pi_within_the_limits_is_followed_not_moved(button_library):
    """The start the user gives is the first sample of the joint path, even 2π away from the IK's."""
    from skillbank.robots import robot_model  # the robot layer, for the start configuration

    robot = robot_model("ur5e")
    orientation = np.array([0.038, 0.955, -0.283, 0.078]) / np.linalg.norm([0.038, 0.955, -0.283, 0.078])
    start = robot.ik_all(np.array([[-0.356, -0.416, 0.176]]), orientation[None])[0, 0]
    shifted = start.copy()
    shifted[5] += 2 * np.pi if shifted[5] < 0 else -2 * np.pi
    doc = button_scene([[-0.3, -0.45, 0.12], [0.0, -0.6, 0.1]], goal=["b2"],
                       orientation=[0.0, 0.94, -0.33, 0.08])
    doc["start"] = {"joints": shifted.tolist()}
    res = plan_task(button_library.store, scene_from_dict(doc), robot="ur5e")
    np.testing.assert_allclose(res.trajectory["joints"][0], shifted, atol=1e-12)


TYPED = """(define (domain typed) (:requirements :strips :typing) (:types button lever - device)
  (:predicates (free ?d - device) (pressed ?d - device))
  (:action press :parameters (?b - button) :precondition (free ?b) :effect (pressed ?b))
  (:action pull :parameters (?l - lever ?d - device) :effect (pressed ?d))
  (:action touch :parameters (?x - object ?y) :effect (pressed ?x)))
"""


def test_ground_actions_are_counted_by_type_with_its_subtypes():
    from skillbank.planning import check_groundings, parse_domain  # the count, on a typed domain

    domain = parse_domain(TYPED)
    objects = {"b1": "button", "b2": "button", "b3": "button", "l1": "lever", "t1": "table"}
    # press: 3 buttons; pull: 1 lever x 4 devices; touch: 5 x 5 objects
    assert check_groundings(domain, objects) == 3 + 4 + 25
    with pytest.raises(ValueError, match=r"^domain: expected at most max_groundings=31 ground actions \(the "
                                         r"planner builds each before it searches\), got 32 in this scene "
                                         r"\(action touch: 2 parameter\(s\) over 5 object\(s\), 25\); give "
                                         r"fewer objects or parameters, or raise the bound "
                                         r"\(--max-groundings"):
        check_groundings(domain, objects, max_groundings=31)
    with pytest.raises(ValueError, match=r"^max_groundings: expected an integer > 0"):
        check_groundings(domain, objects, max_groundings=0)


def test_a_count_too_large_to_write_is_capped_in_the_message():
    from skillbank.planning import check_groundings, domain_text, parse_action  # the count, capped

    params = " ".join(f"?x{k}" for k in range(400))
    domain = domain_text([parse_action(f"(:action a :parameters ({params} - t) :effect (p ?x0))")])
    with pytest.raises(ValueError, match=r"got over 1e\+18 in this scene \(action a: 400 parameter\(s\) over "
                                         r"1000 object\(s\), over 1e\+18\)") as info:
        check_groundings(domain, {f"o{k}": "t" for k in range(1000)})
    assert len(str(info.value)) < 400


def _wide_task(folder, n_objects=20, n_params=6):
    params = " ".join(f"?x{k}" for k in range(n_params))
    (folder / "wide.pddl").write_text(
        "(define (domain wide) (:requirements :strips :typing) (:types button)\n"
        "  (:predicates (free ?b - button) (pressed ?b - button))\n"
        f"  (:action press :parameters ({params} - button)\n"
        "    :precondition (and " + " ".join(f"(free ?x{k})" for k in range(n_params)) + ")\n"
        "    :effect (pressed ?x0)))\n")
    doc = button_scene([[0.01 * k, 0.0, 0.0] for k in range(n_objects)], goal=["b1"])
    return write_scene(folder, doc), folder / "wide.pddl"


def test_cli_plan_of_64_million_ground_actions_is_refused_before_grounding(described_library, synthetic_db,
                                                                          tmp_path, limited):
    """Without the bound the planner grounds 20^6 actions: hours and gigabytes. Now one line, at once."""
    described_library.close()
    folder = tmp_path / "task"
    folder.mkdir()
    scene, domain = _wide_task(folder)
    code, out, err = limited("plan", synthetic_db, "--scene", scene, "--domain", domain, "--out",
                             folder / "plan.csv", memory=1 << 30, timeout=120)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert err.startswith("skillbank plan: error: domain: expected at most max_groundings=250000 ground "
                          "actions (the planner builds each before it searches), got 64000000 in this scene "
                          "(action press: 6 parameter(s) over 20 object(s), 64000000)"), err
    assert sorted(p.name for p in folder.iterdir()) == ["scene.json", "wide.pddl"]


def test_max_groundings_is_the_way_past_the_bound(described_library, synthetic_db, tmp_path, cli):
    described_library.close()
    folder = tmp_path / "task"
    folder.mkdir()
    scene, domain = _wide_task(folder, n_objects=3, n_params=2)  # 9 ground actions
    code, out, err = cli("plan", synthetic_db, "--scene", scene, "--domain", domain, "--max-groundings", "8")
    assert code == 2 and out == "" and "got 9 in this scene" in err and err.count("\n") == 1
    code, out, err = cli("plan", synthetic_db, "--scene", scene, "--domain", domain, "--max-groundings", "9",
                         "--json")
    assert code == 0, err
    assert [step["action"] for step in json.loads(out)["plan"]] == ["press"]


CHAIN = """(define (domain chain) (:requirements :strips :typing) (:types place)
  (:predicates (at ?p - place) (next ?a ?b - place))
  (:action go :parameters (?a ?b - place) :precondition (and (at ?a) (next ?a ?b)) :effect (at ?b)))
"""


def test_reachability_along_a_chain_listed_backwards_names_what_lies_past_a_broken_link():
    from skillbank.planning import solve  # the planner adapter

    n = 120
    objects = " ".join(f"p{k}" for k in range(n))
    links = " ".join(f"(next p{k} p{k + 1})" for k in reversed(range(n - 1)) if k != 100)  # no 100 -> 101
    problem = (f"(define (problem p) (:domain chain) (:objects {objects} - place) (:init (at p0) {links}) "
               f"(:goal (and (at p{n - 1}) (at p100) (at p101))))")
    with pytest.raises(ValueError, match=rf"^goal: no plan reaches \(at p101\), \(at p{n - 1}\): "
                                         r"no sequence"):
        solve(CHAIN, problem)


def test_the_search_gives_up_at_its_time_limit_or_state_budget_and_says_which():
    from skillbank.planning import solve  # the planner adapter

    objects = " ".join(f"p{k}" for k in range(6))
    links = " ".join(f"(next p{k} p{k + 1})" for k in range(5))
    problem = (f"(define (problem p) (:domain chain) (:objects {objects} - place) (:init (at p0) {links}) "
               "(:goal (and (at p5))))")
    assert len(solve(CHAIN, problem)) == 5
    with pytest.raises(ValueError, match=r"^goal: the planner gave up after 1 states without a plan "
                                         r"\(max_expansions\)$"):
        solve(CHAIN, problem, max_expansions=1)
    # a deadline of a nanosecond has passed by the first check, which follows the first heuristic
    with pytest.raises(ValueError, match=r"^goal: the planner gave up after 1e-09 s without a plan \(0 "
                                         r"states\); raise the bound if the task is meant \(--time-limit"):
        solve(CHAIN, problem, time_limit=1e-9)
    for kwargs, match in (({"time_limit": 0}, r"^time_limit: expected a number > 0, got 0$"),
                          ({"max_expansions": 2.5}, r"^max_expansions: expected an integer > 0, got 2\.5$")):
        with pytest.raises(ValueError, match=match):
            solve(CHAIN, problem, **kwargs)


def test_cli_plan_writes_all_its_outputs_or_none(described_library, synthetic_db, tmp_path, cli):
    described_library.close()
    folder = tmp_path / "task"
    folder.mkdir()
    scene = write_scene(folder, BUTTONS_DOC)
    code, out, err = cli("plan", synthetic_db, "--scene", scene, "--out", folder / "plan.csv", "--plot",
                         folder / "missing" / "plan.png")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "plot: expected a file in an existing folder, got " in err and "missing' does not exist" in err
    (folder / "plan.domain.pddl").mkdir()  # the PDDL beside the figure cannot be written: after the CSV was
    code, out, err = cli("plan", synthetic_db, "--scene", scene, "--out", folder / "plan.csv", "--plot",
                         folder / "plan.png")
    assert code == 2 and out == "" and err.count("\n") == 1 and "plan.domain.pddl" in err, err
    assert sorted(p.name for p in folder.iterdir()) == ["plan.domain.pddl", "scene.json"]
    (folder / "plan.domain.pddl").rmdir()
    code, out, err = cli("plan", synthetic_db, "--scene", scene, "--out", folder / "plan.csv", "--plot",
                         folder / "plan.png")
    assert code == 0, err
    assert sorted(p.name for p in folder.iterdir()) == ["plan.csv", "plan.domain.pddl", "plan.png",
                                                        "plan.problem.pddl", "scene.json"]
