"""Progress bars on long work (reuse, cluster, export) on stderr; results the same with or without them."""

from __future__ import annotations

import numpy as np

from skillbank import Constraints, Demonstration
from skillbank.pipeline import Library


def test_reuse_progress_does_not_change_the_result(new_library, make_skills, capsys):
    """reuse with progress reports each adapted candidate; the ranking and result are unchanged."""
    with Library(new_library()) as lib:
        demos = make_skills()
        # ties in every criterion: two copies of each of the first three demonstrations
        lib.add_many(demos + [Demonstration(d.t, d.streams) for d in demos[:3]], segment=False, label="all")
        Y = demos[0]["position"]
        task = Constraints(start=Y[0], goal=Y[-1] + [0.1, 0.0, 0.0])
        for rank in ("shortlist", "length", "endpoints", "deformation"):
            quiet = lib.reuse("all", task, method="promp", rank=rank, random_state=0)
            shown = lib.reuse("all", task, method="promp", rank=rank, random_state=0, progress=True)
            assert shown.ranking == quiet.ranking and shown.used == quiet.used, rank
            np.testing.assert_array_equal(shown.trajectory["position"], quiet.trajectory["position"])
        err = capsys.readouterr().err
        assert "adapting" in err and "15/15" in err


def test_cluster_and_export_show_progress(tmp_path, new_library, make_skills, capsys):
    with Library(new_library()) as lib:
        lib.add_many(make_skills(), segment=False)
        capsys.readouterr()
        quiet = lib.cluster()
        assert capsys.readouterr().err == ""
        shown = lib.cluster(progress=True)
        assert "clustering" in capsys.readouterr().err
        assert lib.store.members(quiet) == lib.store.members(shown)
        lib.export(tmp_path / "a")
        assert capsys.readouterr().err == ""
        lib.export(tmp_path / "b", progress=True)
        err = capsys.readouterr().err
        assert "exporting" in err and "12/12" in err
        assert sorted(p.name for p in (tmp_path / "a" / "demonstrations").iterdir()) == \
            sorted(p.name for p in (tmp_path / "b" / "demonstrations").iterdir())
