"""Import semantics: an exact copy into an empty library, a merge into a non-empty one, idempotent."""

from __future__ import annotations

import json

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.cli import _main
from skillbank.pipeline import Library
from skillbank.store import copy_library, open_store


@pytest.fixture
def library_a(new_library, make_skills):
    """Library A: straight reaches 1-4, bowed ones 5-8, clustered, primitive 6 labelled."""
    location = new_library("a")
    with Library(location) as lib:
        lib.add_many(make_skills(4, seed=0), segment=False)
        lib.cluster()
        lib.label("straight-in-a", cluster=lib.primitives(demonstration=1)[0].cluster)
        lib.label("odd", primitive=6)
    return location


@pytest.fixture
def source(library_a, tmp_path):
    """Library A exported to a folder."""
    with Library(library_a) as lib:
        lib.export(tmp_path / "a")
    return tmp_path / "a"


@pytest.fixture
def target(new_library, make_skills):
    """Library B: A's first two demonstrations, then 4 straight and 4 bowed of its own; labelled."""
    shared = make_skills(4, seed=0)[:2]
    own = make_skills(4, seed=1)
    path = new_library("b")
    with Library(path) as lib:
        lib.add_many(shared + own, segment=False)
        lib.cluster()
        straight, bowed = (lib.primitives(demonstration=i)[0].cluster for i in (1, 7))
        assert straight != bowed
        lib.label("straight", cluster=straight)
        lib.label("bowed", cluster=bowed)
    return path


def test_into_an_empty_library_a_copy_then_a_second_import_changes_nothing(library_a, source, new_library,
                                                                            library_content):
    original = library_content(library_a)
    with Library(library_a) as a:
        n_prims = len(a.primitives(load=False))
    copy = new_library("c")
    with Library(copy) as c:
        first = c.import_folder(source)
        assert first["mode"] == "copy" and first["skipped"] == {} and first["assigned"] == {}
        assert first["demonstrations"] == {i: i for i in range(1, 9)} and first["versions"] == {1: 1}
    copied = library_content(copy)
    for table in ("demonstrations", "streams", "primitives", "cluster_versions", "cluster_members",
                  "cluster_labels"):
        assert copied[table] == original[table], table
    with Library(copy) as c:
        again = c.import_folder(source)
        assert again["mode"] == "merge" and again["skipped"] == {i: i for i in range(1, 9)}
        assert again["demonstrations"] == again["primitives"] == again["versions"] == again["assigned"] == {}
        assert len(c.primitives(load=False)) == n_prims and [v["version"] for v in c.versions()] == [1]
    assert library_content(copy) == copied


def test_into_a_non_empty_library_a_merge_that_keeps_its_clusters_and_labels(source, target, new_library,
                                                                              make_skills, library_content):
    # What Library.add would do with A's demonstrations 3-8: the known answer for their clusters.
    added_location = new_library("added")
    with open_store(target, readonly=True) as src, open_store(added_location) as dst:
        copy_library(src, dst)
    with Library(added_location) as added:
        ids = added.add_many(make_skills(4, seed=0)[2:], segment=False)
        expected = [added.primitives(demonstration=i)[0].cluster for i in ids]
    with Library(target) as b:
        version = b.store.current_version()
        versions, labels = b.versions(), b.store.cluster_labels(version)
        old_members = b.store.members(version)
        old = {p.id: p.label for p in b.primitives(load=False)}
        res = b.import_folder(source)
        assert res["mode"] == "merge" and res["versions"] == {}
        assert res["skipped"] == {1: 1, 2: 2}  # A's first two are B's first two, same content
        assert sorted(res["demonstrations"]) == [3, 4, 5, 6, 7, 8]
        assert sorted(res["demonstrations"].values()) == [11, 12, 13, 14, 15, 16]  # renumbered after B's 10
        # The library's own clustering is still the current one, with its labels and members.
        assert b.versions() == versions and b.store.current_version() == version
        assert b.store.cluster_labels(version) == labels
        members = b.store.members(version)
        assert {k: members[k] for k in old_members} == old_members
        assert {p.id: p.label for p in b.primitives(load=False) if p.id in old} == old
        # Every new primitive joined a cluster of that version: straight reaches the straight one, bowed
        # ones the bowed one (A's cluster label "straight-in-a" is not carried), A's own label kept.
        assert sorted(res["assigned"]) == sorted(res["primitives"].values())
        by_id = {p.id: p for p in b.primitives(load=False)}
        new = {old_id: by_id[new_id] for old_id, new_id in res["primitives"].items()}
        assert {old_id: p.label for old_id, p in new.items()} == {3: "straight", 4: "straight", 5: "bowed",
                                                                 6: "odd", 7: "bowed", 8: "bowed"}
        assert [new[i].cluster for i in range(3, 9)] == expected
        assert all(p.cluster == res["assigned"][p.id] for p in new.values())
        assert "straight-in-a" not in {p.label for p in by_id.values()}
        # reuse --skill finds the old primitives and the new ones of that skill.
        assert [p.id for p in b.skill("straight")] == sorted(
            [i for i, lab in old.items() if lab == "straight"] + [new[3].id, new[4].id])
    rows = library_content(target)
    with Library(target) as b:
        again = b.import_folder(source)
        assert again["demonstrations"] == {} and len(again["skipped"]) == 8
    assert library_content(target) == rows


def test_merge_into_an_unclustered_library_leaves_new_primitives_unclustered(source, new_library,
                                                                             make_reach):
    with Library(new_library("d")) as d:
        d.add(make_reach([0, 0, 0], [1, 1, 0]), segment=False)
        res = d.import_folder(source)
        assert res["mode"] == "merge" and len(res["demonstrations"]) == 8 and res["assigned"] == {}
        assert d.versions() == [] and {p.cluster for p in d.primitives(load=False)} == {None}
        assert [p.id for p in d.primitives(label="odd")] == [res["primitives"][6]]


def test_same_samples_with_other_metadata_or_streams_are_not_duplicates(source, new_library, make_skills):
    first = make_skills(4, seed=0)[0]
    other_meta = Demonstration(first.t, first.streams, {**first.metadata, "user": 2})
    extra = Demonstration(first.t, {**first.streams, "gripper": np.zeros(first.n_steps)}, first.metadata)
    with Library(new_library("e")) as e:
        e.add_many([first, other_meta, extra], segment=False)
        res = e.import_folder(source)
        assert res["skipped"] == {1: 1} and len(res["demonstrations"]) == 7


def test_cli_reports_added_and_skipped(source, new_library, capsys):
    db = new_library("f")
    capsys.readouterr()
    assert _main.main(["library", "import", str(db), str(source), "--json"]) == 0
    first = json.loads(capsys.readouterr().out)
    assert first["mode"] == "copy" and first["added"] == {"demonstrations": 8, "primitives": 8, "versions": 1}
    assert first["skipped"] == 0 and first["duplicates"] == {} and first["demonstrations"]["8"] == 8
    assert _main.main(["library", "import", str(db), str(source), "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["mode"] == "merge" and again["skipped"] == 8 and again["assigned"] == 0
    assert again["added"] == {"demonstrations": 0, "primitives": 0, "versions": 0}
    assert again["duplicates"] == {str(i): i for i in range(1, 9)}
    assert _main.main(["library", "import", str(db), str(source)]) == 0
    out = capsys.readouterr().out
    assert "imported 0 demonstration(s), 0 primitive(s), 0 clustering version(s) (merged)" in out
    assert "skipped 8 demonstration(s) already in the library" in out
