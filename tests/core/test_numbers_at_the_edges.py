"""Numbers at the edges (issue 12, item 4): each reported failure, reproduced, now one clear error.

Before the fix: ``edit --obstacle sphere:0,0,1e300`` (and ``library reuse``) and ``edit --method
dmp`` on time stamps near 1e302 ended in an OverflowError traceback; ``edit`` on coordinates near
1e300 printed "frechet inf"; ±1e300 features gave one cluster with energy NaN. Now the validator
bounds every magnitude by MAX_MAGNITUDE, what still overflows inside a solver becomes a ValueError
naming the step, and results are checked finite.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from skillbank.clustering import ElasticClustering
from skillbank.core import Constraints, Demonstration, Sphere
from skillbank.core._validation import MAX_MAGNITUDE
from skillbank.editing import lte
from skillbank.metrics import frechet_distance, jerk_cost
from skillbank.representations import DMP

_BOUND = r"expected (values|numbers) of magnitude at most 1e\+100"


def _csv(path, t, Y):
    """Written by hand: a Demonstration can no longer hold these values."""
    header = ",".join(["t"] + [f"p{k}" for k in range(Y.shape[1])])
    np.savetxt(path, np.column_stack([t, Y]), fmt="%.17g", delimiter=",", header=header, comments="")
    return path


@pytest.fixture
def arc(tmp_path):
    t = np.linspace(0.0, 1.0, 60)
    return t, np.column_stack([t, np.sin(np.pi * t), 0.5 * t])


def _one_line_error(code, out, err, command, match):
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"skillbank {command}: error: "), err
    assert re.search(match, err), err


def test_edit_sphere_of_radius_1e300_is_refused(cli, arc, tmp_path):
    path = _csv(tmp_path / "arc.csv", *arc)
    code, out, err = cli("edit", path, "--obstacle", "sphere:0,0,0,1e300")
    _one_line_error(code, out, err, "edit", rf"obstacle: {_BOUND}.*got '1e300' in 'sphere:0,0,0,1e300'")


def test_library_reuse_sphere_of_radius_1e300_is_refused(cli, arc, tmp_path):
    t, Y = arc
    files = [_csv(tmp_path / f"d{k}.csv", t, Y + 0.01 * k) for k in range(2)]
    db = tmp_path / "lib.db"
    assert cli("library", "init", db)[0] == 0
    assert cli("library", "add", db, *files, "--whole", "--label", "press")[0] == 0
    code, out, err = cli("library", "reuse", db, "--skill", "press", "--obstacle", "sphere:0,0,0,1e300")
    _one_line_error(code, out, err, "library reuse", rf"obstacle: {_BOUND}.*'sphere:0,0,0,1e300'")
    # A large sphere inside the bound is handled: the edit cannot avoid it, and says so.
    code, out, err = cli("library", "reuse", db, "--skill", "press", "--method", "lte",
                         "--obstacle", "sphere:0,0,0,1e99")
    assert code == 2 and "no usable candidate: " in err and "pinned by a constraint" in err


def test_edit_dmp_on_time_stamps_near_1e302_is_refused(cli, arc, tmp_path):
    t, Y = arc
    path = _csv(tmp_path / "late.csv", 1e302 + t * 1e300, Y)
    code, out, err = cli("edit", path, "--method", "dmp")
    _one_line_error(code, out, err, "edit", rf"cannot read .*late.csv.*t: {_BOUND}.*got 1e\+302 at index 0")


def test_dmp_is_independent_of_the_time_scale(arc):
    """DMP works in phase time, so durations of 1e-200 s or 1e90 s give the same path (no t^2, 1/dt^2)."""
    t, Y = arc
    ref = DMP().fit(Demonstration(t, {"position": Y})).reproduce(Constraints(goal=[1.2, 0.1, 0.4]))
    for scale in (1e-200, 1e90):
        demo = Demonstration(t * scale, {"position": Y})
        out = DMP().fit(demo).reproduce(Constraints(goal=[1.2, 0.1, 0.4]))
        np.testing.assert_allclose(out["position"], ref["position"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(out.t, t * scale, rtol=1e-12)


def test_edit_on_coordinates_near_1e300_is_refused_and_near_the_bound_is_finite(cli, arc, tmp_path):
    t, Y = arc
    code, out, err = cli("edit", _csv(tmp_path / "huge.csv", t, Y * 1e300), "--metrics")
    _one_line_error(code, out, err, "edit", rf"streams\['position'\]: {_BOUND}")
    code, out, err = cli("edit", _csv(tmp_path / "big.csv", t, Y * 1e98), "--metrics", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert all(np.isfinite(v) for v in doc["metrics"].values())
    assert doc["metrics"]["frechet"] == 0.0


def test_cluster_on_features_of_1e300_is_refused(cli, tmp_path):
    features = tmp_path / "f.csv"
    features.write_text("a,b\n1e300,0\n-1e300,0\n1e300,1\n-1e300,1\n")
    code, out, err = cli("cluster", features)
    _one_line_error(code, out, err, "cluster", rf"features: {_BOUND}.*got 1e\+300 at index \(0, 0\)")


def test_clustering_near_the_bound_is_finite():
    X = np.array([[1e99, 0.0], [1e99, 1.0], [-1e99, 0.0], [-1e99, 1.0]])
    # the search alone: two pairs
    model = ElasticClustering(random_state=0, significance=None).fit(X)
    assert np.isfinite(model.energy_) and np.isfinite(model.cluster_centers_).all()
    assert sorted(np.bincount(model.labels_)) == [2, 2]
    # with the significance test (the default), finite too; two points a side prove no second skill
    model = ElasticClustering(random_state=0).fit(X)
    assert np.isfinite(model.energy_) and np.isfinite(model.cluster_centers_).all()


@pytest.mark.parametrize("call", [
    lambda: lte(np.ones((5, 2)) + 1j),
    lambda: DMP().fit(np.ones((5, 2), dtype=complex)),
    lambda: ElasticClustering().fit([[1.0 + 2.0j], [0.0]]),
    lambda: frechet_distance([[0.0, 1j]], [[0.0, 0.0]]),
    lambda: Sphere([0.0, 0.0], 1.0 + 0.5j),
], ids=["lte", "dmp", "clustering", "frechet", "sphere"])
def test_complex_input_is_rejected_by_name(call):
    name = r"^(Y|demos\[0\]|X|P|sphere radius)"
    with pytest.raises(ValueError, match=name + r": expected (a )?real numbers?, got complex"):
        call()


def test_overflow_inside_a_solver_names_the_step():
    """Inside the bound, a huge path on a tiny time step still overflows: one ValueError naming the step."""
    t = np.linspace(0.0, 1e-250, 20)
    Y = 1e99 * np.column_stack([np.linspace(0.0, 1.0, 20), np.zeros(20)])
    with pytest.raises(ValueError, match=r"^DMP\.fit: the computation overflowed or became undefined "):
        DMP().fit(Demonstration(t, {"position": Y}))
    cubic = 1e99 * np.linspace(0.0, 1.0, 20)[:, None] ** 3  # its jerk is 6e99 / (1e-250)^3
    with pytest.raises(ValueError, match=r"^jerk_cost: the computation overflowed .*beyond what it handles$"):
        jerk_cost(cubic, t)


def test_lte_refuses_a_soft_weight_whose_square_underflows():
    Y = np.column_stack([np.linspace(0.0, 1.0, 10), np.zeros(10)])
    with pytest.raises(ValueError, match=r"^weight: expected a number in \[1e-100, 1e\+100\], got 1e-300"):
        lte(Y, Constraints(goal=[1.0, 1.0]), hard=False, weight=1e-300)
    res = lte(Y, Constraints(goal=[1.0, 1.0]), hard=False, weight=1e-100)
    assert np.isfinite(res.Y).all()


def test_lte_at_the_bound_is_finite():
    Y = MAX_MAGNITUDE / 2 * np.column_stack([np.linspace(-1.0, 1.0, 40), np.zeros(40)])
    res = lte(Y, Constraints(goal=[MAX_MAGNITUDE / 2, MAX_MAGNITUDE / 4],
                             obstacles=[Sphere([0.0, 0.0], MAX_MAGNITUDE / 10)]))
    assert res.success and np.isfinite(res.Y).all()
