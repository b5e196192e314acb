"""The library's figures: one panel per skill at its own scale, and a reuse beside its stored primitives."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank import Constraints, Sphere
from skillbank.plotting import plot_reuse, plot_skills

S = np.linspace(0.0, 1.0, 50)
LETTER = np.c_[0.3 + 0.04 * S, -0.3 + 0.04 * np.sin(3 * S), np.zeros_like(S)]  # 4 cm, on the table
REACH = np.c_[0.4 * S, 0.1 * S, 0.3 - 0.2 * S]  # 40 cm through the air


def _names(ax) -> list[str]:
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_one_panel_per_skill_each_at_its_scale(tmp_path, drawn):
    plot_skills({"letter": [LETTER, LETTER + [0.002, 0, 0]], "reach": [REACH]}, tmp_path / "skills.png")
    fig = drawn[-1]
    letter, reach = fig.axes
    assert letter.name == "rectilinear" and reach.name == "3d"  # a skill on a plane is drawn flat
    # the letter fills its panel: its view is a few cm wide, not the reach's 40 cm
    assert np.ptp(letter.get_xlim()) < 0.06 and np.ptp(reach.get_xlim()) > 0.3
    assert [letter.get_xlabel(), letter.get_ylabel()] == ["x (m)", "y (m)"]
    assert reach.get_zlabel() == "z (m)"
    assert letter.get_xticks().size >= 3  # ticks kept, so the size can be read
    assert letter.get_title().startswith("letter\n2 primitives") and "z = 0" in letter.get_title()


def test_reuse_shows_the_stored_primitives_unhidden(tmp_path, drawn):
    stored = [REACH, REACH + [0.0, 0.02, 0.0]]
    c = Constraints(start=REACH[0], goal=REACH[-1] + [0.05, 0.0, 0.0], obstacles=[Sphere(REACH[25], 0.01)])
    reproduction = REACH + np.outer(S, [0.05, 0.0, 0.0])
    plot_reuse(reproduction, tmp_path / "reuse.png", stored=stored, candidates=[REACH], constraints=c,
               skill="reach", method="ja")
    left, right = drawn[-1].axes
    # the stored primitives are drawn alone on the left: no reproduction over them
    assert "reproduction" not in [line.get_label() for line in left.get_lines()]
    assert {"stored primitives (2)", "start", "goal", "obstacle"} <= set(_names(left))
    assert {"reproduction", "adapted by LTE (1)", "start", "goal", "obstacle"} <= set(_names(right))
    for ax in (left, right):
        assert [ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()] == ["x (m)", "y (m)", "z (m)"]


def test_reuse_of_a_planar_skill_is_drawn_flat_with_its_start(tmp_path, drawn):
    # no start given: the square marks where the reproduction begins
    c = Constraints(goal=LETTER[-1] + [0.001, 0, 0], obstacles=[Sphere(LETTER[20], 0.002)])
    plot_reuse(LETTER + [0.001, 0, 0], tmp_path / "flat.png", stored=[LETTER], constraints=c)
    left, right = drawn[-1].axes
    assert left.name == right.name == "rectilinear"
    start = [line for line in right.get_lines() if line.get_label() == "start"]
    np.testing.assert_allclose(start[0].get_xydata()[0], LETTER[0, :2] + [0.001, 0])
    assert len(right.patches) == 1  # the sphere's section by the table's plane


@pytest.mark.parametrize(
    ("skills", "match"),
    [({}, r"skills: expected a dict of skill name to primitives"),
     ({"a": []}, r"skills\['a'\]: expected at least one primitive, got none"),
     ({"a": [np.zeros((5, 4))]}, r"skills\['a'\]\[0\]: expected 2-D or 3-D positions, got 4 columns")],
)
def test_plot_skills_refuses(tmp_path, skills, match):
    with pytest.raises(ValueError, match=match):
        plot_skills(skills, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()
