"""The whole-arm clearance: against a plain per-sample loop, against MuJoCo's own distance, known answers."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize, minimize_scalar

from skillbank.core import Box, Sphere
from skillbank.robots import UR5e, clearance, robot_model
from skillbank.robots._clearance import segment_box_distance, segment_distance

ROBOT = UR5e()


# ------------------------------------------------------------ the reference: one sample, one pair at a time

def _ends(frames, capsule):
    F = frames[capsule.frame]
    return F[:3, :3] @ np.asarray(capsule.a) + F[:3, 3], F[:3, :3] @ np.asarray(capsule.b) + F[:3, 3]


def _sdf_box(p, lower, upper):
    q = np.maximum(lower - p, p - upper)
    return float(np.linalg.norm(np.maximum(q, 0.0)) + min(q.max(), 0.0))


def _segment_box(a, b, box):
    """Convex along the segment: a bounded scalar minimisation and both ends."""
    def f(s):
        return _sdf_box(a + s * (b - a), box.lower, box.upper)
    found = minimize_scalar(f, bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-12})
    return min(found.fun, f(0.0), f(1.0))


def _segment_point(a, b, p):
    v = b - a
    vv = float(v @ v)
    s = 0.0 if vv == 0.0 else float(np.clip((p - a) @ v / vv, 0.0, 1.0))
    return float(np.linalg.norm(a + s * v - p))


def _segment_segment(a, b, c, d):
    """The distance is convex in (s, t): a bounded minimisation from the middle, and the four corners'
    closest points (each a point-to-segment distance)."""
    def f(x):
        return float(np.linalg.norm(a + x[0] * (b - a) - c - x[1] * (d - c)))
    found = minimize(f, [0.5, 0.5], bounds=[(0, 1), (0, 1)], method="L-BFGS-B",
                     options={"ftol": 1e-15, "gtol": 1e-12})
    return min(found.fun, _segment_point(c, d, a), _segment_point(c, d, b), _segment_point(a, b, c),
               _segment_point(a, b, d))


def reference(model, joints, obstacles, table=None, workspace=None, self_collision=True):
    """Per sample, per pair: ``{(body, other): distance}`` for each sample (a list)."""
    out = []
    bodies = model.bodies
    names = dict(enumerate(c.name for c in bodies))
    for q in np.atleast_2d(joints):
        frames = model.link_frames(q)[0]
        row = {}
        for k, capsule in enumerate(bodies):
            a, b = _ends(frames, capsule)
            for name, o in obstacles.items():
                if isinstance(o, Sphere):
                    row[names[k], name] = _segment_point(a, b, o.center) - capsule.radius - o.radius
                else:
                    row[names[k], name] = _segment_box(a, b, o) - capsule.radius
            if table is not None and capsule.frame != 0:
                row[names[k], "table"] = _segment_box(a, b, table) - capsule.radius
            if workspace is not None:
                lower, upper = (np.asarray(x) for x in workspace)
                row[names[k], "workspace"] = min(min((p - lower).min(), (upper - p).min()) for p in (a, b)) \
                    - capsule.radius
        if self_collision:
            by_name = {c.name: c for c in bodies}
            for one, two in model.self_collision_pairs():
                c1, c2 = by_name[one], by_name[two]
                gap = _segment_segment(*_ends(frames, c1), *_ends(frames, c2))
                row[one, two] = gap - c1.radius - c2.radius
        out.append(row)
    return out


NO_DENSIFY = 1e6  # max_move (m): larger than any body's motion, so only the caller's samples are checked

coordinate = st.floats(-0.9, 0.9)
spheres = st.builds(lambda x, y, z, r: Sphere([x, y, z], r), coordinate, coordinate, coordinate,
                    st.floats(0.01, 0.3))
boxes = st.builds(lambda x, y, z, w, d, h: Box([x, y, z], [x + w, y + d, z + h]),
                  coordinate, coordinate, coordinate,
                  st.floats(0.005, 0.6), st.floats(0.005, 0.6), st.floats(0.005, 0.6))


@settings(max_examples=25, deadline=None)
@given(q=st.lists(st.lists(st.floats(-np.pi, np.pi), min_size=6, max_size=6), min_size=1, max_size=3),
       obstacles=st.lists(st.one_of(spheres, boxes), max_size=3), with_table=st.booleans(),
       with_workspace=st.booleans())
def test_vectorised_equals_the_per_sample_loop(q, obstacles, with_table, with_workspace):
    named = {f"o{k}": o for k, o in enumerate(obstacles)}
    table = Box([-2.0, -2.0, -0.1], [2.0, 2.0, 0.0]) if with_table else None
    workspace = ([-0.8, -0.9, -0.2], [0.7, 0.8, 1.2]) if with_workspace else None
    result = clearance(ROBOT, q, named, table=table, workspace=workspace, max_move=NO_DENSIFY)
    expected = reference(ROBOT, q, named, table, workspace)
    assert set(result.per_pair) == set(expected[0])
    for pair, value in result.per_pair.items():
        assert value == pytest.approx(min(row[pair] for row in expected), abs=1e-7), pair
    np.testing.assert_allclose(result.distance, [min(row.values()) for row in expected], atol=1e-7)
    k = result.index
    assert expected[k][result.body, result.other] == pytest.approx(result.min_distance, abs=1e-7)


@settings(max_examples=200, deadline=None)
@given(points=st.lists(st.floats(-1.0, 1.0), min_size=12, max_size=12), flat=st.integers(0, 4))
def test_segment_distances_equal_the_minimisation(points, flat):
    a, b, c, d = np.reshape(points, (4, 3))
    if flat == 1:
        b = a.copy()  # a point
    elif flat == 2:
        d = c + 0.7 * (b - a)  # parallel
    box = Box(np.minimum(c, d) - 0.01, np.maximum(c, d) + 0.01)
    assert float(segment_distance(a, b, c, d)) == pytest.approx(_segment_segment(a, b, c, d), abs=1e-7)
    # exact: never above what the minimiser finds (a point's distance), and below it by its tolerance
    ours, found = float(segment_box_distance(a, b, box.lower, box.upper)), _segment_box(a, b, box)
    assert found - 1e-7 <= ours <= found + 1e-12


# ------------------------------------------------------------------ against MuJoCo's own distance

def test_distances_equal_mujocos_on_the_same_geometry():
    mujoco = pytest.importorskip("mujoco")  # the sim extra: its own distance between the same geoms
    rng = np.random.default_rng(4)
    obstacles = {"ball": Sphere([0.3, -0.3, 0.4], 0.08), "wall": Box([-0.5, 0.2, 0.0], [-0.1, 0.3, 0.7]),
                 "post": Box([0.2, 0.25, 0.0], [0.3, 0.35, 0.9])}
    checked = 0
    for q in rng.uniform(-np.pi, np.pi, (6, 6)):
        frames = ROBOT.link_frames(q)[0]
        geoms = []
        for c in ROBOT.bodies:
            a, b = _ends(frames, c)
            geoms.append(f'<geom name="{c.name}" type="capsule" size="{c.radius!r}" '
                         f'fromto="{" ".join(repr(float(x)) for x in (*a, *b))}"/>')
        for name, o in obstacles.items():
            if isinstance(o, Sphere):
                geoms.append(f'<geom name="{name}" type="sphere" size="{o.radius!r}" '
                             f'pos="{" ".join(map(repr, o.center.tolist()))}"/>')
            else:
                centre, half = (o.lower + o.upper) / 2, (o.upper - o.lower) / 2
                geoms.append(f'<geom name="{name}" type="box" size="{" ".join(map(repr, half.tolist()))}" '
                             f'pos="{" ".join(map(repr, centre.tolist()))}"/>')
        model = mujoco.MjModel.from_xml_string(f"<mujoco><worldbody>{''.join(geoms)}</worldbody></mujoco>")
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        result = clearance(ROBOT, q, obstacles, max_move=NO_DENSIFY)
        for (body, other), ours in result.per_pair.items():
            g1, g2 = model.geom(body).id, model.geom(other).id
            theirs = mujoco.mj_geomDistance(model, data, g1, g2, 10.0, None)
            if ours > 0 and theirs > 0:
                assert ours == pytest.approx(theirs, abs=1e-6), (body, other, q)
                checked += 1
            else:  # both say they overlap
                assert ours < 1e-6 and theirs < 1e-6, (body, other, ours, theirs)
    assert checked > 100


# ------------------------------------------------------------------ known answers

def _forearm_at_home():
    capsule = next(c for c in ROBOT.bodies if c.name == "forearm")
    return capsule, *_ends(ROBOT.link_frames(ROBOT.home)[0], capsule)


def test_a_sphere_at_a_known_distance_above_the_forearm():
    capsule, a, b = _forearm_at_home()
    assert abs(a[2] - b[2]) < 1e-12  # at home the forearm is level: straight up is across it
    centre = (a + b) / 2 + [0.0, 0.0, capsule.radius + 0.05 + 0.07]
    result = clearance(ROBOT, ROBOT.home, {"ball": Sphere(centre, 0.05)}, self_collision=False)
    assert (result.body, result.other) == ("forearm", "ball")
    assert result.min_distance == pytest.approx(0.07, abs=1e-12)
    assert not result.collides(margin=0.07 - 1e-9) and result.collides(margin=0.07 + 1e-9)


def test_a_box_the_upper_arm_passes_through():
    # at home the upper arm stands upright at x = 0, y = -0.129; a 2 cm plate across it
    wall = Box([-0.01, -0.3, 0.3], [0.01, 0.1, 0.35])
    result = clearance(ROBOT, ROBOT.home, {"plate": wall}, self_collision=False)
    assert result.per_pair["upper_arm", "plate"] == pytest.approx(-0.01 - 0.092, abs=1e-12)
    assert result.collides() and result.first_contact() == (0, "upper_arm", "plate")


def test_the_table_with_the_arm_folded_down_into_it_and_the_base_standing_on_it():
    table = Box([-2.0, -2.0, -0.05], [2.0, 2.0, 0.0])
    home = clearance(ROBOT, ROBOT.home, table=table, self_collision=False)
    assert ("base", "table") not in home.per_pair  # mounted on it
    flange_z = ROBOT.link_frames(ROBOT.home)[0, -1, 2, 3]
    # at home the fingers' capsules end 0.128 + 0.044 m below the flange, pointing down
    assert home.per_pair["finger_left", "table"] == pytest.approx(flange_z - 0.128 - 0.044, abs=1e-12)
    # the lowest body: the shoulder, its capsule 0.1565 - 0.085 m above the table whatever the joints
    assert (home.body, home.other) == ("shoulder", "table")
    assert home.min_distance == pytest.approx(0.1625 - 0.006 - 0.085, abs=1e-12)
    down = [0.0, 0.0, 1.5, 0.0, -1.57, 0.0]  # upper arm level, forearm straight down through the table
    result = clearance(ROBOT, [ROBOT.home, down], table=table, self_collision=False, t=[0.0, 1.0])
    assert result.collides() and result.first_contact()[2] == "table" and result.index == 1
    assert result.time == pytest.approx(1.0, abs=0.5)


def test_a_workspace_bound_that_cuts_the_wrist():
    lower, upper = np.array([-0.45, -1.0, -1.0]), np.array([1.0, 1.0, 1.5])
    result = clearance(ROBOT, ROBOT.home, workspace=(lower, upper), self_collision=False)
    frames = ROBOT.link_frames(ROBOT.home)[0]
    expected = {c.name: min(p[0] - lower[0] for p in _ends(frames, c)) - c.radius for c in ROBOT.bodies
                if min(p[0] for p in _ends(frames, c)) - c.radius < lower[0]}
    assert {"wrist_1", "wrist_2", "wrist_3", "gripper_body", "finger_left", "finger_right"} <= set(expected)
    for name, value in expected.items():
        assert result.per_pair[name, "workspace"] == pytest.approx(value, abs=1e-12)
    assert result.body == "finger_left" and result.min_distance == pytest.approx(min(expected.values()))
    inside = clearance(ROBOT, ROBOT.home, workspace=([-1.0, -1.0, -0.2], [1.0, 1.0, 1.5]),
                       self_collision=False)
    assert not inside.collides()


def test_folding_the_wrist_into_the_upper_arm_is_a_self_collision():
    folded = [0.0, -np.pi / 2, 2.9, 0.0, 0.0, 0.0]  # elbow nearly closed: the wrist comes down the upper arm
    result = clearance(ROBOT, [ROBOT.home, folded])
    assert result.collides() and result.index == 1 and result.body == "upper_arm"
    assert result.other in ("wrist_1", "wrist_2", "wrist_3", "gripper_body", "finger_left", "finger_right")
    assert not clearance(ROBOT, ROBOT.home).collides()
    assert clearance(ROBOT, folded, self_collision=False, workspace=([-2] * 3, [2] * 3)).min_distance > 0


def test_a_thin_wall_jumped_over_between_two_samples_is_caught_by_densifying():
    # the base turns by 2 rad between two samples; a 2 mm plate stands where the forearm is half-way
    start, end = np.array(ROBOT.home), np.array(ROBOT.home) + [2.0, 0, 0, 0, 0, 0]
    capsule, a, b = _forearm_at_home()
    turn = 1.0
    R = np.array([[np.cos(turn), -np.sin(turn), 0], [np.sin(turn), np.cos(turn), 0], [0, 0, 1]])
    mid = R @ (a + 0.7 * (b - a))  # out along the forearm, beyond the upper arm's reach
    direction = R @ (b - a) / np.linalg.norm(b - a)  # the wall's plane contains the forearm at half-way
    normal = np.cross(direction, [0, 0, 1])
    size = np.abs(direction) * 0.02 + np.abs(normal) * 0.001 + [0, 0, 0.02]
    wall = {"wall": Box(mid - size, mid + size)}
    ends = clearance(ROBOT, [start, end], wall, self_collision=False, max_move=NO_DENSIFY)
    assert not ends.collides()  # neither sample touches it
    swept = clearance(ROBOT, [start, end], wall, self_collision=False, t=[0.0, 2.0])
    assert swept.collides() and swept.body == "forearm" and swept.other == "wall"
    assert swept.n_checked > 2 and swept.time == pytest.approx(1.0, abs=0.05)
    assert swept.index in (0, 1) and swept.first_contact()[1:] == ("forearm", "wall")
    # every configuration in between is within max_move / 2 of a checked one, so the continuous
    # minimum is at least the reported one minus max_move / 2
    fine = clearance(ROBOT, [start, end], wall, self_collision=False, max_move=1e-3)
    assert fine.min_distance >= swept.min_distance - swept.max_move / 2


def test_densified_samples_report_the_callers_indices():
    q = np.array([ROBOT.home] * 3) + np.array([[0.0] * 6, [0.5] + [0.0] * 5, [1.0] + [0.0] * 5])
    result = clearance(ROBOT, q, {"ball": Sphere([0.0, 0.0, 2.0], 0.1)}, t=[0.0, 1.0, 2.0])
    assert result.distance.shape == (3,) and result.pair.shape == (3,) and result.n_checked > 3
    assert 0 <= result.index <= 2 and 0.0 <= result.time <= 2.0


def test_ignore_lets_the_fingers_touch_their_button_and_nothing_else():
    tcp = robot_model("ur5e", tool="tcp").fk(ROBOT.home)[0]
    button = Box(tcp - [0.02, 0.02, 0.03], tcp + [0.02, 0.02, 0.0])  # its top face at the TCP
    other = Sphere(tcp + [0.3, 0.0, 0.0], 0.05)
    pressing = clearance(ROBOT, ROBOT.home, {"b1": button, "ball": other})
    assert pressing.collides() and pressing.other == "b1" and pressing.body.startswith("finger_")
    allowed = [("finger_left", "b1"), ("finger_right", "b1")]
    result = clearance(ROBOT, ROBOT.home, {"b1": button, "ball": other}, ignore=allowed)
    assert ("finger_left", "b1") not in result.per_pair and ("gripper_body", "b1") in result.per_pair
    assert not result.collides()
    assert "finger_left" not in {b for b, _ in clearance(ROBOT, ROBOT.home, ignore=["finger_left"]).per_pair}


def test_to_dict_is_json_and_names_the_limiting_pair():
    result = clearance(ROBOT, [ROBOT.home] * 2, [Sphere([0.3, 0.3, 0.3], 0.05)], t=[0.0, 0.5])
    out = json.loads(json.dumps(result.to_dict()))
    assert {"min_distance", "index", "time", "body", "other", "per_pair"} <= set(out)
    assert out["per_pair"][0]["min_distance"] == out["min_distance"]
    assert ("forearm", "obstacles[0]") in result.per_pair
    assert clearance(ROBOT, ROBOT.home).first_contact() is None


@pytest.mark.parametrize(("call", "match"), [
    (lambda: clearance(ROBOT, ROBOT.home, [Sphere([0.0, 0.0], 0.1)]),
     r"obstacles\['obstacles\[0\]'\]: expected a 3-D obstacle \(the robot's world\), got 2-D"),
    (lambda: clearance(ROBOT, np.zeros((4, 5))), r"joints: expected 6 joint values per sample"),
    (lambda: clearance(ROBOT, ROBOT.home, workspace=([0, 0, 0], [1, 0, 1])),
     r"workspace: expected lower < upper in every coordinate, got lower=\[0\.0, 0\.0, 0\.0\] "
     r"upper=\[1\.0, 0\.0, 1\.0\]"),
    (lambda: clearance(ROBOT, ROBOT.home, workspace=([0, 0], [1, 1])),
     r"workspace: expected lower and upper of 3 coordinates each"),
    (lambda: clearance(ROBOT, ROBOT.home, ignore=["gripper"]), r"ignore: unknown body 'gripper'; the robot's "
                                                              r"bodies are \['base', 'shoulder'"),
    (lambda: clearance(ROBOT, ROBOT.home, {"b1": Sphere([0, 0, 1], 0.1)}, ignore=[("finger_left", "b2")]),
     r"ignore: unknown other 'b2' in \('finger_left', 'b2'\)"),
    (lambda: clearance(ROBOT, ROBOT.home, table=Sphere([0, 0, 0], 1.0)),
     r"table: expected a 3-D skillbank.core Box"),
    (lambda: clearance(ROBOT, [ROBOT.home] * 2, t=[0.0]),
     r"t: expected one time per joint sample \(2\), got 1"),
    (lambda: clearance(ROBOT, [ROBOT.home] * 2, t=[1.0, 0.0]), r"t: expected non-decreasing times"),
    (lambda: clearance(ROBOT, ROBOT.home, {"table": Sphere([0, 0, 1], 0.1)}),
     r"the name 'table' is reserved"),
    (lambda: clearance(ROBOT, ROBOT.home, Sphere([0, 0, 1], 0.1)), r"got one obstacle: wrap it in a list"),
    (lambda: clearance(ROBOT, ROBOT.home, max_move=0.0), r"max_move: expected a number > 0"),
    (lambda: clearance(UR5e(gripper="none"), ROBOT.home, self_collision=False),
     r"clearance: nothing to check"),
])
def test_bad_input(call, match):
    with pytest.raises(ValueError, match=match):
        call()
