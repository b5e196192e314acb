"""Plans over learned skills carried out in robosuite (#26): real episodes, short ones.

The library is three scripted demonstrations of robosuite's Stack (cube A onto cube B), labelled as a
person would (one reaching primitive ``pick``, one carrying primitive ``place``) and described in PDDL;
the plans stack three cubes, which no demonstration showed.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from skillbank.cli import main
from skillbank.experiments._composition import PICK, PLACE, _label_one_each
from skillbank.pipeline import Library
from skillbank.planning import parse_domain

pytest.importorskip("robosuite", reason="needs the sim extra (pip install 'skillbank[sim]')")

from skillbank.simulation import COMPOSED, STEP_REASONS, execute_plan, record  # noqa: E402
from skillbank.simulation._compose import (  # noqa: E402
    _agreeing,
    _described,
    _highest_first,
    _Phase,
    _phases,
)
from skillbank.simulation._evaluate import _sources  # noqa: E402

AWAY = [-0.15, -0.15, 0.83]  # m: on the table, outside where robosuite's sampler puts the cubes


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    folder = tmp_path_factory.mktemp("compose")
    data = folder / "stack.hdf5"
    record("robosuite:Stack", episodes=3, out=data, seed=0)
    db = folder / "stack.db"
    with Library(db) as lib:
        lib.add_files([data], assign="recluster")
        labelled = _label_one_each(lib)
    return db, labelled


def run(*args):
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def test_labels_given_once_name_every_demonstration_phase(library):
    db, labelled = library
    with Library(db, readonly=True) as lib:
        prims = {p.id: p for p in lib.primitives(load=False)}
        assert prims[labelled["pick"]].label_source == "given"
        sources = _sources(lib.store)
    phases = [ph for src in sources for ph in _phases(src)]
    # every demonstration reaches for cube A, then carries it onto cube B: two phases each
    assert [(ph.kind, ph.object, ph.target) for ph in phases] == [("reach", "cubeA", None),
                                                                  ("carry", "cubeA", "cubeB")] * 3
    assert {ph.label for ph in phases if ph.kind == "reach"} == {"pick"}


def test_a_tower_no_demonstration_showed_is_planned_and_stands(library):
    db, _ = library
    goal = ["(on cubeC cubeA)", "(on cubeA cubeB)"]  # C on A on B: the demonstrations put A on B only
    report = execute_plan(db, "robosuite:Stack3", seed=101, goal=goal)
    row = report["per_episode"][0]
    assert row["plan"] == ["(pick cubeA)", "(place cubeA cubeB)", "(pick cubeC)", "(place cubeC cubeA)"]
    assert row["success"] and report["successes"] == 1 and report["failures"] == {}
    assert all(step["ok"] for step in row["steps"])
    for step in row["steps"]:  # what the plan said each step would do is what the simulation shows
        assert set(step["planned"]["add"]) <= set(step["observed"]["facts"])
    # the cube carried to its place was bound to cube C: the demonstrations only ever carried cube A
    assert row["steps"][3]["observed"]["objects"]["cubeC"]["held"] is False
    assert {"(on cubeC cubeA)", "(on cubeA cubeB)", "(handempty)"} <= set(row["facts"]["end"])
    assert "(loose cubeA)" in row["facts"]["start"] and "(handempty)" in row["facts"]["start"]


def test_a_step_undone_behind_the_plans_back_stops_it_and_replanning_recovers(library):
    db, _ = library
    disturb = {"after": 2, "object": "cubeB", "position": AWAY}  # cube B knocked off cube C
    stopped = execute_plan(db, "robosuite:Stack3", seed=102, disturb=disturb)["per_episode"][0]
    assert not stopped["success"]
    assert stopped["failure"]["reason"] == "world changed" and stopped["failure"]["step"] == 3
    assert "(on cubeB cubeC)" in stopped["failure"]["detail"]
    assert stopped["steps"][1]["disturbed"]["object"] == "cubeB"
    recovered = execute_plan(db, "robosuite:Stack3", seed=102, disturb=disturb, replan=True)
    row = recovered["per_episode"][0]
    assert row["success"] and row["replans"] == 1
    assert row["steps"][2]["reason"] == "world changed"
    assert row["steps"][2]["replanned"][:2] == ["(pick cubeB)", "(place cubeB cubeC)"]
    assert [s["action"] for s in row["steps"] if s["ok"]] == ["pick", "place"] * 3


def test_plan_cli_on_a_robosuite_scene_prints_json_and_a_figure(library, tmp_path):
    db, _ = library
    figure = tmp_path / "plan.png"
    code, out, err = run("plan", db, "--scene", "robosuite:Stack3", "--simulate", "--seed", "101",
                         "--goal", "(on cubeC cubeA) (on cubeA cubeB)", "--plot", figure, "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["successes"] == 1 and doc["planner"]["search"] == "satisficing"
    # the arm driven, and the one the library was recorded on (the same: no note; issue 41, item 6)
    assert doc["robot"] == "UR5e" and doc["recorded_on"] == ["UR5e"] and doc["notes"] == []
    assert doc["written"] == [str(figure)] and figure.stat().st_size > 10_000
    assert set(doc) >= {"episodes", "successes", "success_rate", "interval", "failures", "per_episode"}


@pytest.mark.parametrize(("args", "message"), [
    (["--scene", "robosuite:Kitchen", "--simulate"], "plans run in robosuite tasks"),
    (["--scene", "robosuite:Stack3"], "add --simulate"),
    (["--scene", "robosuite:Stack3", "--simulate", "--out", "x.csv"], "--out: a robosuite scene"),
    (["--scene", "robosuite:Stack3", "--simulate", "--goal", "on cubeA"], "goal: expected facts"),
    (["--scene", "robosuite:Stack3", "--simulate", "--goal", "(on cubeA cubeD) (on cubeB cubeC)"],
     "names 'cubed', which the scene does not have"),
    (["--scene", "robosuite:Stack3", "--simulate", "--goal", "(on cubeA cubeB)"], "one tower of"),
    (["--scene", "robosuite:Stack3", "--simulate", "--disturb", "2:cubeB"], "disturb: expected K:OBJECT"),
    (["--scene", "robosuite:Stack3", "--simulate", "--disturb", "2:cubeQ:0,0,1"], "no object 'cubeQ'"),
    (["--scene", "robosuite:Stack3", "--simulate", "--method", "fast"], "method: expected one of"),
])
def test_bad_robosuite_plans_are_one_line_and_exit_2(library, args, message):
    db, _ = library
    code, out, err = run("plan", db, *args)
    assert code == 2 and out == ""
    assert message in err and len(err.strip().splitlines()) == 1


def test_a_library_without_descriptions_or_labelled_phases_is_refused(library, tmp_path):
    db, _ = library
    bare = tmp_path / "bare.db"
    with Library(db, readonly=True) as lib, Library(bare) as new:
        demos = [lib.demonstration(d) for d in lib.demonstration_ids()]
    with Library(bare) as new:
        new.add_many(demos, assign="recluster")
    with pytest.raises(ValueError, match="no skill descriptions"):
        execute_plan(bare, "robosuite:Stack3")
    with Library(bare) as new:
        new.describe("pick", PICK, {})
        new.describe("place", PLACE, {})
    with pytest.raises(ValueError, match=r"no phase of a demonstration .* is labelled \['pick', 'place'\]"):
        execute_plan(bare, "robosuite:Stack3")
    with pytest.raises(ValueError, match="scene: expected robosuite:TASK"):
        execute_plan(db, "Stack3")
    with pytest.raises(ValueError, match=r"disturb\.position: expected 3 finite numbers"):
        execute_plan(db, "robosuite:Stack3",
                     disturb={"after": 1, "object": "cubeA", "position": [0, np.nan, 1]})


def test_the_tasks_and_reasons_are_documented():
    assert set(COMPOSED) == {"PickPlace", "Stack3"}
    assert {"world changed", "not held", "misplaced", "no plan"} <= set(STEP_REASONS)


DOMAIN = parse_domain("""(define (domain skillbank) (:requirements :strips :typing)
  (:predicates (clear ?x0 - object) (handempty) (holding ?x0 - object) (loose ?x0 - object)
               (on ?x0 - object ?x1 - object))
  (:action pick :parameters (?o - object) :precondition (and (handempty) (clear ?o) (loose ?o))
    :effect (and (holding ?o) (not (handempty)) (not (loose ?o))))
  (:action place :parameters (?o - object ?t - object) :precondition (and (holding ?o) (clear ?t))
    :effect (and (on ?o ?t) (handempty) (not (holding ?o)) (not (clear ?t)))))""")


class _Tops:
    """A scene's objects standing this high (m): what ``_highest_first`` reads of the world."""

    def __init__(self, tops):
        self.models, self.tops = dict.fromkeys(tops), tops

    def top(self, obj):
        return self.tops[obj]


