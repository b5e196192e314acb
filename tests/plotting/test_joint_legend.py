"""plot_executable's joint panel (issue 44, item 6): its legend hides no joint curve.

Six joint curves spread over the panel and a gripper on a twin axis left no
corner for ``loc="best"``, which does not see the twin axis' line: the legend
sat over the joints (reach_ur5e.png, three_button_reuse_ur5e.png). It is
now under the panel, and the figure stays within its width.
"""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np

import skillbank
from skillbank.plotting import plot_executable

from .test_glance import _renderer


def _trajectory():
    t = np.linspace(0.0, 2.5, 120)
    s = t / t[-1]
    position = np.c_[-0.36 + 0.05 * s, -0.40 - 0.05 * s, 0.18 - 0.05 * s ** 2]
    # joints spread from -4 to 3 rad, as a UR5e reach: every corner of the panel holds a curve
    joints = np.column_stack([base + 0.2 * np.sin(2 * np.pi * s + k) for k, base in
                              enumerate([-2.2, -2.0, -1.5, -4.0, -2.0, 2.7])])
    gripper = np.minimum(1.0, 2.0 * s)[:, None] * 45.0 + 45.0
    names = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
             "wrist_3_joint"]
    return skillbank.Demonstration(t, {"position": position, "joints": joints, "gripper": gripper},
                                   metadata={"joint_names": names})


def test_the_joint_legend_covers_no_curve_and_every_joint_is_named(tmp_path, drawn):
    traj = _trajectory()
    out = plot_executable(traj, tmp_path / "x.png", demos=[traj["position"] + 0.01])
    fig = drawn[-1]
    renderer = _renderer(fig)
    jx = next(ax for ax in fig.axes if ax.get_ylabel() == "joint angle (rad)")
    gx = next(ax for ax in fig.axes if ax.get_ylabel().startswith("gripper"))
    legend = jx.get_legend()
    box = legend.get_window_extent(renderer)
    for ax in (jx, gx):
        for line in ax.get_lines():
            if not len(line.get_xdata()):
                continue  # a legend-only entry
            xy = ax.transData.transform(np.column_stack([line.get_xdata(), line.get_ydata()]))
            inside = (xy[:, 0] > box.x0) & (xy[:, 0] < box.x1) & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1)
            assert not inside.any(), line.get_label()
    texts = [t.get_text() for t in legend.get_texts()]
    assert texts == [*traj.metadata["joint_names"], "gripper (right axis)"]
    assert fig.bbox.y0 <= box.y0 and box.x0 >= fig.bbox.x0 and box.x1 <= fig.bbox.x1  # inside the canvas
    for label in (jx.xaxis.label, jx.yaxis.label, gx.yaxis.label):
        extent = label.get_window_extent(renderer)
        assert not extent.overlaps(box), label.get_text()  # the time axis' name is above the legend
        assert fig.bbox.x0 <= extent.x0 and extent.x1 <= fig.bbox.x1 and fig.bbox.y0 <= extent.y0
    assert mpimg.imread(out).shape[1] <= 2000


def test_the_demonstrations_are_drawn_only_inside_the_3d_box(tmp_path, drawn):
    traj = _trajectory()
    near = traj["position"] + [0.005, 0.0, 0.0]
    far = traj["position"] + [0.0, 0.0, 0.02]  # a press at another button, half of it above the box
    plot_executable(traj, tmp_path / "x.png", demos=[near, far])
    ax = drawn[-1].axes[0]
    box = np.array([ax.get_xlim3d(), ax.get_ylim3d(), ax.get_zlim3d()])
    P = traj["position"]
    assert np.all(box[:, 0] <= P.min(axis=0)) and np.all(P.max(axis=0) <= box[:, 1])  # the reproduction's box
    grey = [line for line in ax.get_lines() if line.get_color() == "0.7"]
    assert len(grey) == 2
    for line, given in zip(grey, (near, far), strict=True):
        D = np.column_stack(line.get_data_3d()).astype(float)
        shown = ~np.isnan(D).any(axis=1)
        assert np.all((D[shown] >= box[:, 0]) & (D[shown] <= box[:, 1]))  # a 3-D axes would draw them past
        inside = np.all((given >= box[:, 0]) & (given <= box[:, 1]), axis=1)
        np.testing.assert_array_equal(shown, inside)  # what lies in the box is all drawn
    assert 0 < shown.sum() < len(shown)  # the far one is cut, not dropped
