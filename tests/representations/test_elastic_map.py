"""ElasticMap: fixed nodes, monotone EM, straight lines, several demonstrations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from skillbank.core import Constraints, ViaPoint
from skillbank.representations import ElasticMap


def test_fixed_nodes_are_met_exactly(gshape):
    Y = gshape[0]["position"]
    c = Constraints(start=Y[0] + [1.0, -2.0], goal=Y[-1] + [3.0, 3.0],
                    via=[(0.3, Y[300] + [1.0, 1.0]), ViaPoint(Y[800] - 1.0, index=800)])
    model = ElasticMap().fit(gshape[0])
    out = model.reproduce(c)["position"]
    assert c.position_error(out) == 0.0
    by_phase = Constraints(start=c.start, goal=c.goal, via=c.via[:1])
    short = model.reproduce(by_phase, n_steps=257)["position"]
    assert by_phase.position_error(short) == 0.0


@pytest.mark.parametrize("phase_weight", [0.0, 10.0])
def test_energy_never_increases(gshape, phase_weight):
    model = ElasticMap(phase_weight=phase_weight, max_iter=40, tol=0.0).fit(gshape[:3])
    history = np.array(model.energy_history_)
    assert model.n_iter_ >= 2
    assert np.all(np.diff(history) <= 1e-12 * history[0])
    assert history[-1] < history[0]
    np.testing.assert_allclose(model.energy(model.nodes_), history[-1], rtol=1e-12)
    Y = gshape[0]["position"]
    model.reproduce(Constraints(goal=Y[-1] + [2.0, 2.0]))
    history = np.array(model.energy_history_)
    assert np.all(np.diff(history) <= 1e-12 * history[0])


def test_straight_line_gives_a_straight_line():
    s = np.linspace(0, 1, 120) ** 1.5  # uneven speed along the line
    line = np.column_stack([2 * s, 1 - s, 3 * s])
    model = ElasticMap(stretch=1e-3, bend=1e-3).fit(line)
    out = model.reproduce()["position"]
    direction = (line[-1] - line[0]) / np.linalg.norm(line[-1] - line[0])
    off = (out - line[0]) - np.outer((out - line[0]) @ direction, direction)
    assert np.abs(off).max() < 1e-9  # round-off only, on a line of length 3.7
    np.testing.assert_allclose(out[[0, -1]], line[[0, -1]])


def test_reproduces_demo_and_the_mean_of_several(gshape):
    Y = gshape[0]["position"]
    single = ElasticMap().fit(gshape[0]).reproduce()["position"]
    assert np.abs(single - Y).max() < 1.5  # mm; measured 1.0 (extent 35 mm)
    several = ElasticMap().fit(gshape).reproduce()["position"]
    mean = np.mean([d["position"] for d in gshape], axis=0)
    assert np.abs(several - mean).max() < 1.5  # measured 0.95
    # Purely spatial assignment keeps the curve (not the timing).
    spatial = ElasticMap(phase_weight=0.0).fit(gshape[0]).reproduce()["position"]
    assert cKDTree(Y).query(spatial)[0].max() < 1.0


def test_errors(gshape, arc):
    with pytest.raises(ValueError, match="ElasticMap does not support start/end velocity"):
        ElasticMap().fit(arc).reproduce(Constraints(start_velocity=[0.0, 1.0]))
    with pytest.raises(ValueError, match="n_nodes: expected at least 3 nodes, got 2"):
        ElasticMap(n_nodes=2).fit(arc)
    with pytest.raises(ValueError, match="stretch: expected a number >= 0, got -1"):
        ElasticMap(stretch=-1).fit(arc)
    with pytest.raises(ValueError, match="bend: expected a number >= 0"):
        ElasticMap(bend="x").fit(arc)
    with pytest.raises(ValueError, match="phase_weight: expected a number >= 0, got -2"):
        ElasticMap(phase_weight=-2).fit(arc)
    with pytest.raises(ValueError, match="max_iter: expected an integer > 0, got 0"):
        ElasticMap(max_iter=0).fit(arc)
    with pytest.raises(ValueError, match="the map is underdetermined"):
        ElasticMap(stretch=0.0, bend=0.0, n_nodes=50).fit(np.zeros((5, 2)) + np.arange(5)[:, None])
    with pytest.raises(ValueError, match="nodes: expected 2 columns, got 3"):
        ElasticMap().fit(arc).energy(np.zeros((10, 3)))
