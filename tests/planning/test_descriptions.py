"""Skill descriptions in the library: revisions, export and import, migration, and the command line."""

from __future__ import annotations

import json
import re
import sqlite3

import pytest

from skillbank.pipeline import Library

from .conftest import BUTTONS_DOC, PRESS, write_scene

PUSH = "(:action push :parameters (?b - button) :precondition (pressed ?b) :effect (pushed ?b))"


def test_each_description_is_a_new_revision_and_the_last_is_current(synthetic_library):
    lib = synthetic_library
    assert lib.describe("press", PRESS) == 1
    assert lib.describe("press", PRESS, {"offset": [0, 0, 0.01]}) == 2
    assert [(d["label"], d["revision"], d["binding"]) for d in lib.descriptions()] == \
        [("press", 2, {"offset": [0.0, 0.0, 0.01]})]
    assert lib.describe("press", None) == 3  # a removal is a revision too
    assert lib.descriptions() == [] and len(lib.descriptions(history=True)) == 3


@pytest.mark.parametrize("label, action, binding, message", [
    ("press", PUSH, None, r"action: expected an action named after the skill, 'press', got 'push'"),
    ("press", "(:action press :effect (pressed ?b))", None, r"uses \?b, which is not a parameter"),
    ("press", PRESS, {"goal": "?x"}, r"binding.goal: expected a parameter"),
    ("", PRESS, None, r"label: expected a non-empty string"),
])
def test_bad_descriptions_are_refused_and_nothing_is_stored(synthetic_library, label, action, binding,
                                                            message):
    with pytest.raises(ValueError, match=message):
        synthetic_library.describe(label, action, binding)
    assert synthetic_library.descriptions(history=True) == []


def test_descriptions_travel_with_an_export_as_a_copy_and_as_a_merge(synthetic_library, tmp_path,
                                                                     new_library):
    lib = synthetic_library
    lib.describe("press", PRESS)
    lib.describe("press", PRESS, {"offset": [0, 0, 0.01]})
    lib.export(tmp_path / "out")
    with Library(new_library("copy")) as copy:
        copy.import_folder(tmp_path / "out")
        assert copy.descriptions(history=True) == lib.descriptions(history=True)
    with Library(new_library("other")) as other:
        other.describe("press", PRESS)
        result = other.import_folder(tmp_path / "out")
        assert result["descriptions"] == {"press": 2}  # the export's current one, as a new revision
        assert other.descriptions()[0]["binding"] == {"offset": [0.0, 0.0, 0.01]}
        assert other.import_folder(tmp_path / "out")["descriptions"] == {}  # already current: nothing added


def test_a_version_2_library_gains_the_descriptions_table(tmp_path):
    path = tmp_path / "old.db"
    Library(path).close()
    conn = sqlite3.connect(path)
    conn.executescript("DROP TABLE skill_descriptions; PRAGMA user_version = 2;")
    conn.close()
    with Library(path) as lib:
        assert lib.store.conn.execute("PRAGMA user_version").fetchone()[0] == 3
        assert lib.describe("press", PRESS) == 1


def test_the_manifest_refuses_a_malformed_description(synthetic_library, tmp_path):
    synthetic_library.describe("press", PRESS)
    synthetic_library.export(tmp_path / "out")
    manifest = tmp_path / "out" / "manifest.json"
    doc = json.loads(manifest.read_text())
    doc["descriptions"][0]["binding"] = "offset"
    manifest.write_text(json.dumps(doc))
    with Library(tmp_path / "new.db") as lib, pytest.raises(ValueError, match=r"descriptions\[0\].binding: "
                                                                             r"expected an object"):
        lib.import_folder(tmp_path / "out")


def test_cli_describe_then_plan_prints_the_json_contract_and_writes_every_file(synthetic_library,
                                                                            synthetic_db, tmp_path, cli):
    db = synthetic_db
    synthetic_library.close()
    (tmp_path / "press.pddl").write_text(PRESS)
    code, out, err = cli("library", "describe", db, "press", "--action", tmp_path / "press.pddl", "--binding",
                         '{"offset": [0, 0, 0.0]}', "--json")
    assert code == 0 and json.loads(out)["revision"] == 1, err
    scene = write_scene(tmp_path, BUTTONS_DOC)
    code, out, err = cli("plan", db, "--scene", scene, "--out", tmp_path / "plan.csv", "--plot",
                         tmp_path / "plan.png", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert [s["action"] for s in doc["plan"]] == ["press", "press"]
    assert {"plan", "steps", "t", "streams", "collision", "constraint_error"} <= set(doc)
    assert set(doc["steps"][0]) >= {"action", "args", "skill", "start", "stop", "used"}
    for name in ("plan.csv", "plan.png", "plan.domain.pddl", "plan.problem.pddl"):
        assert (tmp_path / name).is_file()
    assert "(:action press" in (tmp_path / "plan.domain.pddl").read_text()


@pytest.mark.parametrize("change, message", [
    ({"goal": ["(pressed b1)", "(pushed b2)"]},
     r"skillbank plan: error: goal: no plan reaches \(pushed b2\)"),
    ({"obstacles": ["sphere:0.2,0.0,0.0,0.05"]}, r"skillbank plan: error: step \d \(press b1\): cannot avoid "
                                                 r"obstacle obstacles\[0\]"),
    ({"objects": {"b1": {"type": "button", "position": [0, 0]}}}, r"objects\['b1'\].position: expected 3"),
])
def test_cli_failures_are_one_line_exit_2_and_write_nothing(described_library, synthetic_db, tmp_path, cli,
                                                           change, message):
    db = synthetic_db
    described_library.close()
    folder = tmp_path / "task"
    folder.mkdir()
    scene = write_scene(folder, dict(BUTTONS_DOC, **change))
    code, out, err = cli("plan", db, "--scene", scene, "--out", folder / "plan.csv", "--plot",
                         folder / "plan.png")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert re.search(message, err), err
    assert sorted(p.name for p in folder.iterdir()) == ["scene.json"]


def test_cli_plan_with_a_skill_missing_names_the_step(synthetic_library, synthetic_db, tmp_path, cli):
    synthetic_library.describe("press", PRESS)
    synthetic_library.describe("push", PUSH)
    db = synthetic_db
    synthetic_library.close()
    scene = write_scene(tmp_path, dict(BUTTONS_DOC, goal=["(pushed b1)"]))
    code, _, err = cli("plan", db, "--scene", scene)
    assert code == 2 and "step 2 (push b1): skill 'push' has no usable primitive" in err


@pytest.mark.parametrize("binding, message", [
    ("{" + '"a": [' * 3000 + "]" * 3000 + "}", r"binding: expected JSON nested at most 16 levels deep"),
    ('{"offset": [0, 0, 1' + "0" * 5000 + "]}", r"binding: expected JSON, got Exceeds the limit"),
    ("{not json", r"binding: expected JSON, got Expecting property name"),
])
def test_cli_describe_binding_text_is_bounded_as_a_scene_is(synthetic_library, synthetic_db, tmp_path, cli,
                                                            library_content, binding, message):
    synthetic_library.close()
    (tmp_path / "press.pddl").write_text(PRESS)
    for given in (binding, tmp_path / "binding.json"):
        (tmp_path / "binding.json").write_text(binding)
        before = library_content(synthetic_db)
        code, out, err = cli("library", "describe", synthetic_db, "press",
                             "--action", tmp_path / "press.pddl", "--binding", given)
        assert code == 2 and out == "" and err.count("\n") == 1
        assert re.search(message.replace("binding: ", "binding( '[^']*')?: "), err), err
        assert library_content(synthetic_db) == before