def _loose(objects, places=()):
    return {("handempty", ())} | {("loose", (o,)) for o in objects} | \
        {("clear", (x,)) for x in [*objects, *places]}


def test_of_the_moves_the_goal_leaves_unordered_the_tallest_object_goes_first():
    """A bin of three: the planner's order is alphabetical, the world's the tallest first; each pick is
    followed by its own place, the rest in the planner's order, and the goal is still reached."""
    objects = ["Bread", "Cereal", "Milk"]
    world = _Tops({"Bread": 0.87, "Cereal": 0.975, "Milk": 0.968})
    goal = [("on", (o, f"{o}_place")) for o in objects]
    plan = [s for o in objects for s in [("pick", (o,)), ("place", (o, f"{o}_place"))]]
    state = _loose(objects, [f"{o}_place" for o in objects])
    first = _highest_first(DOMAIN, state, plan, goal, world)
    assert first == [("pick", ("Cereal",)), ("place", ("Cereal", "Cereal_place")),
                     ("pick", ("Bread",)), ("place", ("Bread", "Bread_place")),
                     ("pick", ("Milk",)), ("place", ("Milk", "Milk_place"))]
    # holding the cereal, only its place can come next
    held = (state - {("handempty", ()), ("loose", ("Cereal",))}) | {("holding", ("Cereal",))}
    assert _highest_first(DOMAIN, held, first[1:], goal, world) == first[1:]
    # equal heights keep the planner's order
    assert _highest_first(DOMAIN, state, plan, goal, _Tops(dict.fromkeys(objects, 0.9))) == plan


