"""simulate(): real MuJoCo replays with known answers, and every error path."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from skillbank.core import Box, Demonstration, Sphere
from skillbank.io import load
from skillbank.planning import SceneObject
from skillbank.robots import clearance
from skillbank.simulation import simulate

from .conftest import TABLE, button, scene, sweep

GOAL = [("pressed", ("b1",)), ("pressed", ("b2",)), ("pressed", ("b3",))]


@pytest.fixture(scope="module")
def recording(data_dir):
    return load(data_dir / "seed" / "three_button_pressing_demo.h5")


@pytest.fixture(scope="module")
def presses(recording, ur5e):
    """The three lowest points of the TCP, one around each press (9.2, 14.1, 18.7 s)."""
    tcp = (ur5e.link_frames(recording["joints"])[:, -1] @ ur5e.gripper_.tool())[:, :3, 3]
    t = recording.t - recording.t[0]
    out = []
    for lo, hi in ((8.0, 11.0), (12.5, 16.0), (17.0, 20.5)):
        idx = np.flatnonzero((t >= lo) & (t <= hi))
        out.append(tcp[idx[np.argmin(tcp[idx, 2])]])
    return np.array(out)


def _buttons(presses, moved=None):
    out = []
    for k, p in enumerate(presses):
        p = p.copy()
        if moved == k:
            p[0] += 0.05
        out.append(button(f"b{k + 1}", p))
    return out


@pytest.fixture(scope="module")
def three(recording, presses):
    return simulate(recording, scene(_buttons(presses), goal=GOAL))


def test_the_recording_presses_all_three_buttons_and_touches_nothing_else(three):
    assert three.contacts == []
    assert three.facts == {"(pressed b1)": True, "(pressed b2)": True, "(pressed b3)": True}
    assert three.ok
    # pressed at the three presses the data shows (9.2, 14.1, 18.7 s), shortly before the lowest point
    for name, when in (("b1", 9.2), ("b2", 14.0), ("b3", 18.7)):
        b = three.buttons[name]
        assert b["pressed"] and when - 0.3 < b["t"] < when + 0.1
        assert b["peak_force"] > 3.5  # at least the spring's preload
    assert three.tool_max < 2e-3 and three.joint_max < 5e-3
    assert three.duration == pytest.approx(27.714, abs=0.01)
    assert three.real_time_factor > 1


def test_a_button_moved_five_centimetres_is_not_pressed(recording, presses):
    result = simulate(recording, scene(_buttons(presses, moved=1), goal=GOAL))
    assert result.buttons["b2"]["pressed"] is False and result.buttons["b2"]["t"] is None
    assert result.facts == {"(pressed b1)": True, "(pressed b2)": False, "(pressed b3)": True}
    assert not result.ok


def test_the_json_contract(three):
    doc = json.loads(json.dumps(three.to_dict(), allow_nan=False))
    assert {"duration", "real_time_factor", "tracking", "contacts", "buttons", "objects", "facts",
            "notes"} <= set(doc)
    assert set(doc["tracking"]) == {"joint_max", "tool_max"}
    assert all(isinstance(v, float) for v in doc["tracking"].values())
    for b in doc["buttons"].values():
        assert set(b) == {"pressed", "peak_force", "t"}
        assert isinstance(b["pressed"], bool) and isinstance(b["peak_force"], float)
        assert isinstance(b["t"], float)
    assert isinstance(doc["duration"], float) and isinstance(doc["notes"], list)


def _capsule_distance(ur5e, q, cap, box):
    """Smallest distance from the capsule ``cap`` to ``box`` along a path of joints ``q`` (dense sampling)."""
    s = np.linspace(0.0, 1.0, 200)[:, None]
    seg = (1 - s) * np.asarray(cap.a) + s * np.asarray(cap.b)
    T = ur5e.link_frames(q)[:, cap.frame]
    points = np.einsum("nij,kj->nki", T[:, :3, :3], seg) + T[:, None, :3, 3]
    return box.signed_distance(points.reshape(-1, 3)).reshape(len(q), -1).min(axis=1) - cap.radius


def test_the_forearm_driven_into_a_box_is_the_contact_at_the_predicted_time(ur5e):
    q0 = np.array(ur5e.home)
    forearm = next(c for c in ur5e.bodies if c.name == "forearm")
    # a 4 cm box beside the forearm's middle, 0.6 rad further round the base axis
    F = ur5e.link_frames(q0 + [0.6, 0, 0, 0, 0, 0])[0, forearm.frame]
    middle = F[:3, :3] @ (0.5 * (np.asarray(forearm.a) + np.asarray(forearm.b))) + F[:3, 3]
    box = Box(middle - 0.02, middle + 0.02)
    demo = sweep(q0, 0, 0.9, 1.8, n=181)
    distances = {c.name: _capsule_distance(ur5e, demo["joints"], c, box) for c in ur5e.bodies}
    first = {name: demo.t[np.argmax(d <= 0)] for name, d in distances.items() if (d <= 0).any()}
    assert min(first, key=first.get) == "forearm"
    result = simulate(demo, scene(obstacles={"wall": box}))
    hits = [c for c in result.contacts if c["other"] == "wall"]
    assert hits and hits[0]["robot_body"] == "forearm"
    assert hits[0]["t"] == pytest.approx(first["forearm"], abs=0.02)  # within two samples of 10 ms
    assert hits[0]["force"] > 0
    assert not result.ok
    # the geometric whole-arm check flags the same link and obstacle, within one sample of the physics
    check = clearance(ur5e, demo["joints"], {"wall": box}, t=demo.t)
    index, body, other = check.first_contact()
    assert (body, other) == ("forearm", "wall")
    assert abs(demo.t[index] - hits[0]["t"]) <= demo.t[1] - demo.t[0] + 1e-9


def test_a_box_pushed_by_the_gripper_moves(ur5e):
    down = np.array([0.0, 1.0, 0.0, 0.0])  # tool z pointing down
    q0 = ur5e.ik([-0.45, -0.25, 0.03], down, q_seed=ur5e.home)  # the TCP (the model's default tool)
    demo = sweep(q0, 0, 0.5, 1.0, n=101)
    path = (ur5e.link_frames(demo["joints"])[:, -1] @ ur5e.gripper_.tool())[:, :3, 3]
    centre = path[60].copy()
    centre[2] = 0.025
    box = SceneObject("crate", "box", position=centre, shape="box", size=np.array([0.05, 0.05, 0.05]),
                      mass=0.2)
    result = simulate(demo, scene([box], table=TABLE, goal=[("moved", ("crate",))]))
    crate = result.objects["crate"]
    assert crate["displacement"] > 0.01 and not crate["held"] and not crate["lifted"]
    assert result.contacts == []  # the crate is a target: touching it is intended
    assert result.facts == {"(moved crate)": None} and any("cannot judge" in n for n in result.notes)
    # not a target in that window: the same push is an unintended contact
    result = simulate(demo, scene([box], table=TABLE), targets=[(0.0, 0.1, ["crate"])])
    assert result.contacts and {c["other"] for c in result.contacts} == {"crate"}
    assert all(c["t"] > 0.1 for c in result.contacts)


def test_progress_is_called_up_to_the_last_step(ur5e):
    calls = []
    simulate(sweep(ur5e.home, 0, 0.1, 0.2, n=11), scene(),
             progress=lambda done, total: calls.append((done, total)))
    assert calls and calls[-1][0] == calls[-1][1] == 101


@pytest.mark.parametrize("make, match", [
    (lambda m: Demonstration(np.linspace(0, 1, 5), {"position": np.zeros((5, 3))}),
     r"trajectory: expected a 'joints' stream \(n, 6\)"),
    (lambda m: Demonstration(np.linspace(0, 1, 5), {"joints": np.zeros((5, 5))}),
     r"trajectory.joints: expected 6 columns .* got shape \(5, 5\)"),
    (lambda m: 42, "trajectory: expected a skillbank.core.Demonstration"),
])
def test_bad_trajectories_are_refused(ur5e, make, match):
    with pytest.raises(ValueError, match=match):
        simulate(make(ur5e), scene())


def test_a_table_above_the_start_tool_point_is_refused(ur5e):
    high = Box([-1.0, -1.0, 0.0], [1.0, 1.0, 0.9])
    with pytest.raises(ValueError, match=r"scene.table: its top \(z = 0.9 m\) is above the robot's start"):
        simulate(sweep(ur5e.home, 0, 0.1, 0.2, n=11), scene(table=high))


def test_a_robot_that_starts_inside_an_obstacle_is_refused(ur5e):
    elbow = ur5e.link_frames(ur5e.home)[0, 3, :3, 3]
    with pytest.raises(ValueError, match=r"the robot starts inside obstacle 'ball' \(\w+ .* mm deep"):
        simulate(sweep(ur5e.home, 0, 0.1, 0.2, n=11), scene(obstacles={"ball": Sphere(elbow, 0.05)}))


@pytest.mark.parametrize("kwargs, match", [
    ({"targets": [(0.0, 1.0, ["nothing"])]}, r"targets\[0\]: unknown object 'nothing'"),
    ({"targets": [(1.0, 0.0, [])]}, r"targets\[0\]: t_start 1.0 after t_end 0.0"),
    ({"targets": [5]}, r"targets\[0\]: expected \(t_start, t_end, names\)"),
    ({"press_fraction": 1.5}, r"press_fraction: expected a number in \(0, 1.0\]"),
    ({"timestep": 0.0}, r"timestep: expected a number in \(0, 0.1\]"),
    ({"robot": "nao"}, "robot: expected one of"),
    ({"kp": [-1.0] * 6}, "kp: expected positive servo gains"),
    ({"video": "out.mp4"}, r"video: expected a .gif file"),
])
def test_bad_parameters_are_refused(ur5e, kwargs, match):
    with pytest.raises(ValueError, match=match):
        simulate(sweep(ur5e.home, 0, 0.1, 0.2, n=11), scene(), **kwargs)


def test_without_mujoco_one_line_names_the_extra(ur5e, monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # as if the extra were not installed
    with pytest.raises(ImportError, match=r"^simulation needs MuJoCo: pip install 'skillbank\[sim\]'$"):
        simulate(sweep(ur5e.home, 0, 0.1, 0.2, n=11), scene())


def _pick(ur5e, centre, close: bool) -> Demonstration:
    """Down onto a cube with the gripper open, close it (or not), lift it 20 cm: minimum-jerk moves."""
    def move(a, b, n):
        s = np.linspace(0.0, 1.0, n)
        s = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5
        return a + s[:, None] * (b - a)

    above, up = centre + [0.0, 0.0, 0.15], centre + [0.0, 0.0, 0.2]
    P = np.vstack([move(above, centre, 150), np.tile(centre, (100, 1)), move(centre, up, 150),
                   np.tile(up, (50, 1))])
    closing = np.linspace(0.0, 100.0, 60) if close else np.zeros(60)
    G = np.r_[np.zeros(150), closing, np.full(240, closing[-1])]
    down = np.array([0.0, 1.0, 0.0, 0.0])
    J = ur5e.ik(P, np.tile(down, (len(P), 1)), q_seed=ur5e.home)
    return Demonstration(np.arange(len(P)) * 0.01, {"joints": J, "gripper": G[:, None]})


@pytest.mark.parametrize("close", [True, False])
def test_a_cube_grasped_and_lifted_is_held_and_lifted_and_its_facts_say_so(ur5e, close):
    centre = np.array([-0.45, -0.25, 0.025])
    cube = SceneObject("cube", "box", position=centre, shape="box", size=np.array([0.04, 0.04, 0.05]),
                       mass=0.1)
    goal = [("holding", ("cube",)), ("lifted", ("cube",)), ("on", ("cube", "table"))]
    result = simulate(_pick(ur5e, centre, close), scene([cube], table=TABLE, goal=goal))
    state = result.objects["cube"]
    assert state["held"] is close and state["lifted"] is close
    # closed: it went up with the gripper (20 cm); open: the fingers passed round it and left it there
    assert (state["displacement"] > 0.15) if close else (state["displacement"] < 0.01)
    assert result.facts == {"(holding cube)": close, "(lifted cube)": close, "(on cube table)": None}
    assert any(n.startswith("(on cube table): the simulation cannot judge") for n in result.notes)
    assert result.contacts == []  # the cube is a target, the table untouched


def test_a_point_is_visited_when_the_simulated_tool_comes_to_it(ur5e):
    """A scene object that is only a point (a target pose, no shape): ``(visited t)`` is whether the
    simulated tool point came within 5 mm of it; a point the tool passed 3 cm from is not visited."""
    down = np.array([0.0, 1.0, 0.0, 0.0])
    q0 = ur5e.ik([-0.45, -0.25, 0.2], down, q_seed=ur5e.home)
    demo = sweep(q0, 0, 0.5, 1.0, n=101)
    path = (ur5e.link_frames(demo["joints"])[:, -1] @ ur5e.gripper_.tool())[:, :3, 3]
    on = SceneObject("t1", "target", position=path[70], orientation=down)
    off = SceneObject("t2", "target", position=path[30] + [0.0, 0.0, 0.03], orientation=down)
    goal = [("visited", ("t1",)), ("reached", ("t2",))]
    result = simulate(demo, scene([on, off], table=TABLE, goal=goal))
    assert result.facts == {"(visited t1)": True, "(reached t2)": False}
    assert not any("cannot judge" in n for n in result.notes)
