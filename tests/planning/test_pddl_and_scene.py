"""PDDL reading and writing, scene files and bindings: known answers and every error path."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.planning import (
    check_binding,
    domain_text,
    load_scene,
    parse_action,
    parse_atom,
    parse_domain,
    problem_text,
    scene_from_dict,
)

from .conftest import PRESS, button_scene

MOVE = ("(:action move :parameters (?from ?to - place) :precondition (and (at ?from) (not (blocked ?to))) "
        ":effect (and (at ?to) (not (at ?from))))")


def test_an_action_schema_is_read_with_typed_parameters_and_written_back():
    a = parse_action(PRESS)
    assert (a.name, a.parameters) == ("press", [("?b", "button")])
    assert parse_action(a.text).text == a.text  # a round trip changes nothing
    m = parse_action(MOVE)
    assert m.parameters == [("?from", "place"), ("?to", "place")] and m.negative


def test_a_domain_gathers_types_predicates_and_needs_negative_preconditions_when_used():
    d = domain_text([parse_action(PRESS), parse_action(MOVE)], types=["table"])
    assert d.types == ["button", "place", "table"]
    assert d.predicates == {"at": ["place"], "blocked": ["place"], "free": ["button"], "pressed": ["button"]}
    assert ":negative-preconditions" in d.text
    again = parse_domain(d.text)
    assert sorted(again.actions) == ["move", "press"] and again.predicates == d.predicates


def test_a_problem_lists_objects_facts_and_goal():
    text = problem_text({"b1": "button", "b2": "button"}, [("free", ("b1",))],
                        [("pressed", ("b1",)), ("pressed", ("b2",))], domain="skillbank")
    assert "(:objects b1 - button b2 - button)" in text and "(:goal (and (pressed b1) (pressed b2)))" in text


@pytest.mark.parametrize("text, message", [
    ("(:action press :parameters (?b - button) :effect (pressed ?b)", r"balanced parentheses"),
    ("(:action press :parameters (?b - button))", r"expected an :effect"),
    ("(:action press :parameters (b - button) :effect (pressed b))", r"parameters written \?name"),
    ("(:action press :parameters (?b ?b) :effect (pressed ?b))", r"distinct names"),
    ("(:action press :parameters (?b) :effect (pressed ?c))", r"uses \?c, which is not a parameter"),
    ("(:action press :parameters (?b) :effect (or (pressed ?b)))", r"expected an action name|combined with"),
    ("(:action press :parameters (?b) :duration 3 :effect (pressed ?b))", r"expected keys :parameters"),
    ("(:action 3press :parameters (?b) :effect (pressed ?b))", r"expected an action name"),
    ("(define (domain d))", r"expected \(:action NAME"),
    ("(:action press :effect (pressed ?b)) (extra)", r"more text after it"),
    ("", r"expected PDDL text, got none"),
])
def test_bad_action_schemas_are_refused_with_the_reason(text, message):
    with pytest.raises(ValueError, match=message):
        parse_action(text)


def test_a_domain_that_uses_an_undeclared_predicate_is_refused():
    with pytest.raises(ValueError, match=r"uses predicate 'pressed', which :predicates does not declare"):
        parse_domain("(define (domain d) (:predicates (free ?b)) "
                     "(:action press :parameters (?b) :effect (pressed ?b)))")
    with pytest.raises(ValueError, match=r"used with 1 and with 2 argument"):
        domain_text([parse_action(PRESS),
                     parse_action("(:action p2 :parameters (?a ?b) :effect (free ?a ?b))")])


def test_atoms_are_ground_and_lower_case():
    assert parse_atom("(Pressed B1)", "goal[0]") == ("pressed", ("b1",))
    with pytest.raises(ValueError, match=r"goal\[0\]: expected a ground atom"):
        parse_atom("(pressed (b1))", "goal[0]")


def test_a_scene_file_is_read_with_poses_obstacles_facts_and_start(tmp_path):
    doc = button_scene([[0.1, -0.5, 0.15]], goal=["b1"], obstacles=["sphere:0.0,-0.5,0.2,0.03"])
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(doc))
    scene = load_scene(path)
    assert scene.objects["b1"].type == "button" and scene.objects["b1"].position.tolist() == [0.1, -0.5, 0.15]
    assert list(scene.obstacles) == ["obstacles[0]"] and scene.obstacles["obstacles[0]"].radius == 0.03
    assert scene.init == [("free", ("b1",))] and scene.goal == [("pressed", ("b1",))]
    assert scene.start["position"].tolist() == [0.0, 0.0, 0.0] and scene.start["joints"] is None


@pytest.mark.parametrize("change, message", [
    ({"objects": []}, r"objects: expected an object of name"),
    ({"objects": {"b1": {"type": "button", "position": [0, 0]}}}, r"objects\['b1'\].position: expected 3"),
    ({"objects": {"b1": {"position": [0, 0, 0]}}}, r"objects\['b1'\].type: expected a PDDL type name"),
    ({"objects": {"b1": {"type": "button", "colour": "red"}}}, r"objects\['b1'\]: unknown key 'colour'"),
    ({"objects": {"b1": {"type": "button", "orientation": [0, 0, 0, 2]}}}, r"objects\['b1'\].orientation"),
    ({"obstacles": ["cone:1,2,3"]}, r"obstacles\[0\]: obstacle: expected"),
    ({"obstacles": ["sphere:0,0,0.1"]}, r"obstacles\[0\]: expected a 3-D obstacle"),
    ({"goal": []}, r"goal: expected a non-empty list"),
    ({"goal": ["(pressed b7)"]}, r"goal\[0\]: '\(pressed b7\)' names 'b7'"),
    ({"init": "(free b1)"}, r"init: expected a list of atoms"),
    ({"start": {"position": [0, 0, 0], "joints": [0] * 6}}, r"start: expected a pose .* or joints, got both"),
    ({"start": {"speed": 1}}, r"start: unknown key 'speed'"),
    ({"colour": 1}, r"scene: unknown key 'colour'"),
])
def test_bad_scenes_name_the_key(change, message):
    doc = button_scene([[0.1, -0.5, 0.15]], goal=["b1"])
    doc.update(change)
    with pytest.raises(ValueError, match=message):
        scene_from_dict(doc)


def test_a_domain_file_named_by_the_scene_never_leaves_its_folder(tmp_path):
    (tmp_path / "inside").mkdir()
    (tmp_path / "outside.pddl").write_text(PRESS)
    doc = button_scene([[0.1, -0.5, 0.15]], goal=["b1"], domain="../outside.pddl")
    path = tmp_path / "inside" / "scene.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=r"domain: expected a file inside the scene's folder"):
        load_scene(path)
    (tmp_path / "inside" / "d.pddl").write_text(PRESS)
    path.write_text(json.dumps(dict(doc, domain="d.pddl")))
    assert load_scene(path).domain.name == "d.pddl"
    with pytest.raises(ValueError, match=r"domain: a scene read from a dict has no folder"):
        scene_from_dict(dict(doc, domain="d.pddl"))
    path.write_text("{not json")
    with pytest.raises(ValueError, match=r"expected JSON"):
        load_scene(path)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3), st.sampled_from(["button", "block", "Table"]))
def test_any_valid_object_reads_back_exactly(position, kind):
    scene = scene_from_dict({"objects": {"X1": {"type": kind, "position": position}}, "goal": ["(at x1)"]})
    obj = scene.objects["x1"]
    assert obj.type == kind.lower() and np.array_equal(obj.position, np.asarray(position, dtype=float))


@settings(max_examples=40, deadline=None)
@given(st.one_of(st.none(), st.integers(), st.text(max_size=5), st.lists(st.integers(), max_size=4)))
def test_a_malformed_position_is_a_value_error_naming_it(value):
    doc = {"objects": {"b1": {"type": "button", "position": value}}, "goal": ["(pressed b1)"]}
    if value is None or (isinstance(value, list) and len(value) == 3):
        found = scene_from_dict(doc).objects["b1"].position
        # as floats: an integer past 2^53 is read as the nearest double, like every JSON reader does
        assert found is None if value is None else found.tolist() == [float(v) for v in value]
        return
    with pytest.raises(ValueError, match=r"objects\['b1'\].position"):
        scene_from_dict(doc)


@pytest.mark.parametrize("doc, message", [
    ({"goal": "?x"}, r"binding.goal: expected a parameter of the action"),
    ({"offset": [0, 0]}, r"binding.offset: expected 3 numbers"),
    ({"orientation": "up"}, r"binding.orientation: expected 'object', 'none' or a quaternion"),
    ({"orientation": [0, 0, 1]}, r"binding.orientation: expected a quaternion of 4"),
    ({"obstacles": "some"}, r"binding.obstacles: expected 'all' or a list"),
    ({"gripper": {"middle": 1}}, r"binding.gripper: expected an object with 'start'"),
    ({"method": "magic"}, r"binding.method: expected one of"),
    ({"velocity": "fast"}, r"binding.velocity: expected 'zero' or 'free'"),
    ({"duration": -1}, r"binding.duration"),
    ({"speed": 1}, r"binding: unknown key 'speed'"),
    ([1], r"binding: expected a JSON object"),
])
def test_bad_bindings_name_the_key(doc, message):
    with pytest.raises(ValueError, match=message):
        check_binding(doc, [("?b", "button")])


def test_a_binding_keeps_only_what_differs_from_the_defaults():
    b = check_binding({"goal": "?B", "offset": [0, 0, 0.01], "gripper": {"end": 0}, "method": "lte"},
                      [("?b", "button")])
    assert b.as_dict() == {"goal": "?b", "offset": [0.0, 0.0, 0.01], "gripper": {"end": 0.0}}
    assert check_binding(None).as_dict() == {}
