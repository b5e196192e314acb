"""A demonstration's phases: one reach per approach whatever its pauses, every grasp of several objects,
a carried object told from one that settles or is pushed."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank import Demonstration
from skillbank.segmentation import MultimodalSegmenter, carried, demonstration_phases
from skillbank.segmentation._phases import Phase, phase_bounds

RATE = 20.0  # robosuite's control rate
IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])


def _halting(start, goal, n_moves, rng, still=15, move=12):
    """A person's approach at a keyboard: ``n_moves`` bursts towards ``goal``, each followed by a stop."""
    out, here = [], np.asarray(start, float)
    for k in range(n_moves):
        # each burst covers part of what is left (the last arrives), with a little overshoot across
        aim = goal if k == n_moves - 1 else here + rng.uniform(0.3, 0.7) * (goal - here)
        aim = aim + (0 if k == n_moves - 1 else rng.normal(0, 0.004, 3))
        s = 0.5 - 0.5 * np.cos(np.linspace(0, np.pi, move))  # a smooth burst
        out.append(here + s[:, None] * (aim - here))
        out.append(np.repeat(aim[None], still, 0))
        here = aim
    return np.vstack(out)


def _pick_and_place(rng, objects, order, grips, *, halts=4, retry=False, settle=0.0):
    """A demonstration that picks ``order``'s objects one after the other and puts each 20 cm along y.

    ``grips[name]``: where the fingers stop when closed on it (1 closed, 0 open: a thin can stops
    half-way). ``retry``: the first grasp closes 3 cm over the object, comes up empty, opens, tries again.
    ``settle``: the first object sinks this far (m) while the hand is still at the start (robosuite's
    reset).
    """
    where = {name: np.array(p, float) for name, p in objects.items()}
    tool = [np.array([0.0, 0.0, 0.3])]
    grip = [0.0]
    obj = {name: [where[name]] for name in objects}

    def hold(P, g, carrying=None, offset=None):
        for p in P:
            tool.append(p)
            grip.append(g)
            for name in objects:
                if name == carrying:
                    where[name] = p + offset
                obj[name].append(where[name].copy())

    if settle:
        first = order[0]
        for _ in range(20):
            where[first] = where[first] - [0, 0, settle / 20]
            hold([tool[-1]], 0.0)
    for name in order:
        above = where[name] + [0.0, 0.0, 0.08]
        hold(_halting(tool[-1], above, halts, rng), 0.0)
        if retry:
            hold(np.repeat(above[None] + [0, 0, 0.03], 6, 0), grips[name])  # closes on nothing
            hold(np.repeat(above[None] + [0, 0, 0.03], 6, 0), 0.0)
            retry = False
        grasp = where[name] + [0.0, 0.0, 0.01]
        hold(_halting(tool[-1], grasp, 2, rng), 0.0)
        closing = np.linspace(0.0, grips[name], 8)
        for g in closing:
            hold([grasp], float(g))
        offset = where[name] - grasp
        target = where[name] + [0.0, 0.2, 0.0]
        hold(_halting(grasp, target - offset + [0, 0, 0.1], halts, rng), grips[name], name, offset)
        hold(_halting(tool[-1], target - offset, 2, rng), grips[name], name, offset)
        for g in closing[::-1]:
            hold([tool[-1]], float(g))
        hold(_halting(tool[-1], tool[-1] + [0, 0, 0.1], 2, rng), 0.0)
    n = len(tool)
    streams = {"position": np.array(tool), "orientation": np.tile(IDENTITY, (n, 1)),
               "gripper": np.column_stack([grip, -np.array(grip)])}
    for name in objects:
        streams[f"{name}_pos"] = np.array(obj[name])
        streams[f"{name}_quat"] = np.tile(IDENTITY, (n, 1))
    return Demonstration(np.arange(n) / RATE, streams)


CUBE = {"cube": (0.1, 0.0, 0.02)}


def test_a_halting_approach_is_one_reach_and_a_halting_carry_one_carry():
    demo = _pick_and_place(np.random.default_rng(0), CUBE, ["cube"], {"cube": 1.0}, halts=5)
    kinds = [(p.kind, p.object) for p in demonstration_phases(demo)]
    assert kinds == [("reach", "cube"), ("carry", "cube"), ("retreat", "cube")]
    phased = MultimodalSegmenter().fit(demo)
    motion = MultimodalSegmenter(phases=False).fit(demo)
    # the motion's own cuts fall at the person's stops: many pieces; the phases make three
    assert phased.result_.n_segments == 3
    assert motion.result_.n_segments >= 8
    # the reach ends at the grasp: the gripper is open before the cut and closing after it
    cut = phased.result_.keypoints[0]
    assert demo["gripper"][cut - 3, 0] == 0.0 and demo["gripper"][cut + 3, 0] > 0.5
    assert phased.result_.to_dict()["phases"][0] == {"kind": "reach", "start": 0, "stop": int(cut),
                                                     "object": "cube"}


