"""docs/architecture.md's "How to add": a representation, an obstacle shape and a store backend are
each one class plus one registry line, and everything downstream picks them up."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.figure import Figure

import skillbank.io as sio
from skillbank import Constraints, Demonstration
from skillbank.cli import main
from skillbank.core import OBSTACLES, Box, Obstacle, parse_obstacle
from skillbank.editing import lte
from skillbank.pipeline import Library
from skillbank.plotting import draw_edit
from skillbank.representations import REPRESENTATIONS, Representation
from skillbank.selection import reuse
from skillbank.store import STORES, SQLiteStore, open_store


class StraightLine(Representation):
    """A new method: the straight line from start to goal (learns only the duration)."""

    default_k = 2
    min_samples = 2
    supports_via = False

    def __init__(self, *, unused=None):
        self.unused = unused

    def _fit(self, Ys):
        self.start_ = np.mean([Y[0] for Y in Ys], axis=0)
        self.goal_ = np.mean([Y[-1] for Y in Ys], axis=0)

    def _reproduce(self, constraints, n_steps):
        c = self._constraints(constraints, np.vstack([self.start_, self.goal_]))
        s = np.linspace(0.0, 1.0, n_steps)[:, None]
        return c.start + s * (c.goal - c.start)


def _arcs(n=3):
    s = np.linspace(0.0, 1.0, 60)
    return [np.column_stack([s, a * np.sin(np.pi * s)]) for a in np.linspace(0.1, 0.3, n)]


def test_a_new_representation_is_one_class_and_one_line(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(REPRESENTATIONS, "line", StraightLine)
    task = Constraints(goal=[1.2, 0.3], via=[(0.5, [0.6, 0.4])])
    res = reuse(_arcs(), task, method="line")
    assert res.k == 2 and res.method == "line"  # default_k read from the class
    assert "line: via-points followed only through the adapted demonstration" in res.message
    np.testing.assert_allclose(res.trajectory["position"][-1], [1.2, 0.3], atol=1e-12)
    path = tmp_path / "arc.csv"
    sio.write_csv(Demonstration.from_array(_arcs()[0]), path)
    assert main(["edit", str(path), "--method", "line", "--goal", "2,0", "--json"]) == 0
    assert '"collision": false' in capsys.readouterr().out


class Cube(Obstacle):
    """A new shape: an axis-aligned cube given by its centre and half side (geometry of a Box)."""

    kind = "cube"
    usage = "cube:X,Y[,Z],HALF"

    def __init__(self, center, half):
        self.center, self.half = np.asarray(center, dtype=float), float(half)
        self._box = Box(self.center - self.half, self.center + self.half)

    n_dims = property(lambda self: self._box.n_dims)
    size = property(lambda self: self.half)

    def signed_distance(self, Y):
        return self._box.signed_distance(Y)

    def _segment_hits(self, A, B):
        return self._box._segment_hits(A, B)

    def push_out(self, Y, T, margin):
        return self._box.push_out(Y, T, margin)

    def bounds(self):
        return self._box.bounds()

    def outline(self, resolution=48):
        return self._box.outline(resolution)

    @classmethod
    def from_values(cls, values):
        return cls(values[:-1], values[-1])

    def values(self):
        return [*self.center.tolist(), self.half]


def test_a_new_obstacle_shape_is_one_class_and_one_line(monkeypatch):
    monkeypatch.setitem(OBSTACLES, "cube", Cube)
    cube = parse_obstacle("cube:0.5,0.05,0.1")
    assert isinstance(cube, Cube) and parse_obstacle(cube.spec()) == cube
    Y = np.column_stack([np.linspace(0.0, 1.0, 200), np.zeros(200)])
    c = Constraints(obstacles=[cube])
    assert c.collides(Y)
    edited = lte(Y, c)
    assert edited.success and not c.collides(edited.Y)
    res = reuse([Y, Y + [0.0, 0.01]], c, method="promp")
    assert not res.collision and not c.collides(res.trajectory["position"])
    ax = Figure().add_subplot()
    draw_edit(ax, edited.Y, constraints=c)
    assert len(ax.patches) == 1


class RenamedSQLite(SQLiteStore):
    """A new backend (here SQLite under another scheme, to keep the test self-contained)."""

    scheme = "skilltest"

    @classmethod
    def from_url(cls, url, *, create=True, **options):
        return cls(url.split("://", 1)[1], create=create, **options)


def test_a_new_store_backend_is_one_class_and_one_line(monkeypatch, tmp_path):
    monkeypatch.setitem(STORES, "skilltest", RenamedSQLite)
    url = f"skilltest://{tmp_path / 'lib.db'}"
    assert isinstance(open_store(url), RenamedSQLite)
    with Library(url) as lib:
        assert isinstance(lib.store, RenamedSQLite)
        lib.add_many([Demonstration.from_array(Y) for Y in _arcs(4)], segment=False, label="arc")
        assert len(lib.primitives(label="arc")) == 4
    with pytest.raises(ValueError, match=r"library: no store backend for nosuch:// \(known: .*skilltest"):
        open_store("nosuch://x")
