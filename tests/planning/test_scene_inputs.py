"""Scene and domain input at the edges (issue 23, item 8): every bad value is one line naming its key.

Before: a scene nested 3,000 levels deep ended in a RecursionError, ``"type": 5`` in a TypeError, a
position of 10^400 in an OverflowError, booleans were read as numbers, and a PDDL domain of 3,000
nested parentheses in a RecursionError.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from skillbank.planning import load_scene, parse_action, parse_atom, parse_domain, scene_from_dict
from skillbank.planning._json import MAX_JSON_DEPTH
from skillbank.planning._pddl import MAX_PDDL_DEPTH

from .conftest import BUTTONS_DOC, button_scene, write_scene

HUGE = 10 ** 400


def _scene(**change):
    doc = button_scene([[0.1, -0.5, 0.15]], goal=["b1"])
    doc.update(change)
    return doc


def _one_line(exc_info):
    message = str(exc_info.value)
    assert "\n" not in message and len(message) < 300, message
    return message


@pytest.mark.parametrize("change, message", [
    ({"objects": {"b1": {"type": 5}}},
     r"^objects\['b1'\]\.type: expected a PDDL type name \(a string such as 'button'\), got the number 5$"),
    ({"objects": {"b1": {"type": None}}}, r"^objects\['b1'\]\.type: expected a PDDL type name .*got null$"),
    ({"objects": {"b1": {"type": ["button"]}}}, r"^objects\['b1'\]\.type: .*got a list of 1 item\(s\)$"),
    ({"objects": {"b1": {"type": "button", "position": "0,0,0"}}},
     r"^objects\['b1'\]\.position: expected a list of 3 numbers, got the string '0,0,0'$"),
    ({"objects": {"b1": {"type": "button", "position": {"x": 0}}}},
     r"^objects\['b1'\]\.position: expected a list of 3 numbers, got an object$"),
    ({"objects": {"b1": {"type": "button", "position": [True, 0, 0]}}},
     r"^objects\['b1'\]\.position\[0\]: expected a number, got true$"),
    ({"objects": {"b1": {"type": "button", "position": [0, "1", 0]}}},
     r"^objects\['b1'\]\.position\[1\]: expected a number, got the string '1'$"),
    ({"objects": {"b1": {"type": "button", "position": [0, 0, HUGE]}}},
     r"^objects\['b1'\]\.position\[2\]: expected a number of magnitude at most 1e\+100, got an integer of "
     r"401 digits$"),
    ({"objects": {"b1": {"type": "button", "position": [0, 0, float("nan")]}}},
     r"^objects\['b1'\]\.position\[2\]: expected a finite number, got the number NaN$"),
    ({"objects": {"b1": {"type": "button", "orientation": [0, 0, 0, False]}}},
     r"^objects\['b1'\]\.orientation\[3\]: expected a number, got false$"),
    ({"objects": {"b1": ["button"]}}, r"^objects\['b1'\]: expected an object with 'type'.*got a list of 1"),
    ({"objects": {"b1": {"type": "button", "p" * 500: 1}}}, r"^objects\['b1'\]: unknown key 'ppp+\.\.\.'"),
    ({"obstacles": [5]}, r"^obstacles\[0\]: expected a spec string like 'sphere:X,Y,Z,R', got the number 5$"),
    ({"obstacles": {"wall": ["box"]}}, r"^obstacles\['wall'\]: expected a spec string .*got a list of 1"),
    ({"obstacles": "sphere:0,0,0,1"}, r"^obstacles: expected a list \(or an object\) of specs .*got the "
                                      r"string 'sphere:0,0,0,1'$"),
    ({"obstacles": [f"sphere:0,0,{HUGE},0.1"]}, r"^obstacles\[0\]: obstacle: expected numbers of magnitude "
                                                r"at most 1e\+100"),
    ({"init": [5]}, r"^init\[0\]: expected an atom like '\(pressed b1\)', got the number 5$"),
    ({"init": {"free": "b1"}}, r"^init: expected a list of atoms like '\(pressed b1\)', got an object$"),
    ({"goal": "(pressed b1)"}, r"^goal: expected a list of atoms .*got the string '\(pressed b1\)'$"),
    ({"goal": [["pressed", "b1"]]}, r"^goal\[0\]: expected an atom like '\(pressed b1\)', got a list of 2"),
    ({"goal": False}, r"^goal: expected a list of atoms like '\(pressed b1\)', got false$"),
    ({"goal": []}, r"^goal: expected a non-empty list of atoms .*got an empty list$"),
    ({"goal": ["(pressed " + "b" * 500 + ")"]}, r"^goal\[0\]: '\(pressed bbb+\.\.\.' names 'bbb+\.\.\.', "
                                                r"which is not an object"),
    ({"start": [0, 0, 0]}, r"^start: expected an object with 'position' .*got a list of 3 item\(s\)$"),
    ({"start": {"gripper": "open"}}, r"^start\.gripper: expected a number, got the string 'open'$"),
    ({"start": {"gripper": True}}, r"^start\.gripper: expected a number, got true$"),
    ({"start": {"gripper": HUGE}}, r"^start\.gripper: expected a number of magnitude at most 1e\+100"),
    ({"start": {"joints": [0, 0, [0]]}}, r"^start\.joints\[2\]: expected a number, got a list of 1 item"),
    ({"start": {"joints": []}}, r"^start\.joints: expected at least one number, got 0$"),
    ({"start": {"position": [0, 0, -HUGE]}}, r"^start\.position\[2\]: expected a number of magnitude"),
    ({"domain": 5}, r"^domain: expected a file name relative to the scene's folder, got the number 5$"),
], ids=lambda v: None if isinstance(v, str) else "")
def test_a_value_of_the_wrong_type_anywhere_is_one_line_naming_its_key(change, message):
    with pytest.raises(ValueError, match=message) as info:
        scene_from_dict(_scene(**change))
    _one_line(info)


@pytest.mark.parametrize("text, message", [
    ('[0, 0, NaN]', r"position\[2\]: expected a finite number, got the number NaN$"),
    ('[0, Infinity, 0]', r"position\[1\]: expected a finite number, got the number Infinity \(a literal "
                         r"beyond float64's range, such as 1e400, reads as one\)$"),
    ('[0, 0, -1e400]', r"position\[2\]: expected a finite number, got the number -Infinity"),
    ('[0, 0, 1' + '0' * 400 + ']', r"position\[2\]: expected a number of magnitude at most 1e\+100, got an "
                                   r"integer of 401 digits$"),
    ('[0, 0, true]', r"position\[2\]: expected a number, got true$"),
])
def test_number_literals_of_a_scene_file_beyond_float64_name_the_key(tmp_path, text, message):
    doc = json.dumps(_scene()).replace("[0.1, -0.5, 0.15]", text)
    path = tmp_path / "scene.json"
    path.write_text(doc)
    with pytest.raises(ValueError, match=r"^objects\['b1'\]\." + message) as info:
        load_scene(path)
    _one_line(info)


def test_an_integer_literal_too_long_for_python_is_one_line(tmp_path):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(_scene()).replace("0.15", "1" * 5000))
    with pytest.raises(ValueError, match=r"^scene '.*scene\.json': expected JSON, got Exceeds the "
                                         r"limit") as info:
        load_scene(path)
    _one_line(info)


@pytest.mark.parametrize("levels", [MAX_JSON_DEPTH + 1, 3000, 200_000])
def test_a_scene_file_nested_deeper_than_the_bound_is_refused_before_it_is_parsed(tmp_path, levels):
    path = tmp_path / "scene.json"
    path.write_text('{"objects": {}, "goal": ["(p)"],\n "start": {"joints": ' + "[" * levels + "]" * levels
                    + "}}")
    with pytest.raises(ValueError, match=rf"^scene '.*': expected JSON nested at most {MAX_JSON_DEPTH} "
                                         r"levels deep \(a scene needs 4\), got deeper nesting at "
                                         r"line 2$") as info:
        load_scene(path)
    _one_line(info)


def test_brackets_inside_strings_do_not_count_and_the_bound_itself_is_read(tmp_path):
    path = tmp_path / "scene.json"
    doc = _scene(init=["(free b1)"])
    doc["objects"]["b1"]["type"] = "button"
    text = json.dumps(doc).replace('"(free b1)"', '"(free b1)", ' + json.dumps("[" * 5000 + '"{'))
    path.write_text(text)
    with pytest.raises(ValueError, match=r"^init\[1\]: expected an expression starting with '\(', got "
                                         r"'\[\[\[+\.\.\.$"):
        load_scene(path)  # read: the brackets in the string are no nesting
    deep = "[" * (MAX_JSON_DEPTH - 2) + "]" * (MAX_JSON_DEPTH - 2)  # scene, start, then 14 lists
    path.write_text('{"objects": {}, "goal": ["(p)"], "start": {"gripper": ' + deep + "}}")
    with pytest.raises(ValueError, match=r"^start\.gripper: expected a number, got a list of 1 item"):
        load_scene(path)


def test_a_deep_or_self_containing_dict_is_refused_before_it_is_walked():
    deep: list = []
    for _ in range(3000):
        deep = [deep]
    with pytest.raises(ValueError, match=rf"^scene: expected lists and objects nested at most "
                                         rf"{MAX_JSON_DEPTH} levels deep"):
        scene_from_dict(_scene(start={"joints": deep}))
    loop: dict = {"goal": ["(pressed b1)"]}
    loop["objects"] = {"b1": loop}
    with pytest.raises(ValueError, match=r"^scene: .*or a structure that contains itself\)$"):
        scene_from_dict(loop)
    wide: list = []
    wide.extend([wide] * 1000)  # contains itself 1000 times: refused after a walk of 1000 * 16 items
    with pytest.raises(ValueError, match=r"^scene: expected lists and objects nested"):
        scene_from_dict(_scene(start={"joints": wide}))


def test_a_list_shared_by_several_keys_of_a_dict_is_read():
    down = [1.0, 0.0, 0.0, 0.0]
    doc = {"objects": {f"b{k}": {"type": "button", "position": [0.1 * k, 0, 0], "orientation": down}
                       for k in range(1, 40)}, "goal": ["(pressed b1)"], "start": {"orientation": down}}
    scene = scene_from_dict(doc)
    assert len(scene.objects) == 39 and scene.objects["b39"].orientation.tolist() == down
    np.testing.assert_array_equal(scene.start["orientation"], down)


@pytest.mark.parametrize("text, where", [
    ("(" * 3000 + ")" * 3000, "action"),
    ("(:action a :parameters () :effect " + "(and " * 3000 + "(p)" + ")" * 3001, "action"),
    ("(:action a :parameters () :effect " + "(not " * 3000 + "(p)" + ")" * 3001, "action"),
])
def test_pddl_nested_deeper_than_the_bound_is_one_line(text, where):
    with pytest.raises(ValueError, match=rf"^{where}: expected parentheses nested at most {MAX_PDDL_DEPTH} "
                                         r"deep \(STRIPS needs 5\), got deeper nesting at token \d+$"):
        parse_action(text)
    with pytest.raises(ValueError, match=r"^domain: expected parentheses nested at most"):
        parse_domain(f"(define (domain d) {text})")
    with pytest.raises(ValueError, match=r"^goal\[0\]: expected parentheses nested at most"):
        parse_atom(text, "goal[0]")


def test_pddl_at_the_bound_is_read():
    nested = "(and " * (MAX_PDDL_DEPTH - 3) + "(p ?b)" + ")" * (MAX_PDDL_DEPTH - 3)
    action = parse_action(f"(:action a :parameters (?b) :effect {nested})")  # (:action, (and ...)*29, (p)
    assert action.atoms() == [(False, "p", ("?b",))]


def test_names_of_the_wrong_type_or_length_in_pddl_are_short_lines():
    with pytest.raises(ValueError, match=r"^action: expected an action name .*got \(x\)$"):
        parse_action("(:action (x) :effect (p))")
    with pytest.raises(ValueError, match=r"^action a: expected keys :parameters.*got "
                                         r"':zzzzzz+\.\.\.$") as info:
        parse_action("(:action a :" + "z" * 5000 + " 1 :effect (p))")
    _one_line(info)


def _deep_scene(folder, levels=3000):
    path = folder / "scene.json"
    path.write_text(json.dumps(BUTTONS_DOC).replace('"init"', '"start": {"joints": ' + "[" * levels + "]"
                                                    * levels + '}, "x"', 1))
    return path


@pytest.mark.parametrize("case", ["deep scene", "type 5", "huge position", "deep domain"])
def test_cli_plan_on_bad_input_is_exit_2_one_line_and_writes_nothing(described_library, synthetic_db,
                                                                     tmp_path, cli, case):
    described_library.close()
    folder = tmp_path / "task"
    folder.mkdir()
    extra = []
    if case == "deep scene":
        scene, match = _deep_scene(folder), r"scene '.*': expected JSON nested at most 16 levels deep"
    elif case == "type 5":
        doc = json.loads(json.dumps(BUTTONS_DOC))
        doc["objects"]["b2"]["type"] = 5
        scene, match = write_scene(folder, doc), r"objects\['b2'\]\.type: expected a PDDL type name"
    elif case == "huge position":
        text = json.dumps(BUTTONS_DOC).replace("0.2", "1" + "0" * 400, 1)
        (folder / "scene.json").write_text(text)
        scene = folder / "scene.json"
        match = r"objects\['b1'\]\.position\[0\]: expected a number of magnitude"
    else:
        scene = write_scene(folder, BUTTONS_DOC)
        (folder / "deep.pddl").write_text("(define (domain d) " + "(" * 3000 + ")" * 3000 + ")")
        extra, match = ["--domain", folder / "deep.pddl"], r"domain deep\.pddl: expected parentheses nested"
    before = sorted(p.name for p in folder.iterdir())
    code, out, err = cli("plan", synthetic_db, "--scene", scene, *extra, "--out", folder / "plan.csv",
                         "--plot", folder / "plan.png", "--json")
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert re.search(r"^skillbank plan: error: " + match, err), err
    assert sorted(p.name for p in folder.iterdir()) == before


@pytest.mark.parametrize("doc, message", [
    ({"method": ["lte"]}, r"^binding\.method: expected one of \[.*\], got a list of 1 item\(s\)$"),
    ({"velocity": {}}, r"^binding\.velocity: expected 'zero' or 'free', got an object$"),
    ({"goal": [1]}, r"^binding\.goal: expected a parameter of the action \(\['\?b'\]\), got a list of 1"),
    ({"offset": [0, 0, True]}, r"^binding\.offset\[2\]: expected a number, got true$"),
    ({"offset": [0, HUGE, 0]}, r"^binding\.offset\[1\]: expected a number of magnitude at most 1e\+100, got "
                               r"an integer of 401 digits$"),
    ({"offset": "up"}, r"^binding\.offset: expected a list of 3 numbers, got the string 'up'$"),
    ({"orientation": [0, 0, 0, float("inf")]}, r"^binding\.orientation\[3\]: expected a finite number"),
    ({"gripper": {"start": True}}, r"^binding\.gripper\.start: expected a number, got true$"),
    ({"gripper": {"end": -HUGE}}, r"^binding\.gripper\.end: expected a number of magnitude at most 1e\+100"),
    ({"gripper": [1]}, r"^binding\.gripper: expected an object with 'start' and/or 'end', got a list of 1"),
    ({"obstacles": "o" * 500}, r"^binding\.obstacles: expected 'all' or a list of obstacle names, got the "
                               r"string 'ooo+\.\.\.'$"),
    ({"k": HUGE}, r"^binding\.k: expected an integer > 0 of magnitude at most 1e\+100, got an integer "
                  r"of 401"),
    ({"duration": True}, r"^binding\.duration: expected a number > 0, got bool True$"),
    ({"obstacles": json.loads("[" * 900 + "]" * 900)}, r"^binding: expected lists and objects nested at most "
                                                       r"16 levels deep"),
])
def test_bad_binding_values_are_one_line_naming_the_key(doc, message):
    from skillbank.planning import check_binding  # the binding checker

    with pytest.raises(ValueError, match=message) as info:
        check_binding(doc, [("?b", "button")])
    _one_line(info)


@pytest.mark.parametrize("body", ["[" * (15 * 2 ** 20), '{"goal": [' + "1" * (15 * 2 ** 20) + "]}",
                                  '{"objects": ' + '{"a": ' * (2 * 2 ** 20)],
                         ids=["15 MiB of [", "an integer of 15 million digits", "2 million nested objects"])
def test_cli_plan_of_a_15_mib_scene_built_to_hurt_is_one_line_within_1_gib(tmp_path, limited, body):
    path = tmp_path / "scene.json"
    path.write_text(body)
    code, out, err = limited("plan", tmp_path / "lib.db", "--scene", path, memory=1 << 30, timeout=120)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert re.match(r"skillbank plan: error: scene '.*scene\.json': expected JSON", err), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.json"]


def test_a_scene_file_above_the_size_bound_is_refused_unread(tmp_path):
    from skillbank.planning._scene import MAX_SCENE_BYTES  # the documented bound

    path = tmp_path / "scene.json"
    path.write_bytes(b" " * (MAX_SCENE_BYTES + 1))
    with pytest.raises(ValueError, match=rf"^scene: expected a file of at most {MAX_SCENE_BYTES} bytes, got "
                                         r"a larger one"):
        load_scene(path)
    path.write_bytes(b'{"goal": ["(p)"]}' + b" " * (MAX_SCENE_BYTES - 17))
    assert load_scene(path).goal == [("p", ())]


def test_the_depth_check_is_linear_on_strings_of_escaped_quotes(tmp_path, limited):
    """A string of 7 million escaped quotes, never closed: a regular expression that rescans from each
    quote is quadratic here (2 s for 10^4, 29 s for 4 * 10^4); the vectorised pass reads it once."""
    path = tmp_path / "scene.json"
    path.write_text('{"goal": ["' + '\\"' * (7 * 2 ** 20))
    code, out, err = limited("plan", tmp_path / "lib.db", "--scene", path, memory=1 << 30, timeout=120)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert re.match(r"skillbank plan: error: scene '.*': expected JSON, got Unterminated string", err), err


@pytest.mark.parametrize("word", ["and", "or", "not", "forall", "exists", "when", "imply", "either"])
def test_a_predicate_named_like_a_pddl_connective_is_refused_before_the_planner_sees_it(word):
    """jupyddl read ``(forall b1)`` in a goal as a quantifier and failed with an IndexError."""
    with pytest.raises(ValueError, match=rf"^goal\[0\]: expected a predicate name, got '{word}', a word of "
                                         r"PDDL's logic \(rename the predicate\)$"):
        scene_from_dict(_scene(goal=[f"({word} b1)"]))
    if word not in ("and", "not"):  # those two are read as the connectives they are
        with pytest.raises(ValueError, match=rf"^action a effect: expected a predicate name, got '{word}'"):
            parse_action(f"(:action a :parameters (?x) :effect (and (p ?x) ({word} ?x)))").atoms()


def test_pddl_the_planner_refuses_or_fails_on_is_one_line_naming_the_planner():
    """Past skillbank's reader (problem text written directly), jupyddl 2.4 raised an IndexError on a
    goal (forall b1) and a bare ValueError on (and): now one line naming the planner (or the goal)."""
    from skillbank.planning import domain_text, problem_text, solve  # written directly, past the checks

    domain = domain_text([parse_action("(:action press :parameters (?b - button) :effect (pressed ?b))")])
    for goal in (("forall", ("b1",)), ("exists", ()), ("and", ())):
        problem = problem_text({"b1": "button"}, [], [goal], domain=domain.name)
        with pytest.raises(ValueError, match=r"^(planner: the PDDL was refused: |planner: the search "
                                             r"failed on this task \(|goal: )") as info:
            solve(domain.text, problem)
        _one_line(info)