def test_a_grasp_with_no_room_waits_for_one_that_has_room():
    """The cereal box stands against the milk carton: its grasp's fingers, on either of its symmetric
    turns, close 3 cm from the carton (under NEIGHBOUR), while the milk's turn clears the box. The milk
    goes first though the box is taller; among grasps with room, the tallest still goes first."""
    objects = ["Bread", "Cereal", "Milk"]
    world = _Tops({"Bread": 0.87, "Cereal": 0.975, "Milk": 0.968})
    goal = [("on", (o, f"{o}_place")) for o in objects]
    plan = [s for o in objects for s in [("pick", (o,)), ("place", (o, f"{o}_place"))]]
    state = _loose(objects, [f"{o}_place" for o in objects])
    rooms = {"Bread": 0.12, "Cereal": 0.03, "Milk": 0.08}

    def room(act, args):
        return rooms[args[0]] if act == "pick" else np.inf

    first = _highest_first(DOMAIN, state, plan, goal, world, room=room)
    assert first[:2] == [("pick", ("Milk",)), ("place", ("Milk", "Milk_place"))]
    # the milk gone, the box has room: the tallest first again
    rooms["Cereal"] = 0.2
    later = _highest_first(DOMAIN, state, plan, goal, world, room=room)
    assert later[0] == ("pick", ("Cereal",))
    # every grasp crowded: as if none were
    assert _highest_first(DOMAIN, state, plan, goal, world, room=lambda act, args: 0.0)[0] == \
        ("pick", ("Cereal",))


