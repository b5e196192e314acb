"""Library: add, segment, cluster, label, query, remove, provenance."""

from __future__ import annotations

import sqlite3

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.pipeline import Library
from skillbank.store._arrays import from_npy, to_npy


@pytest.fixture
def lib(new_library):
    """An empty library, once on each store backend."""
    with Library(new_library()) as library:
        yield library


@pytest.fixture
def reach(make_reach):
    return make_reach


@pytest.fixture
def two_skills(make_skills):
    return make_skills


def test_npy_round_trip_refuses_pickles():
    a = np.arange(12.0).reshape(3, 4)
    assert np.array_equal(from_npy(to_npy(a)), a)
    with pytest.raises(ValueError, match="numeric array"):
        to_npy(np.array([{"a": 1}], dtype=object))
    import io

    buf = io.BytesIO()
    np.save(buf, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError, match="not a numeric .npy"):
        from_npy(buf.getvalue())


def test_wal_mode_and_schema_version(tmp_path):
    Library(tmp_path / "a.db").close()
    conn = sqlite3.connect(tmp_path / "a.db")
    assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    assert conn.execute("PRAGMA user_version").fetchone()[0] == Library.schema_version == 3
    conn.close()


def test_demonstration_is_stored_losslessly(lib):
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.001, 0.01, 50))
    demo = Demonstration(t, {"joints": rng.standard_normal((50, 6)), "position": rng.standard_normal((50, 3)),
                             "gripper": rng.standard_normal((50, 1))}, {"user": "7", "nested": {"a": [1, 2]}})
    did = lib.add(demo, segment=False, source="robot.h5")
    back = lib.demonstration(did)
    assert back.stream_names == ["joints", "position", "gripper"]
    assert np.array_equal(back.t, t)
    for name in demo.streams:
        assert np.array_equal(back[name], demo[name])
    assert back.metadata == {"user": "7", "nested": {"a": [1, 2]}}
    [prim] = lib.primitives(source="robot.h5")
    assert (prim.start, prim.stop, prim.n_steps) == (0, 50, 50)
    assert np.array_equal(prim.demo["joints"], demo["joints"])
    assert lib.provenance(did) == {"segment": False}


def test_segmentation_bounds_tile_the_demo_and_provenance_is_recorded(lib):
    t = np.linspace(0.0, 2.0, 400)
    Y = np.column_stack([np.minimum(t, 1.0), np.maximum(t - 1.0, 0.0), 0 * t])
    did = lib.add(Demonstration.from_array(Y, t), segmentation={"window": 16})
    prims = lib.primitives(demonstration=did)
    assert len(prims) == 2
    assert prims[0].start == 0 and prims[-1].stop == 400 and prims[0].stop == prims[1].start
    assert np.array_equal(np.vstack([p.demo["position"] for p in prims]), Y)
    prov = lib.provenance(did)
    assert prov["segment"] is True and prov["requested"]["window"] == 16
    assert prov["resolved"]["position"]["window"] == 16


def test_cluster_label_query_and_incremental_assignment(lib, reach, two_skills):
    lib.add_many(two_skills(), segment=False)
    assert lib.summary()["skills"] == []
    version = lib.cluster()
    assert version == 1
    doc = lib.summary()
    assert [s["count"] for s in doc["skills"]] == [6, 6]
    clusters = [p["cluster"] for p in doc["primitives"]]
    straight, bowed = clusters[0], clusters[6]
    assert straight != bowed and clusters == [straight] * 6 + [bowed] * 6
    lib.label("straight", cluster=straight)
    assert [p.id for p in lib.primitives(label="straight")] == [1, 2, 3, 4, 5, 6]
    # A primitive's own label overrides its cluster's.
    lib.label("special", primitive=2)
    assert [p.id for p in lib.primitives(label="straight")] == [1, 3, 4, 5, 6]
    assert lib.primitives(label="special")[0].cluster == straight
    # New primitives go to the nearest centre under the stored featuriser.
    new_bowed = lib.add(reach([0, 0, 0], [1.0, -0.7, 0], bend=0.8, seed=50), segment=False)
    new_straight = lib.add(reach([3, 1, 2], [2.2, 1.8, 2], seed=51), segment=False)
    assert lib.primitives(demonstration=new_bowed)[0].cluster == bowed
    p = lib.primitives(demonstration=new_straight)[0]
    assert p.cluster == straight and p.label == "straight" and p.features.shape == (3,)
    unassigned = lib.add(reach([0, 0, 0], [1, 1, 0], seed=52), segment=False, assign="none")
    assert lib.primitives(demonstration=unassigned)[0].cluster is None
    assert len(lib.primitives(cluster=straight)) == 7  # 6 fitted + 1 assigned


