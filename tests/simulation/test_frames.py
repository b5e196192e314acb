"""Where a skill's goal is kept, chosen from its demonstrations alone (no robosuite needed).

Synthetic skills with a known answer: a lift ends at a height above where the cube was, a placement
in a fixed bin at one place in the world, a grasp of a cube at its faces (a quarter-turn symmetry),
and a carry holds the wrist as it was.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from skillbank.core import Demonstration
from skillbank.selection import acted_on
from skillbank.simulation._evaluate import _choose_frames, _held_until, _Segment, _slack, _Source

DOWN = np.array([1.0, 0.0, 0.0, 0.0])  # the tool pointing down (x, y, z, w)


def _yawed(q, angle):
    turn = np.array([0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2)])
    x1, y1, z1, w1 = turn
    x2, y2, z2, w2 = q
    return np.array([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2])


def _primitive(tool, cube, tool_yaw, cube_yaw, cluster, from_yaw=None):
    """``from_yaw``: the wrist turns from this heading to ``tool_yaw`` in the first third (a reach)."""
    n = len(tool)
    t = np.linspace(0.0, 2.0, n)
    yaw = np.full(n, tool_yaw) if from_yaw is None else \
        from_yaw + np.clip(np.linspace(0.0, 3.0, n), 0, 1) * (tool_yaw - from_yaw)
    demo = Demonstration(t, {"position": tool, "orientation": np.array([_yawed(DOWN, a) for a in yaw]),
                             "cube_pos": cube, "cube_quat": np.tile(_yawed([0, 0, 0, 1.0], cube_yaw), (n, 1)),
                             "actions": np.zeros((n, 7))})
    return SimpleNamespace(demo=demo, cluster=cluster, id=cluster, start=0, stop=n)


def _sources(rng, carry_to):
    sources = []
    for k in range(8):
        cube = np.r_[rng.uniform(-0.1, 0.1, 2), 0.82]
        cube_yaw = rng.uniform(-math.pi, math.pi)
        grasp_yaw = cube_yaw + rng.integers(0, 4) * math.pi / 2 + rng.normal(0, 0.01)  # at a face
        s = np.linspace(0.0, 1.0, 30)[:, None]
        start = np.array([-0.2, 0.0, 1.0])
        reach = start + s * (cube + [0, 0, 0.005] - start)
        end = cube + [0, 0, 0.15] if carry_to is None else np.asarray(carry_to)
        tool = cube + [0, 0, 0.005] + s * (end - cube)
        src = _Source(k, {"cube": cube}, None)
        for prim in (_primitive(reach, np.tile(cube, (30, 1)), grasp_yaw, cube_yaw, 0, from_yaw=0.0),
                     _primitive(tool, tool - [0, 0, 0.005], grasp_yaw, cube_yaw, 1)):
            relation = acted_on(prim.demo)
            src.segments.append(_Segment(prim, relation, ("world",)))
        sources.append(src)
    _choose_frames(sources)
    return sources


def test_a_lift_is_kept_above_where_the_cube_was_and_a_grasp_at_its_faces():
    reach, lift = _sources(np.random.default_rng(0), None)[0].segments
    assert reach.relation.object == "cube" and not reach.relation.moves_with
    assert reach.frame == ("cube", "end") and reach.turn == ("cube", "end") and reach.symmetry == 4
    assert lift.relation.moves_with and lift.frame == ("cube", "start")
    assert lift.turn == "held" and lift.symmetry == 1  # the wrist stays as it grasped


def test_a_placement_at_a_fixed_place_is_kept_in_the_world():
    _, carry = _sources(np.random.default_rng(1), [0.1, 0.3, 0.95])[0].segments
    assert carry.relation.moves_with and carry.frame == ("world",)


def test_a_place_is_judged_where_the_object_was_let_go_though_it_crept_in_the_fingers():
    # a can slides by two centimetres in the fingers over the carry: held as it was grasped only for the
    # first samples, near where each was picked up; let go at one place of a bin in every member
    rng = np.random.default_rng(3)
    sources = []
    for k in range(8):
        can = np.r_[rng.uniform(-0.1, 0.1, 2), 0.82]
        s = np.linspace(0.0, 1.0, 40)[:, None]
        drop = np.array([0.1, 0.3, 0.95]) + rng.normal(0, 0.003, 3)
        tool = can + [0, 0, 0.005] + s * (drop - can)
        held = tool - [0, 0, 0.005] - s * [0.0, 0.0, 0.02]  # creeping down in the fingers
        prim = _primitive(tool, held, 0.0, 0.0, 1)
        prim.demo["actions"][:, 6] = np.where(np.arange(40) < 37, 1.0, -1.0)  # let go at the end
        src = _Source(k, {"cube": can}, None)
        src.segments.append(_Segment(prim, acted_on(prim.demo), ("world",), released=True))
        sources.append(src)
    _choose_frames(sources)
    carry = sources[0].segments[0]
    assert carry.relation.moves_with and _held_until(carry.primitive.demo, "cube") < 20
    assert carry.frame == ("world",)
    # and a move planned with the can in the hand keeps it as much clearer as it crept until let go
    assert _slack(carry.primitive.demo, "cube") == pytest.approx(0.02 * 37 / 39)  # to the let-go, sample 37


def test_the_parts_of_a_task_run_in_the_order_named():
    from skillbank.simulation._evaluate import _order

    groups = {("Can",): [], ("Milk",): [], ("Bread",): []}
    # none given: as the demonstrations show them (the parts in the order they first appear)
    assert _order(groups, None) == [("Can",), ("Milk",), ("Bread",)]
    assert _order(groups, ["Milk", "Can", "Bread"]) == [("Milk",), ("Can",), ("Bread",)]
    with pytest.raises(ValueError, match=r"order: the library's demonstrations move no object \['Cereal'\]"):
        _order(groups, ["Milk", "Cereal"])
    with pytest.raises(ValueError, match=r"order: it leaves out \['Bread'\]; name every object"):
        _order(groups, ["Milk", "Can"])
    with pytest.raises(ValueError, match=r"order: expected a list of object names"):
        _order(groups, "Milk")


@pytest.mark.parametrize(("heading", "turns_with", "side"), [(0.0, True, 1.0), (math.pi, True, -1.0),
                                                            (math.pi, False, 1.0)])
def test_a_grasp_turned_by_the_objects_symmetry_is_made_from_the_other_side(heading, turns_with, side):
    """A thin box grasped 1 cm off its centre along its y, the wrist at the box's heading; its grasps
    agree up to a half turn. A tool that is turned half round now takes the half-turned grasp: when the
    symmetry is the object's, its goal is 1 cm off the centre on the other side, as the demonstration's
    grasp is on the turned box; when it is the gripper's (a handle taken either way round), the same
    place."""
    from skillbank.simulation._evaluate import _goal

    box = np.array([0.1, -0.3, 0.9])
    n = 20
    tool = box + [0.0, 0.01, 0.02] + np.linspace(0.1, 0.0, n)[:, None] * [0.0, 0.0, 1.0]
    prim = _primitive(tool, np.tile(box, (n, 1)), 0.0, 0.0, 0)
    seg = _Segment(prim, acted_on(prim.demo), ("cube", "end"), ("cube", "end"), 2, turns_with)
    here = _yawed(DOWN, heading + 0.1)
    obs = {"robot0_eef_quat": here, "robot0_eef_pos": box + [0, 0, 0.2], "cube_pos": box,
           "cube_quat": np.array([0.0, 0.0, 0.0, 1.0])}
    p, q = _goal(seg, obs)
    np.testing.assert_allclose(p, box + [0.0, 0.01 * side, 0.02], atol=1e-9)
    assert abs(abs(float(np.dot(q, _yawed(DOWN, heading)))) - 1.0) < 1e-9


def test_a_primitive_of_a_few_samples_is_adapted_with_one_pin_per_sample():
    """Six samples: the leaving and closing-in phases (0.125 ... 0.875) fall two to a sample and on the
    start; the path is still adapted, from where the tool is to the goal."""
    from skillbank.simulation._evaluate import _path_adapted

    box = np.array([0.1, -0.3, 0.9])
    n = 6
    tool = box + [0.0, 0.0, 0.02] + np.linspace(0.1, 0.0, n)[:, None] * [0.0, 0.0, 1.0]
    prim = _primitive(tool, np.tile(box, (n, 1)), 0.0, 0.0, 0)
    seg = _Segment(prim, acted_on(prim.demo), ("cube", "end"), ("cube", "end"), 1)
    here = box + [0.05, 0.0, 0.15]
    obs = {"robot0_eef_quat": DOWN, "robot0_eef_pos": here, "cube_pos": box + [0.02, 0.0, 0.0],
           "cube_quat": np.array([0.0, 0.0, 0.0, 1.0])}
    P, Q, G = _path_adapted(seg, obs, "lte", 0)
    np.testing.assert_allclose(P[0], here, atol=1e-6)
    np.testing.assert_allclose(P[-1], box + [0.02, 0.0, 0.02], atol=1e-6)


@pytest.mark.parametrize(("place", "expected"), [("turns", True), ("stays", False), ("centre", True)])
def test_whether_a_symmetric_grasp_turns_with_the_object_is_read_from_the_demonstrations(place, expected):
    """Eight grasps, each from one of two sides (a half turn) of an object placed at its own heading:
    where the tool's place on the object turns with the side (a box), the symmetry is the object's; where
    it stays (a nut's handle, taken with the fingers either way round), the gripper's; where the grasps
    are at the centre, a few millimetres apart, the demonstrations cannot tell, and the place turns with
    the approach, which is turned with the tool."""
    rng = np.random.default_rng(3)
    sources = []
    for k in range(8):
        cube = np.r_[rng.uniform(-0.1, 0.1, 2), 0.82]
        cube_yaw = rng.uniform(-math.pi, math.pi)
        side = int(rng.integers(0, 2)) if k > 1 else k  # both sides among them
        local = np.array([0.06, 0.0, 0.02]) if place != "centre" else \
            np.r_[rng.normal(0.0, 0.003, 2), 0.02]
        if place == "turns" and side:
            local = local * [-1, -1, 1]
        c, s = math.cos(cube_yaw), math.sin(cube_yaw)
        end = cube + np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]]) @ local
        n = 20
        tool = end + np.linspace(0.1, 0.0, n)[:, None] * [0.0, 0.0, 1.0]
        prim = _primitive(tool, np.tile(cube, (n, 1)), cube_yaw + side * math.pi + rng.normal(0, 0.01),
                          cube_yaw, 0, from_yaw=0.0)
        src = _Source(k, {"cube": cube}, None)
        src.segments.append(_Segment(prim, acted_on(prim.demo), ("world",)))
        sources.append(src)
    _choose_frames(sources)
    seg = sources[0].segments[0]
    assert (seg.frame, seg.turn, seg.symmetry) == (("cube", "end"), ("cube", "end"), 2)
    assert all(src.segments[0].turns_with is expected for src in sources)


def test_pieces_of_one_halting_approach_keep_the_objects_frame():
    """Issue 42: a person's approach to one cube, cut at its pauses into four pieces of one skill, the cube
    settling by a millimetre meanwhile. Their ends spread a little less in the world than in the cube's
    frame (the settling), but the cube's frame and the world's are one frame shifted: the data cannot tell
    them apart, and the relation's own frame, the cube's, is kept. Eight demonstrations of the same pieces
    with the cube placed anew each time do tell them apart."""
    def pieces(cube, settle):
        src, start = _Source(0, {"cube": cube}, None), np.array([-0.2, 0.0, 1.0])
        for k, stop in enumerate((0.146, 0.038, 0.007, 0.001)):  # each piece ends nearer the cube
            s = np.linspace(0.0, 1.0, 20)[:, None]
            end = cube + [stop, 0.0, 0.005]
            tool = start + s * (end - start)
            at = np.tile(cube + [0.0, 0.0, -settle * k / 3], (20, 1))  # settling as the hand comes
            prim = _primitive(tool, at, 0.0, 0.0, 0)
            src.segments.append(_Segment(prim, acted_on(prim.demo), ("world",)))
            start = end
        return src

    one = [pieces(np.array([0.0, 0.0, 0.82]), 0.0013)]
    _choose_frames(one)
    near = [seg for seg in one[0].segments if seg.relation is not None]
    assert near and all(seg.frame == ("cube", "end") for seg in near)
    rng = np.random.default_rng(4)
    many = [pieces(np.r_[rng.uniform(-0.1, 0.1, 2), 0.82], 0.0013) for _ in range(8)]
    _choose_frames(many)
    # placed anew, the cube's frame is told apart from the world's, and the ends agree in the cube's
    assert all(seg.frame == ("cube", "end") for src in many for seg in src.segments if seg.relation)


def test_one_demonstration_grasps_on_the_object_and_places_on_the_fixture_as_it_showed():
    """One demonstration teaches no symmetry: its grasp keeps the tool's orientation on the object
    (MimicGen's transform), its place on what the scene holds fixed keeps the object's orientation in the
    world, and a lift keeps the wrist as it was; the turns either may take are the scene's to say
    (``_in_scene``, tests/simulation/test_support.py)."""
    rng = np.random.default_rng(5)
    (one,) = [_sources(rng, [0.1, 0.3, 0.95])[0]]
    reach, carry = one.segments
    for seg in (reach, carry):
        seg.frame, seg.turn, seg.symmetry = ("world",), "held", 1
    carry.released = True  # it let the cube go at the fixed place
    _choose_frames([one])
    assert (reach.frame, reach.turn, reach.symmetry) == (("cube", "end"), ("cube", "end"), 1)
    assert (carry.frame, carry.turn, carry.symmetry) == (("world",), ("world",), 1)
    (lift_source,) = [_sources(np.random.default_rng(6), None)[0]]
    lift = lift_source.segments[1]
    lift.turn = "held"
    _choose_frames([lift_source])
    assert lift.frame == ("cube", "start") and lift.turn == "held"


def test_a_place_turns_the_tool_so_the_object_ends_as_it_did_whatever_the_grasp():
    """The cube held a quarter turn round from the demonstration's grasp: the tool's goal turns so that
    the cube's orientation at its place is the demonstration's, and the carried cube, not the tool,
    follows the demonstration's path (the tool's path is the cube's less where the tool holds it now)."""
    from skillbank.simulation._evaluate import _carried_path, _goal_orientations

    n = 30
    cube0, place = np.array([0.0, 0.0, 0.83]), np.array([0.2, 0.1, 0.9])
    s = np.linspace(0.0, 1.0, n)[:, None]
    cube = cube0 + s * (place - cube0)
    tool = cube + [0.0, 0.0, 0.01]  # held at its centre, the wrist at the cube's heading (0)
    prim = _primitive(tool, cube, 0.0, 0.0, 0)
    seg = _Segment(prim, acted_on(prim.demo), ("world",), ("world",), 1, released=True)
    # now: the cube at heading 0.3 rad, the tool a quarter turn further round, 2 cm off the centre
    cube_q = _yawed([0.0, 0.0, 0.0, 1.0], 0.3)
    here_q = _yawed(DOWN, 0.3 + math.pi / 2)
    here_p = np.array([-0.1, 0.1, 0.85])
    obs = {"robot0_eef_pos": here_p, "robot0_eef_quat": here_q, "cube_pos": here_p + [0.02, 0.0, -0.01],
           "cube_quat": cube_q}
    ((q, _),) = _goal_orientations(seg, obs)
    # the tool turns by -0.3 rad: the cube, turned with it, ends at heading 0
    np.testing.assert_allclose(abs(float(np.dot(q, _yawed(DOWN, math.pi / 2)))), 1.0, atol=1e-9)
    path = _carried_path(seg, obs, prim.demo, q)
    from skillbank.core._rotations import quaternion_to_matrix

    held = quaternion_to_matrix(here_q).T @ (obs["cube_pos"] - here_p)
    np.testing.assert_allclose(path[-1] + quaternion_to_matrix(q) @ held, place, atol=1e-9)
    np.testing.assert_allclose(path[0] + quaternion_to_matrix(_yawed(DOWN, math.pi / 2)) @ held, cube0,
                               atol=1e-9)


def test_a_carry_is_aimed_again_from_where_the_object_sits_in_the_hand_before_letting_go():
    """The cube slid 1 cm in the fingers on the way: at the release, the tool's last stretch is shifted so
    that the cube, not the tool, comes down where the path meant to let it go (planned with the cube 1 cm
    below the tool); the wrist's turn at the release turns where the path meant it with it."""
    from skillbank.simulation._evaluate import _aimed

    place = np.array([0.2, 0.1, 0.9])
    held = np.array([0.0, 0.0, 0.01])  # 1 cm below the tool pointing down (its z is the world's -z)
    tool = place + [0.0, 0.0, 0.05]  # on its way down, 4 cm above where it lets go
    p = place + [0.0, 0.0, 0.01]  # the path's release point
    obs = {"robot0_eef_pos": tool, "robot0_eef_quat": DOWN, "cube_pos": tool + [0.01, 0.0, -0.01]}
    np.testing.assert_allclose(_aimed(obs, "cube", held, p, DOWN), [-0.01, 0.0, 0.0], atol=1e-12)
    obs["cube_pos"] = tool + [0.0, 0.0, -0.01]  # where the plan had it: no shift
    np.testing.assert_allclose(_aimed(obs, "cube", held, p, DOWN), 0.0, atol=1e-12)
    # held 2 cm along the tool's x, the release a quarter turn round: the path meant it 2 cm along y
    side = np.array([0.02, 0.0, 0.0])
    obs["cube_pos"] = tool + [0.0, 0.02, 0.0]  # already turned as the path turns it
    np.testing.assert_allclose(_aimed(obs, "cube", side, p, _yawed(DOWN, math.pi / 2)), 0.0, atol=1e-12)


@pytest.mark.parametrize(("offset", "pad", "expected"), [(0.0275, 0.01, 0.01), (0.0275, 0.008, 0.012),
                                                         (0.005, 0.01, 0.005), (-0.03, 0.01, -0.01),
                                                         (0.02, 0.025, 0.0)])
def test_a_grasp_across_the_closing_axis_keeps_the_executing_pads_on_the_face(offset, pad, expected):
    """A cube of 2 cm half sides grasped ``offset`` off its centre across the closing axis (the tool's
    x; the fingers close along y): the goal keeps the offset as far as pads of half width ``pad`` still
    cover the face, centres a face narrower than a pad, and never moves along the closing axis."""
    from skillbank.simulation._evaluate import _Fingers, _on_pads

    box = np.array([0.1, -0.3, 0.82])
    n = 10
    tool = box + [offset, 0.004, 0.0] + np.linspace(0.1, 0.0, n)[:, None] * [0.0, 0.0, 1.0]
    prim = _primitive(tool, np.tile(box, (n, 1)), 0.0, 0.0, 0)
    prim.demo["actions"][-1, 6] = 1.0  # it closes on the cube at its end
    seg = _Segment(prim, acted_on(prim.demo), ("cube", "end"), ("cube", "end"), 1)
    obs = {"cube_pos": box, "cube_quat": np.array([0.0, 0.0, 0.0, 1.0])}
    fingers = _Fingers(np.array([0.0, 1.0, 0.0]), 0.04, pad, {"cube": np.full(3, 0.02)})
    p = _on_pads(seg, obs, tool[-1], DOWN, fingers)
    np.testing.assert_allclose(p - box, [expected, 0.004, 0.0], atol=1e-12)
    carry = _Segment(prim, acted_on(prim.demo), ("cube", "end"), ("cube", "end"), 1)
    carry.primitive.demo["actions"][-1, 6] = -1.0  # a reach that does not close: left as it is
    np.testing.assert_allclose(_on_pads(carry, obs, tool[-1], DOWN, fingers), tool[-1])


def test_a_reach_is_kept_relative_to_where_the_object_stood_not_where_the_fingers_pushed_it():
    """A reach for a milk carton: it settles 4 mm at reset, stands while the hand comes down over its
    centre, and the closing fingers push it 1 cm. Kept relative to where the carton ended, the way down
    lands a centimetre off where a carton stands in a new scene (on its top edge: it topples); kept
    relative to where it stood, the hand comes down over its centre as the demonstration's did."""
    from skillbank.simulation._evaluate import _goal_position, _source_frame

    n = 60
    t = np.linspace(0.0, 3.0, n)
    stood = np.array([0.05, -0.36, 0.88])
    carton = np.tile(stood, (n, 1))
    carton[:5, 2] += np.linspace(0.004, 0.0, 5)  # settling at reset
    carton[50:] += np.linspace(0.0, 1.0, 10)[:, None] * [0.01, 0.0, 0.0]  # pushed as the fingers close
    tool = stood + np.c_[np.zeros(n), np.zeros(n), np.linspace(0.2, 0.02, n)]
    tool[50:] += np.linspace(0.0, 1.0, 10)[:, None] * [0.005, 0.0, 0.0]
    demo = Demonstration(t, {"position": tool, "orientation": np.tile(DOWN, (n, 1)), "Milk_pos": carton,
                             "Milk_quat": np.tile([0, 0, 0, 1.0], (n, 1)), "actions": np.zeros((n, 7))})
    relation = acted_on(demo)
    assert relation.object == "Milk" and not relation.moves_with
    np.testing.assert_allclose(_source_frame(demo, relation, ("Milk", "end"))[0], stood, atol=1e-9)
    seg = _Segment(SimpleNamespace(demo=demo, cluster=0, id=0), relation, ("Milk", "end"))
    there = np.array([0.2, -0.1, 0.88])
    obs = {"Milk_pos": there, "Milk_quat": np.array([0, 0, 0, 1.0]), "robot0_eef_pos": there + [0, 0, 0.3],
           "robot0_eef_quat": DOWN}
    # the tool ends where the demonstration's did relative to the carton as it stood: 5 mm past its centre
    np.testing.assert_allclose(_goal_position(seg, obs, DOWN), there + [0.005, 0.0, 0.02], atol=1e-9)


@pytest.mark.parametrize("heading, spans", [(0.0, True), (math.pi / 2, False), (math.pi, True)])
def test_a_grasp_closes_only_across_a_side_the_open_fingers_span(heading, spans):
    """A cereal box 10 cm by 3 cm: the fingers (9.5 cm apart when open) close across its 3 cm side; a
    goal turned a quarter round, which headings agreeing at quarter turns offer, closes them across the
    10 cm side, and is not a grasp."""
    from skillbank.simulation._evaluate import _Fingers, _spans

    t = np.linspace(0.0, 1.0, 5)
    actions = np.zeros((5, 7))
    actions[:, 6] = 1.0  # the reach ends closing the gripper
    demo = Demonstration(t, {"position": np.zeros((5, 3)), "orientation": np.tile(DOWN, (5, 1)),
                             "box_pos": np.zeros((5, 3)), "box_quat": np.tile([0, 0, 0, 1.0], (5, 1)),
                             "actions": actions})
    seg = _Segment(SimpleNamespace(demo=demo), acted_on(demo), ("box", "end"))
    fingers = _Fingers(axis=np.array([0.0, 1.0, 0.0]), half=0.0475, pad=0.01,
                       extents={"box": np.array([0.05, 0.015, 0.075])})
    obs = {"box_quat": np.array([0.0, 0.0, 0.0, 1.0])}
    # the tool pointing down with its closing axis along the box's y (its 3 cm side), turned by heading
    assert _spans(seg, obs, _yawed(DOWN, heading), fingers) is spans
