"""The turns of a place and of a grasp that change nothing, from the scene's own collision geometry.

``vertical_symmetry`` against point sets of known symmetry; ``support`` and ``object_symmetry`` on
robosuite's own scenes (no mock): a square peg accepts a nut at any quarter turn, a round one too (its
rim), a rectangular bin half turns; a cube is a quarter-turn object, a nut with its handle is none.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.simulation._support import vertical_symmetry


def _turned(P, angle, centre):
    c, s = math.cos(angle), math.sin(angle)
    out = np.array(P, float)
    out[:, :2] = (out[:, :2] - centre) @ np.array([[c, -s], [s, c]]).T + centre
    return out


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), k=st.sampled_from([1, 2, 4]))
def test_points_made_symmetric_are_found_so(seed, k):
    """A random motif repeated k times about a random vertical axis has exactly that symmetry (a random
    motif has none of its own)."""
    rng = np.random.default_rng(seed)
    centre = rng.uniform(-0.5, 0.5, 2)
    motif = np.column_stack([centre + rng.uniform(0.02, 0.1, (5, 2)), rng.uniform(0.8, 1.0, 5)])
    P = np.vstack([_turned(motif, 2 * math.pi * j / k, centre) for j in range(k)])
    assert vertical_symmetry(P, np.zeros(len(P)), centre) == k


def test_an_axis_off_the_centre_or_a_ball_for_a_corner_is_no_symmetry():
    square = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (0.0, 0.1)])
    assert vertical_symmetry(square, np.zeros(8), [0.0, 0.0]) == 4
    assert vertical_symmetry(square, np.zeros(8), [0.02, 0.0]) == 1
    radii = np.zeros(8)
    radii[0] = 0.01  # one corner is a ball: turned onto a bare corner, it no longer matches
    assert vertical_symmetry(square, radii, [0.0, 0.0]) == 1


def test_the_match_tolerates_round_off_not_a_shift():
    square = np.array([[x, y, 0.0] for x in (-0.1, 0.1) for y in (-0.1, 0.1)])
    nudged = square + [[0.001, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]
    assert vertical_symmetry(nudged, np.zeros(4), [0.0, 0.0]) == 4
    shifted = square + [[0.03, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]
    assert vertical_symmetry(shifted, np.zeros(4), [0.0, 0.0]) == 1


robosuite = pytest.importorskip("robosuite")  # the extra skillbank[sim]; installed in CI


@pytest.fixture(scope="module")
def scenes():
    from skillbank.simulation._evaluate import _make
    from skillbank.simulation._robosuite import import_robosuite

    out = {}
    for task in ("NutAssemblySquare", "PickPlace"):
        env = _make(import_robosuite(), task, 0, 1000)
        out[task] = (env, env.reset())
    yield out
    for env, _ in out.values():
        env.close()


def test_a_nut_is_put_on_its_peg_at_any_quarter_turn_and_in_a_bin_at_half_turns(scenes):
    from skillbank.simulation._support import fixtures, support

    env, _ = scenes["NutAssemblySquare"]
    square = env.sim.data.body_xpos[env.peg1_body_id]
    round_ = env.sim.data.body_xpos[env.peg2_body_id]
    assert support(env, square + [0.003, 0.0, 0.0]) == ("peg1", 4)
    assert support(env, round_) == ("peg2", 4)  # a cylinder: every turn, at least a quarter
    assert support(env, [0.0, 0.0, 0.82]) == ("table", 4)  # the 0.8 m square table
    assert support(env, [3.0, 3.0, 0.82]) is None
    # an arm is no fixture, nor is an object
    assert not any(name.startswith(("robot0", "gripper0", "fixed_mount0", "SquareNut"))
                   for name in fixtures(env))
    env, _ = scenes["PickPlace"]
    for place in env.target_bin_placements:
        assert support(env, place) == ("bin2", 2)


def test_a_cube_has_quarter_turns_and_a_nut_with_its_handle_none(scenes):
    from skillbank.simulation._support import object_symmetry

    env, _ = scenes["NutAssemblySquare"]
    assert object_symmetry(env, "SquareNut") == 1
    assert object_symmetry(env, "no such object") == 1
    from skillbank.simulation._evaluate import _make
    from skillbank.simulation._robosuite import import_robosuite

    stack = _make(import_robosuite(), "Stack", 0, 1000)
    try:
        stack.reset()
        assert object_symmetry(stack, "cubeA") == 4
    finally:
        stack.close()


def test_a_cubes_extents_and_the_grippers_pads(scenes):
    from skillbank.simulation._evaluate import _make
    from skillbank.simulation._robosuite import _pads, import_robosuite
    from skillbank.simulation._support import object_extents, pad_half_width

    env, _ = scenes["NutAssemblySquare"]
    assert object_extents(env, "no such object") is None
    nut = object_extents(env, "SquareNut")
    assert nut[0] > 2 * nut[2]  # a flat nut, its handle along its x
    for robot, pad in (("UR5e", 0.01), ("Panda", 0.008)):  # the 2F-85's pads 2 cm wide, the Panda's 1.6 cm
        lift = _make(import_robosuite(), "Lift", 0, 1000, robot)
        try:
            lift.reset()
            half = object_extents(lift, "cube")
            np.testing.assert_allclose(half, half[0], rtol=0.2)  # a cube, about 2 cm each way
            assert 0.015 < half[0] < 0.03
            closing = _pads(lift) * [1, 1, 0]
            assert abs(pad_half_width(lift, closing / np.linalg.norm(closing)) - pad) < 1.5e-3
        finally:
            lift.close()


def test_a_place_beside_the_object_it_ended_nearest_is_kept_in_the_world_one_on_it_on_it(scenes):
    """One demonstration's can let go in the bin beside the cereal already put there is placed in the
    bin's compartment (the world), not beside wherever the cereal stands now (still in the first bin);
    the same can let go on top of the cereal box keeps the box's frame."""
    from types import SimpleNamespace

    from skillbank.selection import Relation
    from skillbank.simulation._evaluate import _in_scene, _Segment

    env, _ = scenes["PickPlace"]
    n = 20
    tool = np.linspace([0.0, -0.25, 1.0], [0.1, 0.2, 0.95], n)
    down = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    upright = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    cereal = np.tile([0.18, 0.2, 0.9], (n, 1))

    def place(can_at_release):
        can = tool + (can_at_release - tool[-1])  # held rigidly, let go where it is at the end
        demo = {"position": tool, "orientation": down, "Can_pos": can, "Can_quat": upright,
                "Cereal_pos": cereal, "Cereal_quat": upright, "actions": np.zeros((n, 7))}
        relation = Relation("Can", True, 0.05, np.zeros(3), None, target="Cereal")
        seg = _Segment(SimpleNamespace(id=1, demo=demo), relation, ("Can", "target"), "held", released=True)
        return _in_scene(seg, env)

    beside = place(cereal[-1] + [0.0, -0.08, -0.03])  # on the bin's floor, 8 cm from the box
    assert beside.frame == ("world",) and beside.turn == ("world",)
    assert beside.symmetry == 2  # a rectangular bin's compartment takes it either way round
    on = place(cereal[-1] + [0.0, 0.0, 0.13])  # over the box's footprint, above its top
    assert on.frame == ("Can", "target") and on.turn == "held"
    # where several members' ends told the frames apart, the data's choice stands
    relation = Relation("Can", True, 0.05, np.zeros(3), None, target="Cereal")
    seg = _Segment(SimpleNamespace(id=1, demo=None), relation, ("Can", "target"), "held", released=True,
                   told=True)
    assert _in_scene(seg, env) is seg
