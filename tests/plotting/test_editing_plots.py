"""Editing figures: 2-D and 3-D, obstacles and constraint markers drawn, bad input rejected."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.patches import Polygon

from skillbank import Demonstration
from skillbank.core import Box, Constraints, Sphere
from skillbank.plotting._editing import draw_edit, plot_edit

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _curve(n_dims, n=80):
    s = np.linspace(0.0, 1.0, n)
    cols = [s, np.sin(np.pi * s), 0.5 * s**2][:n_dims]
    return np.column_stack(cols)


def test_2d_draws_everything():
    demo = _curve(2)
    rep = demo + [0.0, 0.2]
    c = Constraints(start=rep[0], goal=rep[-1], via=[(0.5, rep[40])],
                    obstacles=[Sphere([0.3, 0.5], 0.1), Box([0.6, 0.0], [0.7, 0.3])])
    ax = Figure().add_subplot()
    draw_edit(ax, Demonstration.from_array(rep), demo=demo, demos=[demo - 0.1, demo + 0.1], constraints=c)
    labels = [line.get_label() for line in ax.get_lines()]
    for name in ("reproduction", "demonstration", "demonstrations", "start", "goal", "via-point"):
        assert name in labels
    np.testing.assert_allclose(ax.get_lines()[labels.index("reproduction")].get_xydata(), rep)
    # each obstacle is drawn from its own outline, a filled polygon in 2-D
    assert [type(p) for p in ax.patches] == [Polygon, Polygon]
    for patch, ob in zip(ax.patches, c.obstacles, strict=True):
        np.testing.assert_allclose(patch.get_xy(), ob.outline()[0])
    # Equal scale, and everything (obstacles, the shifted demos) inside the view.
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert x1 - x0 == pytest.approx(y1 - y0)
    assert x0 < -0.1 and x1 > 1.1 and y0 < -0.1 and y1 > 1.2


def test_3d_file(tmp_path):
    demo = _curve(3)
    c = Constraints(goal=demo[-1] + 0.1, obstacles=[Sphere([0.5, 1.0, 0.1], 0.1),
                                                    Box([0.2, 0.2, 0.0], [0.3, 0.4, 0.1])])
    out = plot_edit(demo + 0.05, tmp_path / "edit3d.png", demo=demo, constraints=c, title="3-D")
    assert out == tmp_path / "edit3d.png" and out.read_bytes()[:8] == PNG_MAGIC
    ax = Figure().add_subplot(projection="3d")
    draw_edit(ax, demo, constraints=c, legend=False)
    # 1 path + the start (where the path begins) + 1 goal marker + the obstacles' wireframes
    n_wire = sum(len(ob.outline()) for ob in c.obstacles)
    assert n_wire == 19 + 12  # sphere: 7 parallels and 12 meridians; box: 12 edges
    assert len(ax.get_lines()) == 3 + n_wire and ax.get_legend() is None


def test_svg_and_pdf(tmp_path):
    for suffix in ("svg", "pdf"):
        path = plot_edit(_curve(2), tmp_path / f"e.{suffix}")
        assert path.stat().st_size > 1000


@pytest.mark.parametrize("call, match", [
    (lambda ax2, ax3: draw_edit(ax2, _curve(1)), r"reproduction: expected a 2-D or 3-D trajectory to draw, "
                                                 r"got 1 dimensions"),
    (lambda ax2, ax3: draw_edit(ax2, _curve(3)), r"ax: expected 3-D axes for 3-D trajectories, got 2-D"),
    (lambda ax2, ax3: draw_edit(ax3, _curve(2)), r"ax: expected 2-D axes for 2-D trajectories, got 3-D"),
    (lambda ax2, ax3: draw_edit(ax2, _curve(2), demo=_curve(3)), r"demo: expected 2 dimensions"),
    (lambda ax2, ax3: draw_edit(ax2, _curve(2), demos=[_curve(3)]), r"demos\[0\]: expected 2 dimensions"),
    (lambda ax2, ax3: draw_edit(ax2, _curve(2), constraints={"goal": [0, 0]}),
     r"constraints: expected a skillbank Constraints, got dict"),
    (lambda ax2, ax3: draw_edit(ax2, _curve(2), constraints=Constraints(goal=[0, 0, 0])),
     r"goal has 3 dimensions but the trajectory has 2"),
    (lambda ax2, ax3: draw_edit(ax2, Demonstration(np.arange(3.0), {"force": np.zeros((3, 2))})),
     r"reproduction: expected a Demonstration with a 'position' stream"),
    (lambda ax2, ax3: draw_edit(ax2, [[np.nan, 0.0]]), r"reproduction: expected finite values"),
    (lambda ax2, ax3: plot_edit(_curve(2)[:, :1], "never.png"), r"got 1 dimensions"),
])
def test_errors(call, match):
    ax2, ax3 = Figure().add_subplot(), Figure().add_subplot(projection="3d")
    with pytest.raises(ValueError, match=match):
        call(ax2, ax3)


def test_start_is_marked_when_the_constraints_leave_it_free(tmp_path, drawn):
    rep = _curve(2)
    plot_edit(rep, tmp_path / "e.png", constraints=Constraints(goal=rep[-1]), unit="mm")
    ax = drawn[-1].axes[0]
    starts = [line for line in ax.get_lines() if line.get_label() == "start"]
    np.testing.assert_allclose(starts[0].get_xydata(), rep[:1])
    assert "start" in [t.get_text() for t in ax.get_legend().get_texts()]
    assert [ax.get_xlabel(), ax.get_ylabel()] == ["x (mm)", "y (mm)"]


def test_axes_say_when_the_unit_is_not_known(tmp_path, drawn):
    plot_edit(_curve(3), tmp_path / "e.png")
    ax = drawn[-1].axes[0]
    assert [ax.get_xlabel(), ax.get_zlabel()] == ["x (as recorded)", "z (as recorded)"]
