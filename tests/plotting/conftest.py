"""Fixtures of the figure tests: the figures a call wrote, and the texts of a figure that collide."""

from __future__ import annotations

import itertools

import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure


@pytest.fixture
def drawn(monkeypatch):
    """The list of every :class:`~matplotlib.figure.Figure` saved while the test runs, in order."""
    figures = []
    real = Figure.savefig

    def spy(self, *args, **kwargs):
        figures.append(self)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", spy)
    return figures


def texts_of(fig) -> list:
    """Every text a drawn 2-D figure shows: titles, axis and tick labels, notes and legends.

    Tick labels are those of the ticks in view (matplotlib keeps labels of
    ticks beyond the limits, undrawn).
    """
    out = [fig._suptitle, *fig.texts]
    for legend in fig.legends:
        out += legend.get_texts()
    for ax in fig.axes:
        out += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label, *ax.texts]
        for axis in (ax.xaxis, ax.yaxis):
            for tick in axis._update_ticks():  # the ticks drawn
                out += [tick.label1, tick.label2]
        if ax.get_legend() is not None:
            out += ax.get_legend().get_texts()
    unique = {id(t): t for t in out if t is not None}  # the suptitle is among fig.texts too
    return [t for t in unique.values() if t.get_visible() and t.get_text().strip()]


def colliding_texts(fig) -> list[tuple[str, str]]:
    """Pairs of texts of a drawn 2-D figure whose boxes overlap: what a reader cannot read."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in texts_of(fig)]
    return [(a, b) for (a, box_a), (b, box_b) in itertools.combinations(boxes, 2) if box_a.overlaps(box_b)]


@pytest.fixture(scope="session")
def collisions():
    """``collisions(fig)``: the pairs of texts of a 2-D figure that overlap once drawn (none: readable)."""
    return colliding_texts
