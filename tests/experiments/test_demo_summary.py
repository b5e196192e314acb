"""The demo's summary.md says how many primitives its skills hold, not more."""

from __future__ import annotations

from skillbank.experiments._library_demo import _markdown


def _result(n_primitives):
    return {"library": "demo/library.sqlite", "seconds": 1.0, "source": "LASA", "n_demonstrations": 32,
            "n_primitives": n_primitives, "features": "position",
            "timing": [{"part": "library", "seconds": 1.0}]}


ROWS = [{"cluster": 0, "label": "pick", "count": 3, "majority": 1.0, "composition": {"pick": 3}},
        {"cluster": 1, "label": "Angle", "count": 7, "majority": 1.0, "composition": {"Angle": 7}}]


def test_skills_hold_fewer_than_all_primitives():
    text = _markdown(_result(13), ROWS, [], None)
    assert ("32 demonstrations, 13 primitives, clustered with elastic clustering on `position` features into "
            "2 skills, which hold 10 of them (3 in no skill).") in text


def test_skills_hold_every_primitive():
    text = _markdown(_result(10), ROWS, [], None)
    assert "features into 2 skills.\n" in text and "no skill" not in text
