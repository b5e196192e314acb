"""The planning demonstrations: tasks never demonstrated, planned, chained, collision-free, written."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import skillbank.experiments._planning_demo as demo
from skillbank.experiments import button_task, rail_task, run_planning_demo, synthetic_ur5e
from skillbank.pipeline import Library
from skillbank.planning import load_scene, scene_from_dict


def _columns(path) -> dict:
    """The trajectory CSV as ``t``, ``position`` (n, 3) and ``joints`` (n, 6) when written."""
    # the lines before the header (``#``) state the limits the trajectory was timed for
    lines = [line for line in Path(path).read_text().splitlines() if not line.startswith("#")]
    header = lines[0].split(",")
    rows = np.loadtxt(lines[1:], delimiter=",", ndmin=2)
    out = {"t": rows[:, 0], "position": rows[:, [header.index(f"position_{k}") for k in range(3)]]}
    joints = [k for k, name in enumerate(header) if name.startswith("joints_")]
    if joints:
        out["joints"] = rows[:, joints]
    return out


def _check_written_and_chained(item) -> dict:
    """Every file is there and reads back; the steps tile one continuous trajectory; returns the CSV."""
    json.dumps(item)  # JSON-able
    files = item["files"]
    for key in ("scene", "domain", "problem", "trajectory", "figure", "library"):
        assert Path(files[key]).is_file(), key
    assert Path(files["figure"]).stat().st_size > 10_000
    assert Path(files["domain"]).read_text().startswith("(define (domain")
    assert Path(files["problem"]).read_text().startswith("(define (problem")
    load_scene(files["scene"])  # the scene written is a valid scene file
    traj = _columns(files["trajectory"])
    t, P = traj["t"], traj["position"]
    assert t[0] == 0.0 and np.all(np.diff(t) > 0) and len(t) == item["n_samples"]
    steps = item["steps"]
    assert steps[0]["samples"][0] == 0 and steps[-1]["samples"][1] == len(t)
    for prev, step in zip(steps[:-1], steps[1:], strict=True):
        assert step["samples"][0] == prev["samples"][1] - 1  # the join sample is shared, kept once
        j = step["samples"][0]
        # at rest at every join: the samples either side do not move (zero velocity at both ends)
        assert np.linalg.norm(P[j] - P[j - 1]) < 1e-6 and np.linalg.norm(P[j + 1] - P[j]) < 1e-6
    assert np.linalg.norm(np.diff(P, axis=0), axis=1).max() < 0.01  # no jump anywhere
    assert all(v < 1e-9 for v in item["join_error"].values())
    if "joints" in traj:
        J = traj["joints"]
        assert np.abs(np.diff(J, axis=0)).max() < 0.05  # one continuous joint path
        assert (np.abs(np.diff(J, axis=0)) / np.diff(t)[:, None]).max() <= 1.0 + 1e-9  # the 1 rad/s limit
    return traj


def _no_collision(item, P) -> None:
    scene = load_scene(item["files"]["scene"])
    assert not item["collision"]
    for name, obstacle in scene.obstacles.items():
        assert obstacle.signed_distance(P).min() > 0.0, name


def _replan(item, doc):
    with Library(item["files"]["library"]) as lib:
        return lib.plan(scene_from_dict(doc), robot=item["robot"],
                        limits={"joint_velocity": 1.0} if item["robot"] else None, random_state=0)


# --- the embedded task (no data) ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def embedded(tmp_path_factory):
    out = tmp_path_factory.mktemp("planning")
    return out, run_planning_demo(out)


def test_without_data_the_embedded_task_is_planned_written_and_summarised(embedded):
    out, res = embedded
    assert list(res["tasks"]) == ["reach"]
    written = json.loads((out / "summary.json").read_text())
    assert written["tasks"]["reach"]["plan"] == res["tasks"]["reach"]["plan"]
    text = Path(res["summary"]).read_text()
    assert "![reach](reach.png)" in text and "skillbank plan " in text


def test_the_embedded_task_visits_every_target_from_the_start_joints_without_a_collision(embedded):
    item = embedded[1]["tasks"]["reach"]
    assert sorted(args[1] for args in item["plan"]) == ["t1", "t2", "t3"] and len(item["plan"]) == 3
    traj = _check_written_and_chained(item)
    P = traj["position"]
    for step in item["steps"]:
        assert np.linalg.norm(P[step["samples"][1] - 1] - demo.REACH_TARGETS[step["args"][0]]) < 1e-9
    start = synthetic_ur5e(random_state=0)["joints"][0]
    assert np.abs(traj["joints"][0] - start).max() < 1e-9  # it starts at the scene's start joints
    _no_collision(item, P)


def test_the_ball_is_on_the_path_the_embedded_task_takes_without_it(embedded):
    item = embedded[1]["tasks"]["reach"]
    doc = json.loads(Path(item["files"]["scene"]).read_text())
    ball = load_scene(item["files"]["scene"]).obstacles["ball"]
    doc["obstacles"] = {}
    free = _replan(item, doc)
    hit = [s.args for s in free.steps if ball.collides(free.trajectory["position"][s.start:s.stop])]
    assert hit == [("t2",)]  # between t1 and t2, which the planned path goes round


def test_data_that_is_not_a_folder_with_the_data_is_refused(tmp_path):
    with pytest.raises(ValueError, match=r"data: expected a folder with rail/ and seed/, got '.*nowhere'"):
        run_planning_demo(tmp_path / "out", data=tmp_path / "nowhere")
    assert not (tmp_path / "out").exists()  # refused before anything is written


def test_a_demonstration_without_two_button_to_button_presses_is_refused(tmp_path, monkeypatch):
    # the synthetic recording's moves all start or end high above a table: no press among them
    monkeypatch.setattr(demo, "load", lambda path: synthetic_ur5e())
    with pytest.raises(ValueError, match=r"data: expected the three-button demonstration to segment into two "
                                         r"presses from one button to the next, got 1"):
        button_task(tmp_path, tmp_path)


# --- the three-button demonstration: four new buttons --------------------------------------------------


@pytest.fixture(scope="module")
def buttons(tmp_path_factory, data_dir):
    return button_task(tmp_path_factory.mktemp("buttons"), data_dir)


def test_four_new_buttons_are_pressed_in_the_codes_order_each_within_2_mm(buttons):
    assert buttons["plan"] == [["press", "home", "b3"], ["press", "b3", "b1"], ["press", "b1", "b4"],
                               ["press", "b4", "b2"]]
    xs = [demo.BUTTONS[step[2]][0] for step in buttons["plan"]]
    assert xs != sorted(xs)  # not left to right, the one order the demonstration showed
    traj = _check_written_and_chained(buttons)
    P = traj["position"]
    for step in buttons["steps"]:
        assert np.linalg.norm(P[step["samples"][1] - 1] - demo.BUTTONS[step["args"][1]]) < 2e-3
    _no_collision(buttons, P)
    assert "joints" in traj


def test_the_buttons_are_where_the_demonstration_never_pressed(buttons):
    with Library(buttons["files"]["library"]) as lib:
        pressed = np.vstack([p.demo["position"][[0, -1]] for p in lib.primitives(label="press")])
    for name, position in demo.BUTTONS.items():
        assert np.linalg.norm(pressed - position, axis=1).min() > 0.1, name


def test_the_post_stands_on_the_path_from_b1_to_b4_without_it(buttons):
    doc = demo.button_scene()
    post = scene_from_dict(doc).obstacles["post"]
    doc["obstacles"] = {}
    free = _replan(buttons, doc)
    hit = [s.args for s in free.steps if post.collides(free.trajectory["position"][s.start:s.stop])]
    assert hit == [("b1", "b4")]


# --- RAIL: push the cube onto the plate, then press the button -----------------------------------------


@pytest.fixture(scope="module")
def rail(tmp_path_factory, data_dir):
    return rail_task(tmp_path_factory.mktemp("rail"), data_dir)


def test_the_planner_pushes_the_cube_before_pressing_and_the_press_ends_within_2_mm(rail):
    # the goal names only the button: the push comes from the button's precondition
    assert rail["plan"] == [["pushing", "cube", "plate"], ["pressing", "plate", "run_button"]]
    traj = _check_written_and_chained(rail)
    P = traj["position"]
    push, press = rail["steps"]
    assert np.linalg.norm(P[press["samples"][1] - 1] - demo.RAIL_OBJECTS["run_button"][1]) < 2e-3
    assert np.linalg.norm(P[push["samples"][1] - 1] - demo.RAIL_OBJECTS["plate"][1]) < 2e-3
    _no_collision(rail, P)
    assert "joints" not in traj  # RAIL has positions only


def test_the_push_comes_down_at_the_cube_and_slides_it_along_the_table_to_the_plate(rail):
    P = _columns(rail["files"]["trajectory"])["position"]
    start, stop = rail["steps"][0]["samples"]
    Q = P[start:stop]
    d = np.linalg.norm(Q - demo.RAIL_OBJECTS["cube"][1], axis=1)
    k = int(np.argmin(d))
    assert d[k] < 0.01
    assert Q[k:, 2].max() < 0.045  # from the cube on, on the table (its top plus 3 cm)
    assert np.linalg.norm(Q[-1] - Q[k]) > 0.08


def test_the_objects_are_where_no_demonstration_of_their_skill_went(rail):
    with Library(rail["files"]["library"]) as lib:
        paths = {lab: np.vstack([p.demo["position"] for p in lib.primitives(label=lab)])
                 for lab in ("pushing", "pressing")}
    assert rail["skills"] == {"pressing": 59, "pushing": 60, "reaching": 60}
    for name, skill, far in (("cube", "pushing", 0.1), ("plate", "pushing", 0.15),
                             ("run_button", "pressing", 0.2)):
        assert np.linalg.norm(paths[skill] - demo.RAIL_OBJECTS[name][1], axis=1).min() > far, name


def test_the_table_and_the_mug_are_each_in_the_way_without_them(rail):
    doc = demo.rail_scene()
    scene = scene_from_dict(doc)
    doc["obstacles"] = {"table": demo.RAIL_OBSTACLES["table"]}
    on_table = _replan(rail, doc)
    assert scene.obstacles["mug"].collides(on_table.trajectory["position"])
    doc["obstacles"] = {}
    free = _replan(rail, doc)
    # pressing, which starts on the table after the push, dips into it
    assert scene.obstacles["table"].collides(free.trajectory["position"])
