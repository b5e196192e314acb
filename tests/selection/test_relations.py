"""acted_on: the object a primitive moves with or ends at, from the data, and its end pose in its frame."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.core import exp_map
from skillbank.selection import Relation, acted_on, compose, object_streams

T = np.linspace(0.0, 2.0, 41)
UP = np.tile([0.0, 0.0, 0.0, 1.0], (41, 1))


def _demo(tool, **objects):
    streams = {"position": tool, "orientation": np.tile(exp_map([0.0, np.pi, 0.0]), (len(T), 1))}
    for name, (pos, quat) in objects.items():
        streams[f"{name}_pos"], streams[f"{name}_quat"] = pos, quat
    return Demonstration(T, streams)


def _reach(to):
    s = (T / T[-1])[:, None]
    return np.asarray([0.0, 0.0, 0.4]) + s * (np.asarray(to) - [0.0, 0.0, 0.4])


def test_a_reach_acts_on_the_object_it_ends_nearest_and_composes_back():
    a = np.tile([0.5, 0.1, 0.02], (41, 1))
    b = np.tile([0.5, -0.1, 0.02], (41, 1))
    yaw = exp_map([0.0, 0.0, 0.7])
    r = acted_on(_demo(_reach([0.5, 0.1, 0.03]), a=(a, np.tile(yaw, (41, 1))), b=(b, UP)))
    assert r.object == "a" and not r.moves_with and r.distance == pytest.approx(0.01)
    np.testing.assert_allclose(r.start_position, r.position, atol=1e-12)  # it stood still
    # the tool's end pose, put back on the object's pose, is the tool's end pose
    p, q = compose(r, a[-1], yaw)
    np.testing.assert_allclose(p, [0.5, 0.1, 0.03], atol=1e-12)
    np.testing.assert_allclose(np.abs(q @ exp_map([0.0, np.pi, 0.0])), 1.0, atol=1e-12)
    # and on a new pose of the object, turned and moved, the same grasp relative to it
    new_q = exp_map([0.0, 0.0, -1.2])
    p2, _ = compose(r, [0.2, 0.3, 0.02], new_q)
    np.testing.assert_allclose(p2 - [0.2, 0.3, 0.02], [0.0, 0.0, 0.01], atol=1e-12)


def test_an_object_carried_with_the_tool_wins_over_one_nearer_at_the_end():
    tool = _reach([0.2, 0.0, 0.3])
    carried = tool - [0.0, 0.0, 0.03]  # held 3 cm below the tool all along
    bystander = np.tile([0.2, 0.0, 0.31], (41, 1))  # nearer the tool's end, but still
    r = acted_on(_demo(tool, held=(carried, UP), other=(bystander, UP)))
    assert r.object == "held" and r.moves_with
    np.testing.assert_allclose(r.position, [0.0, 0.0, 0.03], atol=1e-12)
    # relative to where it was picked up: where the carry takes the tool (0.2 m over, 0.1 m down)
    np.testing.assert_allclose(r.start_position, [0.2, 0.0, -0.07], atol=1e-12)
    p, _ = compose(r, [1.0, 1.0, 0.37], [0.0, 0.0, 0.0, 1.0], at="start")  # the same carry elsewhere
    np.testing.assert_allclose(p, [1.2, 1.0, 0.3], atol=1e-12)
    with pytest.raises(ValueError, match=r"at: expected 'end', 'start' or 'target', got 'middle'"):
        compose(r, [1.0, 1.0, 0.37], [0.0, 0.0, 0.0, 1.0], at="middle")


def test_a_carry_knows_where_it_puts_the_object():
    """Carried onto another object: the target is that object, and the tool's end pose on it composes
    back on a new pose of the target (a stack built elsewhere); with no other object near, no target."""
    tool = _reach([0.5, -0.1, 0.1])
    carried = tool - [0.0, 0.0, 0.03]
    base = np.tile([0.5, -0.1, 0.025], (41, 1))  # the carried object ends on it
    r = acted_on(_demo(tool, a=(carried, UP), b=(base, UP)))
    assert r.object == "a" and r.moves_with and r.target == "b"
    np.testing.assert_allclose(r.target_position, [0.0, 0.0, 0.075], atol=1e-12)
    p, _ = compose(r, [0.1, 0.4, 0.025], [0.0, 0.0, 0.0, 1.0], at="target")
    np.testing.assert_allclose(p, [0.1, 0.4, 0.1], atol=1e-12)
    lone = acted_on(_demo(tool, a=(carried, UP)))
    assert lone.moves_with and lone.target is None
    with pytest.raises(ValueError, match=r"at: the relation to 'a' has no target .* use at='start'"):
        compose(lone, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], at="target")


def test_a_move_in_free_space_acts_on_nothing():
    far = np.tile([1.0, 1.0, 0.02], (41, 1))
    assert acted_on(_demo(_reach([0.2, 0.0, 0.3]), box=(far, UP))) is None
    assert acted_on(Demonstration(T, {"position": _reach([0.2, 0.0, 0.3])})) is None  # no objects recorded


def test_a_reach_that_closes_the_gripper_grasps_the_nearest_object_however_far_its_origin():
    # a pot's handle is 17 cm from the pot's origin: the hand ends there and closes
    pot = np.tile([0.5, 0.17, 0.02], (41, 1))
    cube = np.tile([1.0, 1.0, 0.02], (41, 1))
    demo = _demo(_reach([0.5, 0.0, 0.02]), pot=(pot, UP), cube=(cube, UP))
    assert acted_on(demo) is None  # nothing within 15 cm, nothing said about the gripper
    actions = np.zeros((41, 7))
    actions[:, 6] = np.where(T < T[-1] - 0.2, -1.0, 1.0)  # open, then shut at the end
    closes = Demonstration(T, {**demo.streams, "actions": actions})
    r = acted_on(closes)
    assert r.object == "pot" and not r.moves_with and r.distance == pytest.approx(0.17)
    actions[:, 6] = -1.0  # a reach that stays open reached for nothing
    assert acted_on(Demonstration(T, {**demo.streams, "actions": actions})) is None


def test_a_straight_lift_held_fast_is_a_carry_not_a_slide_along_a_rail():
    tool = np.column_stack([0.5 + 0 * T, 0 * T, 0.05 + 0.1 * T])  # straight up, 20 cm
    cube = tool - [0.0, 0.0, 0.01]
    actions = np.zeros((41, 7))
    actions[:, 6] = 1.0  # shut all along
    demo = Demonstration(T, {**_demo(tool, cube=(cube, UP)).streams, "actions": actions})
    r = acted_on(demo)
    assert r.object == "cube" and r.moves_with and r.joints == ()


def test_object_streams_are_robosuites_pose_pairs_only():
    pos = np.zeros((41, 3))
    d = Demonstration(T, {"position": pos, "cube_pos": pos, "cube_quat": UP, "lone_pos": pos,
                          "Can_to_robot0_eef_pos": pos, "Can_to_robot0_eef_quat": UP})
    assert object_streams(d) == ["cube"]


def test_bad_input_is_one_clear_error():
    with pytest.raises(ValueError, match="demo: expected a Demonstration with a 'position' stream"):
        acted_on(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="near"):
        acted_on(_demo(_reach([0.2, 0.0, 0.3])), near=-1.0)
    with pytest.raises(ValueError, match=r"demo.position: expected 3-D tool positions, got 2-D"):
        acted_on(Demonstration(T, {"position": np.zeros((41, 2))}))
    r = Relation("cube", False, 0.0, np.zeros(3), None)
    with pytest.raises(ValueError, match=r"position: expected 3 finite numbers"):
        compose(r, [0.0, np.nan, 0.0], [0.0, 0.0, 0.0, 1.0])


def test_an_object_let_go_at_the_end_was_carried_and_one_settling_at_the_start_was_not():
    """A carry that ends with a release (the object falls 8 cm after it) is a carry; a cube that settles
    1.2 cm as the tool sets off towards it, and a nut turned with the wrist, are judged by where they sit
    in the tool's frame."""
    s = (T / T[-1])[:, None]
    tool = np.asarray([0.5, 0.0, 0.1]) + s * [0.0, 0.3, 0.1]
    box = tool - [0.0, 0.0, 0.03]
    box[-5:, 2] -= np.linspace(0.02, 0.08, 5)  # let go: it falls into the bin
    r = acted_on(_demo(tool, box=(box, UP)))
    assert r.object == "box" and r.moves_with
    reach = _reach([0.5, 0.1, 0.05])
    cube = np.tile([0.5, 0.1, 0.02], (41, 1))
    cube[:3, 2] += [0.012, 0.006, 0.0]  # dropped into place by the simulator's reset
    r = acted_on(_demo(reach, cube=(cube, UP)))
    assert r.object == "cube" and not r.moves_with


def test_an_object_turned_with_the_wrist_is_carried():
    from skillbank.core import quaternion_to_matrix
    from skillbank.core._rotations import quaternion_multiply

    s = (T / T[-1])
    down = exp_map([0.0, np.pi, 0.0])
    q = np.array([quaternion_multiply([0.0, 0.0, np.sin(a / 2), np.cos(a / 2)], down) for a in s * np.pi / 4])
    tool = np.asarray([0.4, 0.0, 0.2]) + s[:, None] * [0.0, 0.2, 0.05]
    nut = tool + np.einsum("nij,j->ni", quaternion_to_matrix(q), [0.067, 0.0, 0.0])  # held by its handle
    d = Demonstration(T, {"position": tool, "orientation": q, "nut_pos": nut, "nut_quat": UP})
    r = acted_on(d)
    assert r.object == "nut" and r.moves_with
