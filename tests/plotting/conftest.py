"""Fixtures of the figure tests: the figures a call wrote, and the texts of a figure that collide."""

from __future__ import annotations

import itertools
import os
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from skillbank import Demonstration


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


# -- the web view: a small library and a real browser -----------------------------------------------
#: A label that would run a script if a page wrote it as HTML.
HOSTILE = "<img src=x onerror=alert(1)>"
#: The action of a press skill (as tests/planning's).
PRESS_PDDL = """(:action press
  :parameters (?b - button)
  :precondition (free ?b)
  :effect (and (pressed ?b) (not (free ?b))))
"""
#: Debian's Chromium; the tests drive it with playwright's Python package and never download a browser.
CHROMIUM = Path(os.environ.get("SKILLBANK_CHROMIUM", "/usr/bin/chromium"))
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def three_streams() -> Demonstration:
    """A 3-D path with corners, a force that steps and a gripper that closes: keypoints from all three."""
    n = 400
    t = np.linspace(0.0, 4.0, n)
    corners = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.2], [1.0, 1.0, 0.4], [0.0, 1.0, 0.1]])
    s = np.linspace(0.0, corners.shape[0] - 1, n)
    Y = np.column_stack([np.interp(s, np.arange(corners.shape[0]), c) for c in corners.T])
    F = np.column_stack([np.sin(2.0 * t), np.where(t > 2.0, 1.0, 0.0) + 0.1 * t])
    G = (t > 3.0).astype(float)
    return Demonstration(t, {"position": Y, "force": F, "gripper": G})


def _reach(start, goal, *, bend, n=60, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n)
    s = 10 * t ** 3 - 15 * t ** 4 + 6 * t ** 5
    Y = start + s[:, None] * (goal - start)
    Y[:, 2] += bend * np.sin(np.pi * s) * np.linalg.norm(goal - start)
    Y = Y + 1e-6 * rng.standard_normal(Y.shape)
    return Demonstration(t, {"position": Y}, {"source": f"reach-{seed}"})


def build_view_library(path) -> dict:
    """A library of 6 straight and 6 bowed 3-D reaches (stored whole) and one segmented pick-and-place,
    clustered; the straight reaches' cluster labelled with :data:`HOSTILE`, one of its primitives labelled
    itself, one bowed reach labelled 'arc' (so its cluster's label is inferred), one hostile description.
    Returns what the pages should show."""
    from skillbank.experiments._demo import synthetic_multistream
    from skillbank.pipeline import Library

    rng = np.random.default_rng(0)
    demos = []
    for k in range(12):
        start = rng.uniform(-1, 1, 3)
        goal = start + np.r_[rng.uniform(0.5, 1.0, 2) * rng.choice([-1, 1], 2), 0.0]
        demos.append(_reach(start, goal, bend=0.0 if k < 6 else 0.8, seed=k))
    with Library(path) as lib:
        lib.add_many(demos, segment=False, assign="none")
        # three pick-and-places, so their pieces are skills of their own (the clustering joins a lone
        # demonstration's pieces to the nearest larger skill: one demonstration is no skill)
        picked = lib.add(synthetic_multistream(), assign="none")
        for seed in (1, 2):
            lib.add(synthetic_multistream(random_state=seed), assign="none")
        lib.cluster()
        straight = lib.primitives(demonstration=1, load=False)[0].cluster
        bowed = lib.primitives(demonstration=7, load=False)[0].cluster
        lib.label(HOSTILE, cluster=straight)
        lib.label("own-label", primitive=2)
        lib.label("arc", primitive=lib.primitives(demonstration=8, load=False)[0].id)  # a sparse label
        lib.store.set_description(HOSTILE, "(:action x :parameters (?b) :effect (</pre><script>alert(2)"
                                            "</script> ?b))", {"note": "</script><script>alert(3)</script>"})
        summary = lib.summary()
    return {"path": Path(path), "straight": straight, "bowed": bowed, "segmented": picked, "summary": summary}


@pytest.fixture(scope="session")
def view_library(tmp_path_factory) -> dict:
    """:func:`build_view_library` once per session (a SQLite file)."""
    return build_view_library(tmp_path_factory.mktemp("view") / "lib.db")


@pytest.fixture(scope="session")
def chromium(tmp_path_factory):
    """A headless Chromium (a playwright ``BrowserContext`` with a fresh profile), once per session.

    Skipped when Chromium or playwright is missing, except in CI (``CI`` set), where that fails.
    """
    reason = None
    if not CHROMIUM.is_file():
        reason = f"needs Chromium at {CHROMIUM} (apt-get install chromium; 'make test' installs it)"
    else:
        try:
            from playwright.sync_api import sync_playwright  # the test extra's
        except ImportError:
            reason = "needs playwright's Python package (pip install -e '.[test]')"
    if reason is not None:
        if os.environ.get("CI"):
            pytest.fail(reason)
        pytest.skip(reason)
    with sync_playwright() as p:
        context = p.chromium.launch_persistent_context(
            str(tmp_path_factory.mktemp("chromium-profile")), executable_path=str(CHROMIUM),
            args=CHROMIUM_ARGS, headless=True, viewport={"width": 1200, "height": 900})
        try:
            yield context
        finally:
            context.close()


class Visit:
    """One page opened in the browser, with every request, console message, page error and dialog it made."""

    def __init__(self, context, url: str, *, timeout: float = 15_000):
        self.requests, self.console, self.errors, self.dialogs = [], [], [], []
        self.page = context.new_page()
        self.page.on("request", lambda r: self.requests.append(r.url))
        self.page.on("console", lambda m: self.console.append((m.type, m.text)))
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.on("dialog", lambda d: (self.dialogs.append(d.message), d.dismiss()))
        self.response = self.page.goto(url)
        self.page.wait_for_selector("body[data-ready]", timeout=timeout)
        self.ready = self.page.evaluate("document.body.getAttribute('data-ready')")

    def console_errors(self) -> list:
        return [text for kind, text in self.console if kind == "error"]

    def close(self):
        self.page.close()


@pytest.fixture
def visit(chromium):
    """``visit(url) -> Visit``: open a page in the session's Chromium; closed after the test."""
    opened = []

    def open_(url):
        opened.append(Visit(chromium, url))
        return opened[-1]

    yield open_
    for v in opened:
        v.close()
