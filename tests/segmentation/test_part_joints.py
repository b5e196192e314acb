"""The joints a carried part moved about, found from recorded poses (skillbank.segmentation.part_joints)."""

import numpy as np
import pytest

from skillbank.core import Demonstration
from skillbank.core._rotations import exp_map, quaternion_multiply, quaternion_to_matrix
from skillbank.segmentation import part_joints


def _door(n=40, hinge=(0.0, 0.0, 1.0), at=(0.5, 0.2, 1.0), seed=0):
    """A handle pressed 1.3 rad about its latch (the door's y axis) while the door stays shut, then held
    while the door turns 0.4 rad about a hinge 0.3 m from the door's origin."""
    rng = np.random.default_rng(seed)
    latch = np.r_[np.linspace(0, 1.3, n // 2), np.full(n - n // 2, 1.3)]
    door = np.r_[np.zeros(n // 2), np.linspace(0, 0.4, n - n // 2)]
    hinge = np.asarray(hinge, float) / np.linalg.norm(hinge)
    d0 = exp_map(rng.normal(scale=0.1, size=3))  # the door's orientation at rest
    turn = exp_map(door[:, None] * hinge)
    door_q = quaternion_multiply(turn, np.broadcast_to(d0, turn.shape))
    door_p = np.asarray(at) + np.einsum("nij,j->ni", quaternion_to_matrix(turn), [0.30, 0.0, 0.0])
    local_q = exp_map(latch[:, None] * np.array([0.0, 1.0, 0.0]))
    handle_q = quaternion_multiply(door_q, local_q)
    # the handle (its latch's origin) 15 cm further from the hinge than the door's, 10 cm out of it
    handle_p = door_p + np.einsum("nij,j->ni", quaternion_to_matrix(door_q), [0.15, -0.1, 0.0])
    streams = {"door_pos": door_p, "door_quat": door_q, "handle_pos": handle_p, "handle_quat": handle_q}
    return Demonstration(np.arange(float(n)), streams), latch, door


def test_a_handle_pressed_then_pulled_with_its_door_is_two_joints_anchored_to_the_door():
    demo, latch, door = _door()
    chain = part_joints(demo, "handle")
    assert chain.anchor == "door" and [j.kind for j in chain.joints] == ["revolute", "revolute"]
    assert chain.residual < 1e-6
    assert np.allclose(np.abs(chain.joints[0].values), latch, atol=1e-6)
    assert np.allclose(np.abs(chain.joints[1].values), door, atol=1e-6)
    assert abs(abs(chain.joints[1].axis[2]) - 1.0) < 1e-9


def test_what_is_measured_between_two_scenes_is_the_joints_values():
    demo, _, _ = _door()
    chain = part_joints(demo, "handle")
    pose = {name: (demo[f"{name}_pos"], demo[f"{name}_quat"]) for name in ("door", "handle")}
    start = {k: (p[0], q[0]) for k, (p, q) in pose.items()}
    for k in (5, 25, 39):
        now = {name: (p[k], q[k]) for name, (p, q) in pose.items()}
        assert np.allclose(chain.measure(start, now), [j.values[k] for j in chain.joints], atol=1e-9)


def test_the_chain_moved_with_its_door_moves_the_hand_as_the_handle_moved():
    demo, _, _ = _door()
    chain = part_joints(demo, "handle")
    # the same door placed elsewhere, turned 0.3 rad about the vertical: the handle's last pose follows
    turn = exp_map(np.array([0.0, 0.0, 0.3]))
    R, shift = quaternion_to_matrix(turn), np.array([0.1, -0.2, 0.0])

    def there(p, q):
        return R @ p + shift, quaternion_multiply(turn, q)

    moved = chain.moved_with((demo["door_pos"][0], demo["door_quat"][0]),
                             there(demo["door_pos"][0], demo["door_quat"][0]))
    p, q = moved.move(*there(demo["handle_pos"][0], demo["handle_quat"][0]), -1)
    want_p, want_q = there(demo["handle_pos"][-1], demo["handle_quat"][-1])
    assert np.allclose(p, want_p, atol=1e-9)
    assert min(np.abs(q - want_q).max(), np.abs(q + want_q).max()) < 1e-9


def test_a_part_that_did_not_move_has_no_joints_and_a_free_object_no_parent():
    demo, _, _ = _door()
    still = Demonstration(demo.t, {"cube_pos": np.zeros((len(demo.t), 3)),
                                   "cube_quat": np.tile([0, 0, 0, 1.0], (len(demo.t), 1))})
    assert part_joints(still, "cube") is None
    assert part_joints(still, "ghost") is None


@pytest.mark.parametrize("hinge", [(0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (0.2, 0.0, 1.0)])
def test_the_hinge_is_found_whichever_way_it_points(hinge):
    demo, _, door = _door(hinge=hinge)
    chain = part_joints(demo, "handle")
    want = np.asarray(hinge) / np.linalg.norm(hinge)
    assert abs(abs(chain.joints[1].axis @ want) - 1.0) < 1e-6


@pytest.mark.parametrize("grip, carried", [(1.0, True), (-1.0, False)])
def test_a_lever_that_slides_in_fingers_held_shut_is_carried_a_lever_let_go_is_not(grip, carried):
    from skillbank.selection import acted_on

    demo, _, _ = _door()
    n = len(demo.t)
    # the hand on the lever, sliding 3 cm along it as the lever is pressed (the first 40 %) and turning
    # 0.3 rad on it as the fingers give: more than the 2 cm a rigidly held object may shift, early on
    R = quaternion_to_matrix(demo["handle_quat"])
    slide = np.clip(np.linspace(0.0, 0.075, n), 0.0, 0.03)[:, None] * np.array([1.0, 0.0, 0.0])
    tool_p = demo["handle_pos"] + np.einsum("nij,nj->ni", R, slide + [0.0, -0.02, 0.0])
    tool_q = quaternion_multiply(demo["handle_quat"], exp_map(np.linspace(0, 0.3, n)[:, None] * [0, 0, 1.0]))
    actions = np.zeros((n, 7))
    actions[:, 6] = grip
    streams = dict(demo.streams, position=tool_p, orientation=tool_q, actions=actions)
    relation = acted_on(Demonstration(demo.t, streams))
    assert relation.object == "handle" and relation.moves_with is carried
    if carried:  # the joints it moved about travel with the relation (library list shows them)
        kinds = [(j["kind"], j["in"]) for j in relation.joints]
        assert kinds == [("revolute", "door"), ("revolute", "world")]
        assert [abs(j["value"]) for j in relation.joints] == pytest.approx([1.3, 0.4])
        assert type(relation).from_dict(relation.to_dict()).joints == relation.joints


@pytest.mark.parametrize("joints", [{"kind": "revolute"}, [{"kind": "revolute", "in": "door"}], ["x"]])
def test_a_relation_whose_joints_are_not_as_written_is_refused_in_one_line(joints):
    from skillbank.selection import Relation

    doc = Relation("handle", True, 0.02, np.zeros(3), None).to_dict()
    doc["joints"] = joints
    with pytest.raises(ValueError, match=r"^relation: expected joints as a list of \{kind, in, value\}"):
        Relation.from_dict(doc)