def test_a_tower_keeps_the_order_its_goal_forces_however_tall_the_top_cube():
    """A on B on C: A cannot go first (B must be on C before A is put on B, and nothing picks a cube that
    something stands on), so the planner's order stands even with A the tallest."""
    cubes = ["cubeA", "cubeB", "cubeC"]
    plan = [("pick", ("cubeB",)), ("place", ("cubeB", "cubeC")), ("pick", ("cubeA",)),
            ("place", ("cubeA", "cubeB"))]
    goal = [("on", ("cubeA", "cubeB")), ("on", ("cubeB", "cubeC"))]
    world = _Tops({"cubeA": 0.95, "cubeB": 0.85, "cubeC": 0.84})
    assert _highest_first(DOMAIN, _loose(cubes), plan, goal, world) == plan


def _phase(kind, obj, label, grip):
    """A phase of one segment whose recorded gripper command goes ``grip`` = (first, last)."""
    from types import SimpleNamespace

    actions = np.zeros((2, 7))
    actions[:, 6] = grip
    source = SimpleNamespace(actions=actions)
    segment = SimpleNamespace(primitive=SimpleNamespace(start=0, stop=2))
    return _Phase(source, [segment], kind, obj, None, label)


def _given(kind, obj, label, grip, source):
    """A phase like :func:`_phase` whose one segment's label is ``source`` (``"given"``, ``"inferred"``)."""
    from types import SimpleNamespace

    phase = _phase(kind, obj, label, grip)
    primitive = SimpleNamespace(start=0, stop=2, label=label, label_source=source)
    relation = SimpleNamespace(moves_with=kind == "carry")
    phase.segments = [SimpleNamespace(primitive=primitive, relation=relation)]
    return phase


def test_a_label_given_to_a_carry_names_carries_though_its_cluster_is_mostly_reaches():
    """The first milk carry is labelled place, and clustering put it with the short reaches down to the
    bread and the can, which inherit the label: the skill is what the person labelled (a carry), the
    reaches lose the label and are named by what they do (pick), the unlabelled cereal carry is a place."""
    phases = [_given("reach", "Milk", "pick", (-1, 1), "given"),
              _given("carry", "Milk", "place", (1, -1), "given"),
              _given("reach", "Bread", "place", (-1, 1), "inferred"),
              _given("reach", "Can", "place", (-1, 1), "inferred"),
              _given("carry", "Cereal", None, (1, -1), None)]
    every = _agreeing(phases)
    assert [ph.label for ph in every] == ["pick", "place", None, None, None]
    labelled = [ph for ph in every if ph.label is not None]
    named = _described(every, labelled, DOMAIN)
    assert [(ph.kind, ph.object, ph.label) for ph in named] == [("reach", "Bread", "pick"),
                                                                ("reach", "Can", "pick"),
                                                                ("carry", "Cereal", "place")]
    # a label given to a whole cluster (no primitive's own): the skill is what most of its phases do
    cluster = [_given("reach", o, "pick", (-1, 1), "cluster") for o in ("Milk", "Bread")]
    cluster.append(_given("carry", "Can", "pick", (1, -1), "cluster"))
    assert [ph.label for ph in _agreeing(cluster)] == ["pick", "pick", None]


def test_a_phase_no_label_names_is_named_by_the_one_described_skill_it_does():
    """The milk's reach is labelled pick and its carry place; the bread's reach fell in another cluster.
    It reaches and closes on the bread, which only pick describes: it is a pick. A reach that never
    closes, a phase on no object, and one two skills fit stay unnamed."""
    labelled = [_phase("reach", "Milk", "pick", (-1, 1)), _phase("carry", "Milk", "place", (1, -1))]
    bread = _phase("reach", "Bread", None, (-1, 1))
    open_hand = _phase("reach", "Bread", None, (-1, -1))
    nothing = _phase("reach", None, None, (-1, 1))
    named = _described([*labelled, bread, open_hand, nothing], labelled, DOMAIN)
    assert [(ph.object, ph.label) for ph in named] == [("Bread", "pick")]
    assert bread.label is None  # the library's phase is not changed: a copy is named
    twins = parse_domain(DOMAIN.text.replace("(:action pick", "(:action take :parameters (?o - object) "
                                             ":precondition (and (handempty)) :effect (and (holding ?o)))"
                                             "(:action pick"))
    both = [_phase("reach", "Milk", "pick", (-1, 1)), _phase("reach", "Can", "take", (-1, 1))]
    assert _described([*both, bread], both, twins) == []
