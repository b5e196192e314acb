"""Export to a folder of NPZ files plus a JSON manifest, and import back."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.pipeline import Library


def _everything(lib):
    """Every table's content, arrays compared by value."""
    conn = lib.store.conn
    out = {}
    for table, order in (("demonstrations", "id"), ("streams", "demonstration_id, position"),
                         ("primitives", "id"), ("cluster_versions", "version"),
                         ("cluster_members", "version, primitive_id"),
                         ("cluster_labels", "version, cluster")):
        rows = conn.execute(f"SELECT * FROM {table} ORDER BY {order}").fetchall()  # noqa: S608
        out[table] = [tuple(np.load(io.BytesIO(v), allow_pickle=False).tolist()
                            if isinstance(v, bytes) else v for v in row) for row in rows]
    out["provenance"] = [lib.provenance(i) for i in lib.demonstration_ids()]
    return out


@pytest.fixture
def full(new_library, make_skills):
    lib = Library(new_library("src"))
    skills = make_skills()
    skills[0] = Demonstration(skills[0].t, {**skills[0].streams, "force": np.arange(120.0).reshape(60, 2)},
                              {"source": "robot.h5", "user": 3})
    t = np.linspace(0.0, 2.0, 400)
    lib.add(Demonstration.from_array(np.column_stack([np.minimum(t, 1), np.maximum(t - 1, 0), 0 * t]), t),
            segmentation={"window": 16}, assign="none")
    lib.add_many(skills, segment=False)
    lib.cluster()
    lib.label("straight", cluster=lib.primitives(demonstration=2)[0].cluster)
    lib.cluster(stretch=0.6)
    lib.label("odd", primitive=3)
    lib.add(make_skills(1, seed=4)[0], segment=False)  # incremental member of version 2
    yield lib
    lib.close()


def test_round_trip_keeps_everything(full, tmp_path, new_library):
    manifest = full.export(tmp_path / "out")
    doc = json.loads(manifest.read_text())
    assert doc["format"] == "skillbank-library" and len(doc["demonstrations"]) == 14
    assert len(doc["versions"]) == 2
    with Library(new_library("copy")) as copy:
        maps = copy.import_folder(tmp_path / "out")
        assert maps["demonstrations"] == {i: i for i in full.demonstration_ids()}
        assert _everything(copy) == _everything(full)
        assert copy.summary() == full.summary()
        assert copy.demonstration(2).metadata == {"source": "robot.h5", "user": 3}
        assert np.array_equal(copy.demonstration(2)["force"], np.arange(120.0).reshape(60, 2))
        # The imported library keeps working: incremental assignment uses the imported featuriser.
        new = copy.add(full.demonstration(5), segment=False)
        assert copy.primitives(demonstration=new)[0].cluster == full.primitives(demonstration=5)[0].cluster


def test_import_into_a_non_empty_library_merges_and_renumbers(full, tmp_path, new_library, make_reach):
    full.export(tmp_path / "out")
    with Library(new_library("other")) as other:
        other.add(make_reach([0, 0, 0], [1, 1, 0]), segment=False)
        maps = other.import_folder(tmp_path / "out")
        assert maps["mode"] == "merge" and maps["skipped"] == {}
        assert maps["demonstrations"][1] == 2 and len(maps["demonstrations"]) == 14
        assert other.summary()["n_demonstrations"] == 15
        # The imported clusterings describe another population: not added (see test_import_merge.py).
        assert other.versions() == [] and maps["versions"] == {}
        assert [p.id for p in other.primitives(label="odd")] == [maps["primitives"][3]]


def test_export_and_import_errors(full, tmp_path):
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "x.txt").write_text("x")
    with pytest.raises(ValueError, match="not empty"):
        full.export(tmp_path / "busy")
    with pytest.raises(ValueError, match="expected manifest.json"):
        full.import_folder(tmp_path / "busy")
    full.export(tmp_path / "out")
    manifest = tmp_path / "out" / "manifest.json"
    doc = json.loads(manifest.read_text())
    (tmp_path / "out" / doc["demonstrations"][3]["file"]).unlink()
    n = full.summary()["n_demonstrations"]
    with pytest.raises(ValueError, match="cannot read|missing|no such"):
        full.import_folder(tmp_path / "out")
    assert full.summary()["n_demonstrations"] == n  # nothing half-imported
    doc["schema_version"] = 99
    manifest.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="newer skillbank"):
        full.import_folder(tmp_path / "out")
