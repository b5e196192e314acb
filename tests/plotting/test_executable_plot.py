"""plot_executable: the pose path with tool frames and the joint curves of an executable reproduction."""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np
import pytest

from skillbank import Constraints, Demonstration, Sphere
from skillbank.experiments import synthetic_ur5e
from skillbank.plotting import plot_executable


def test_pose_and_joints_side_by_side(tmp_path):
    demo = synthetic_ur5e()
    c = Constraints(start=demo["position"][0], goal=demo["position"][-1],
                    obstacles=[Sphere(demo["position"][450], 0.02)])
    out = plot_executable(demo, tmp_path / "figs" / "ur5e.png", demos=[demo["position"]], constraints=c,
                          title="synthetic")
    assert out == tmp_path / "figs" / "ur5e.png"
    wide = mpimg.imread(out).shape
    # without joints, only the 3-D panel: a narrower figure
    pose = Demonstration(demo.t, {"position": demo["position"], "orientation": demo["orientation"]})
    narrow = mpimg.imread(plot_executable(pose, tmp_path / "pose.png")).shape
    assert wide[1] > 1.5 * narrow[1]


@pytest.mark.parametrize(
    ("trajectory", "match"),
    [
        (np.zeros((10, 3)), r"trajectory: expected a Demonstration with a 'position' stream, got ndarray"),
        (Demonstration(np.arange(5.0), {"position": np.zeros((5, 2))}),
         r"trajectory: expected a 3-D position stream, got 2 dimensions"),
    ],
)
def test_errors(tmp_path, trajectory, match):
    with pytest.raises(ValueError, match=match):
        plot_executable(trajectory, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()