def test_recluster_adds_a_version_and_carries_labels(lib, reach, two_skills):
    lib.add_many(two_skills(), segment=False)
    lib.cluster()
    first = lib.summary()["primitives"][0]["cluster"]
    lib.label("straight", cluster=first)
    version = lib.cluster(stretch=0.5, random_state=3)
    assert version == 2
    assert [v["version"] for v in lib.versions()] == [1, 2]
    assert lib.versions()[1]["params"]["stretch"] == 0.5
    assert lib.clustering_params(1)["stretch"] == 1.2
    assert [p.id for p in lib.primitives(label="straight")] == [1, 2, 3, 4, 5, 6]
    ids = lib.add_many([reach([0, 0, 0], [1, 0.5, 0], seed=60)], segment=False, assign="recluster")
    assert lib.versions()[-1]["version"] == 3 and lib.versions()[-1]["params"]["stretch"] == 0.5
    assert lib.primitives(demonstration=ids[0])[0].label == "straight"


def test_remove_deletes_primitives_and_memberships(lib, two_skills):
    ids = lib.add_many(two_skills(), segment=False)
    lib.cluster()
    lib.remove(ids[0])
    assert lib.demonstration_ids() == ids[1:]
    assert [p.demonstration_id for p in lib.primitives()] == ids[1:]
    n = lib.store.conn.execute("SELECT COUNT(*) FROM cluster_members").fetchone()[0]
    assert n == 11 and lib.store.conn.execute("SELECT COUNT(*) FROM streams").fetchone()[0] == 11
    with pytest.raises(ValueError, match="no demonstration with id 1"):
        lib.remove(ids[0])


def test_add_is_all_or_nothing(lib, reach):
    lib.add(reach([0, 0, 0], [1, 1, 0]), segment=False)
    bad = reach([0, 0, 0], [1, 1, 0])
    # the provenance row is written before the metadata fails to serialise, inside the same transaction
    bad.metadata["handle"] = object()
    with pytest.raises(TypeError, match="cannot convert object to JSON"):
        lib.add(bad, segment=False)
    for table in ("demonstrations", "streams", "primitives", "provenance"):
        assert lib.store.conn.execute(f"SELECT COUNT(*) FROM {table}").fetchone()[0] == 1, table  # noqa: S608


def test_errors(lib, reach, two_skills, new_library):
    with pytest.raises(ValueError, match="expected a Demonstration"):
        lib.add(np.zeros((5, 2)))
    with pytest.raises(ValueError, match="'position' stream"):
        lib.add(Demonstration(np.arange(5.0), {"force": np.zeros((5, 3))}))
    with pytest.raises(ValueError, match="assign: expected one of"):
        lib.add(reach([0, 0], [1, 1]), assign="sometimes")
    with pytest.raises(ValueError, match="label: expected a non-empty string"):
        lib.add(reach([0, 0], [1, 1]), label="  ")
    with pytest.raises(ValueError, match="at least 2 primitives"):
        lib.cluster()
    with pytest.raises(ValueError, match="no clusters yet"):
        lib.label("x", cluster=0)
    with pytest.raises(ValueError, match="exactly one of"):
        lib.label("x")
    with pytest.raises(ValueError, match="no primitive with id 99"):
        lib.label("x", primitive=99)
    lib.add_many(two_skills(), segment=False)
    lib.cluster()
    with pytest.raises(ValueError, match=r"cluster id in 0\.\.1"):
        lib.label("x", cluster=5)
    with pytest.raises(ValueError, match="features: expected one of"):
        lib.cluster(features="wavelets")
    with pytest.raises(ValueError, match="skill: no primitive has label 'nope'"):
        lib.skill("nope")
    with pytest.raises(ValueError, match="skill: expected a label"):
        lib.skill(1.5)
    with pytest.raises(ValueError, match="does not exist"):
        Library(new_library("missing"), create=False)  # a missing file, or a database without a library


def test_closed_library(new_library):
    lib = Library(new_library())
    lib.close()
    lib.close()
    with pytest.raises(ValueError, match="is closed"):
        lib.summary()


