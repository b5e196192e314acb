"""All representations on one LASA shape: constraints met, shape kept, demo reproduced.

Thresholds are the measured values (in the comments) with a margin; GShape's
extent is 35 mm. The shape measure is the relative RMS change of the discrete
curvature vectors (second differences) against the method's own unchanged
reproduction, so it isolates the effect of the new start and goal.
"""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.core import Constraints
from skillbank.representations import DMP, ElasticMap, JerkAccuracy, ProMP

# method -> (max reproduction error in mm, curvature deviation after a 5 % start/goal move)
MEASURED = {
    JerkAccuracy: (0.6, 0.4),  # measured 0.43, 0.27
    ProMP: (0.2, 0.1),  # 0.11, 0.062
    ElasticMap: (1.5, 0.3),  # 1.0, 0.19
    DMP: (0.03, 0.05),  # 0.014, 0.027
}


@pytest.mark.parametrize("cls", list(MEASURED))
def test_unchanged_constraints_reproduce_the_demo(cls, gshape):
    Y = gshape[0]["position"]
    plain = cls().fit(gshape[0]).reproduce()["position"]
    assert np.abs(plain - Y).max() < MEASURED[cls][0]
    # Start and goal given as the demo's own change nothing for the exact methods.
    same = cls().fit(gshape[0]).reproduce(Constraints(start=Y[0], goal=Y[-1]))["position"]
    if cls is not ProMP:  # ProMP conditions on them (to 1e-6) instead of returning the mean
        np.testing.assert_allclose(same, plain, atol=1e-9)
    else:
        assert np.abs(same - Y).max() < MEASURED[cls][0]


@pytest.mark.parametrize("cls", list(MEASURED))
def test_shifted_start_and_goal_keep_the_shape(cls, gshape, curvature_deviation):
    Y = gshape[0]["position"]
    extent = np.ptp(Y, axis=0).max()
    move = 0.05 * extent / np.sqrt(2)
    c = Constraints(start=Y[0] + [move, -move], goal=Y[-1] + [move, move])
    model = cls().fit(gshape[0])
    plain = model.reproduce()["position"]
    out = model.reproduce(c)["position"]
    tolerance = 0.02 if cls is DMP else 1e-6  # DMP: measured 0.011 mm
    assert c.position_error(out) < tolerance
    assert curvature_deviation(out, plain) < MEASURED[cls][1]


@pytest.mark.parametrize("cls", [JerkAccuracy, ProMP, ElasticMap])
def test_via_point_at_a_phase(cls, gshape):
    Y = gshape[0]["position"]
    c = Constraints(via=[(0.4, Y[400] + [0.5, 0.5]), (0.75, Y[750] - [0.5, 0.0])])
    for demos in (gshape[0], gshape):
        if cls is JerkAccuracy and demos is gshape:
            continue
        out = cls().fit(demos).reproduce(c)["position"]
        assert c.position_error(out) < 1e-6
        assert out.shape == (1000, 2)
