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


def _legend_names(ax) -> list[str]:
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_start_goal_and_obstacle_are_in_the_legend(tmp_path, drawn):
    demo = synthetic_ur5e()
    c = Constraints(start=demo["position"][0], goal=demo["position"][-1],
                    obstacles=[Sphere(demo["position"][450], 0.02)])
    plot_executable(demo, tmp_path / "ur5e.png", constraints=c)
    pose = drawn[-1].axes[0]
    assert {"reproduction", "start", "goal", "obstacle", "tool x"} <= set(_legend_names(pose))
    assert [pose.get_xlabel(), pose.get_ylabel(), pose.get_zlabel()] == ["x (m)", "y (m)", "z (m)"]


def test_a_moving_gripper_gets_an_axis_and_a_constant_one_does_not(tmp_path, drawn):
    demo = synthetic_ur5e()  # its gripper closes and opens
    plot_executable(demo, tmp_path / "moving.png")
    moving = drawn[-1]
    assert len(moving.axes) == 3 and moving.axes[2].get_ylabel() == "gripper (as recorded)"
    held = Demonstration(demo.t, {**demo.streams, "gripper": np.zeros((demo.n_steps, 1))}, demo.metadata)
    plot_executable(held, tmp_path / "held.png")
    fig = drawn[-1]
    assert len(fig.axes) == 2  # the pose and the joints: no axis for a gripper that never moves
    assert "gripper held at 0" in _legend_names(fig.axes[1])
    assert fig.axes[1].get_ylabel() == "joint angle (rad)" and fig.axes[1].get_xlabel() == "time (s)"