def test_reuse_is_selection_on_the_skill_primitives(lib, two_skills):
    """Library.reuse's own part: the skill's primitives (ids kept) go to skillbank.selection.reuse."""
    from skillbank import Constraints
    from skillbank.selection import SHORTLIST, reuse

    lib.add_many(two_skills(), segment=False)
    lib.cluster()
    cluster = lib.primitives(demonstration=7)[0].cluster
    lib.label("bow", cluster=cluster)
    prims = lib.primitives(label="bow")
    assert [p.id for p in prims] == [7, 8, 9, 10, 11, 12]
    assert all(p.demo.metadata["primitive_id"] == p.id for p in prims)
    task = Constraints(goal=prims[0].demo["position"][-1] + 0.05)
    mine = lib.reuse("bow", task, method="ja", random_state=4)
    direct = reuse([p.demo for p in prims], task, method="ja", ids=[p.id for p in prims], rank="shortlist",
                   shortlist=SHORTLIST, random_state=4)
    assert mine.used == direct.used and mine.ranking == direct.ranking
    np.testing.assert_array_equal(mine.trajectory["position"], direct.trajectory["position"])
    assert lib.reuse(cluster, task, method="ja").used == mine.used  # by cluster id too


def test_primitives_added_while_clustering_join_the_new_version(new_library, backend, two_skills):
    """Another process adds a demonstration between the fit and the write of a clustering version."""
    location = new_library()
    demos = two_skills()
    late = demos.pop()
    with Library(location) as lib:
        write_version = lib.store.add_version

        def racing(**kwargs):
            with Library(location) as other:  # a second writer, as another process would be
                other.add(late, segment=False, assign="none")
            return write_version(**kwargs)

        lib.store.add_version = racing
        lib.add_many(demos, segment=False)
        version = lib.cluster()
        prims = lib.primitives()
        assert len(prims) == len(demos) + 1 and all(p.cluster is not None for p in prims)
        members = lib.store.members(version)
        assert set(members) == {p.id for p in prims}
        mark = "?" if backend == "sqlite" else "%s"
        assigned = dict(lib.store.conn.execute(
            f"SELECT primitive_id, assigned FROM cluster_members WHERE version = {mark}",  # noqa: S608
            (version,)).fetchall())
        assert assigned[prims[-1].id] == "incremental" and list(assigned.values()).count("fit") == len(demos)
        # the late one, a bowed reach, joins the bowed reaches' cluster, not the straight ones'
        assert prims[-1].cluster == prims[-2].cluster != prims[0].cluster


def test_sparse_labels_one_primitive_labels_its_cluster_and_reclustering_keeps_it(lib, reach, two_skills):
    lib.add_many(two_skills(), segment=False)
    lib.cluster()
    clusters = [p["cluster"] for p in lib.summary()["primitives"]]
    straight, bowed = clusters[0], clusters[6]
    # the paper's sparse labels: a person names one primitive, its cluster carries the name
    lib.label("reach", primitive=3)
    found = lib.primitives(label="reach", load=False)
    assert [p.id for p in found] == [1, 2, 3, 4, 5, 6]
    assert {p.id: p.label_source for p in found} == {1: "inferred", 2: "inferred", 3: "given",
                                                     4: "inferred", 5: "inferred", 6: "inferred"}
    skills = {s["cluster"]: s for s in lib.summary()["skills"]}
    assert skills[straight]["label"] == "reach" and skills[straight]["label_source"] == "inferred"
    assert skills[bowed]["label"] is None and skills[bowed]["label_source"] is None
    # a primitive's own label stays its own; a label given to the cluster wins over an inferred one
    lib.label("curve", cluster=bowed)
    lib.label("swerve", primitive=8)
    assert [p.id for p in lib.primitives(label="curve", load=False)] == [7, 9, 10, 11, 12]
    # members labelled differently are an ambiguity: nothing is inferred for the others
    lib.label("dash", primitive=4)
    assert [p.id for p in lib.primitives(label="reach", load=False)] == [3]
    assert lib.primitives(demonstration=2, load=False)[0].label is None
    lib.label(None, primitive=4)
    # reclustering keeps what the person said: the primitive's label, inferred again in the new version
    lib.cluster(stretch=0.5, random_state=3)
    assert [p.id for p in lib.primitives(label="reach", load=False)] == [1, 2, 3, 4, 5, 6]
    assert lib.primitives(demonstration=3, load=False)[0].label_source == "given"


def test_a_version_records_the_significance_level_it_was_clustered_with(tmp_path):
    from skillbank.experiments._demo import synthetic_multistream

    with Library(tmp_path / "lib.sqlite") as lib:
        for seed in range(3):
            lib.add(synthetic_multistream(random_state=seed), assign="none")
        lib.cluster()
        assert lib.clustering_params()["significance"] == 0.01