def test_a_grasp_that_held_nothing_stays_inside_the_reach():
    demo = _pick_and_place(np.random.default_rng(1), CUBE, ["cube"], {"cube": 1.0}, retry=True)
    phases = demonstration_phases(demo)
    assert [p.kind for p in phases] == ["reach", "carry", "retreat"]
    reach = demo["gripper"][phases[0].start:phases[0].stop, 0]
    assert reach.max() == 1.0  # the failed grasp closed and opened again within the reach


def test_every_grasp_of_four_objects_is_found_whatever_the_fingers_close_to():
    objects = {"milk": (0.1, -0.2, 0.05), "bread": (0.1, -0.1, 0.02), "cereal": (0.1, 0.0, 0.05),
               "can": (0.1, 0.1, 0.03)}
    grips = {"milk": 1.0, "cereal": 0.95, "bread": 0.37, "can": 0.5}  # bread and can stop part way
    order = ["milk", "bread", "cereal", "can"]
    demo = _pick_and_place(np.random.default_rng(2), objects, order, grips)
    phases = demonstration_phases(demo)
    carries = [p.object for p in phases if p.kind == "carry"]
    reaches = [p.object for p in phases if p.kind == "reach"]
    assert carries == order and reaches == order
    result = MultimodalSegmenter().fit(demo).result_
    assert result.n_segments == len(phases) == 9
    # contiguous, in order, covering every sample
    assert phases[0].start == 0 and phases[-1].stop == demo.n_steps
    assert all(a.stop == b.start for a, b in zip(phases[:-1], phases[1:], strict=True))


def test_a_cube_settling_at_reset_is_not_carried():
    demo = _pick_and_place(np.random.default_rng(3), CUBE, ["cube"], {"cube": 1.0}, settle=0.013)
    phases = demonstration_phases(demo)
    assert phases[0].kind == "reach"
    assert carried(demo, "cube", 0, 20) == 0.0  # it sank 1.3 cm, the hand did not move
    from skillbank.selection import acted_on

    relation = acted_on(demo.slice(phases[0].start, phases[0].stop))
    assert relation.object == "cube" and not relation.moves_with


def test_without_objects_or_a_gripper_the_motion_alone_cuts():
    demo = _pick_and_place(np.random.default_rng(4), CUBE, ["cube"], {"cube": 1.0})
    bare = Demonstration(demo.t, {"position": demo["position"], "gripper": demo["gripper"]})
    assert demonstration_phases(bare) == []
    assert MultimodalSegmenter().fit(bare).result_.n_segments == \
        MultimodalSegmenter(phases=False).fit(bare).result_.n_segments
    # a gripper that never holds anything (it closes in the air) makes no phases either
    still = Demonstration(demo.t, {"position": demo["position"], "gripper": demo["gripper"],
                                   "cube_pos": np.tile([1.0, 1.0, 0.02], (demo.n_steps, 1)),
                                   "cube_quat": np.tile(IDENTITY, (demo.n_steps, 1))})
    assert demonstration_phases(still) == []


def test_two_grippers_are_an_ambiguity_and_cut_by_motion():
    demo = _pick_and_place(np.random.default_rng(5), CUBE, ["cube"], {"cube": 1.0})
    streams = dict(demo.streams)
    streams["suction"] = streams["gripper"].copy()
    two = Demonstration(demo.t, streams)
    assert demonstration_phases(two, stream_kinds={"suction": "discrete"}) == []


def test_phases_must_be_a_bool():
    demo = _pick_and_place(np.random.default_rng(6), CUBE, ["cube"], {"cube": 1.0})
    with pytest.raises(ValueError, match="phases: expected True or False"):
        MultimodalSegmenter(phases="yes").fit(demo)
    with pytest.raises(ValueError, match="demo: expected a skillbank.Demonstration"):
        demonstration_phases(np.zeros((3, 3)))


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.lists(st.integers(1, 60), min_size=1, max_size=8), st.integers(1, 30))
def test_phase_bounds_cover_the_samples_and_respect_the_minimum(sizes, min_size):
    edges = np.r_[0, np.cumsum(sizes)]
    phases = [Phase("reach", int(a), int(b), None) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    n = int(edges[-1])
    bounds = phase_bounds(phases, n, min_size)
    assert set(bounds.tolist()) <= set(edges[1:-1].tolist())  # only phase boundaries, none invented
    assert np.all(np.diff(bounds) > 0)
    if len(bounds):
        assert np.diff(np.r_[0, bounds, n]).min() >= min_size
    # a boundary is dropped only where a piece was too short
    if np.all(np.asarray(sizes) >= min_size):
        assert bounds.tolist() == edges[1:-1].tolist()
