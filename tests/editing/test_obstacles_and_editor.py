"""Obstacle avoidance in LTE, and the LaplacianEditor estimator."""

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.core import Box, Constraints, Sphere
from skillbank.core._params import NotFittedError
from skillbank.editing import lte
from skillbank.metrics import constraint_report, frechet_distance
from skillbank.representations import LaplacianEditor


def wave(n):
    s = np.linspace(0.0, 1.0, n)
    return np.column_stack([s, 0.2 * np.sin(3 * s), 0.1 * np.cos(5 * s)])


GOAL = [1.1, 0.3, 0.1]


def on_path(n=1000):
    """The unobstructed edit, whose samples the obstacles below are placed on."""
    return lte(wave(n), Constraints(goal=GOAL)).Y


@pytest.mark.parametrize("make", [
    lambda P: [Sphere(P[500], 0.1)],
    lambda P: [Sphere(P[500] + [0, 0.02, 0], 0.1)],
    lambda P: [Box(P[500] - 0.08, P[500] + 0.08)],
    lambda P: [Sphere(P[450], 0.06), Sphere(P[560], 0.06), Box(P[250] - 0.04, P[250] + 0.04)],
])
def test_obstacles_are_avoided(make):
    Y, P = wave(1000), on_path()
    obstacles = make(P)
    c = Constraints(goal=GOAL, obstacles=obstacles)
    assert c.collides(P)
    res = lte(Y, c)
    assert res.success and not res.collision and res.n_iter >= 1 and res.added
    assert res.constraint_error <= 1e-12 and "collision-free" in res.message
    report = constraint_report(res.Y, c)
    assert not report["collision"] and report["clearance"] >= 0.0
    # Pushed sideways, not along the path: no sample jumps.
    def step(A):
        return np.linalg.norm(np.diff(A, axis=0), axis=1).max()
    assert step(res.Y) < 5 * step(P)
    # And the detour stays of the obstacle's size.
    assert frechet_distance(res.Y[::10], P[::10]) < 0.3


def test_goal_inside_an_obstacle_fails_honestly():
    c = Constraints(goal=GOAL, obstacles=[Sphere(GOAL, 0.05)])
    res = lte(wave(500), c)
    assert not res.success and res.collision
    assert "pinned by a constraint inside obstacle 0" in res.message


def test_no_rounds_left_fails_honestly():
    P = on_path()
    res = lte(wave(1000), Constraints(goal=GOAL, obstacles=[Sphere(P[500], 0.1)]), max_iter=0)
    assert not res.success and res.collision and res.n_iter == 0
    assert "no collision-free edit within max_iter=0 rounds" in res.message
    res = lte(wave(1000), Constraints(goal=GOAL, obstacles=[Sphere(P[500], 0.1)]), avoid_obstacles=False)
    assert not res.success and res.collision and "avoid_obstacles=False" in res.message


def test_segment_through_a_thin_wall_is_a_collision():
    # Two samples straddle a wall thinner than the sampling step: no sample is inside.
    Y = np.column_stack([np.linspace(0, 1, 6), np.zeros(6)])
    c = Constraints(obstacles=[Box([0.45, -1.0], [0.55, 1.0])])
    assert not c.collision_mask(Y).any() and c.collides(Y)  # one definition: samples and segments
    res = lte(Y, c)
    assert not res.success and res.collision and "segment(s) cross obstacle 0" in res.message


def test_soft_constraints_with_obstacle():
    P = on_path()
    res = lte(wave(1000), Constraints(goal=GOAL, obstacles=[Sphere(P[500], 0.1)]), hard=False, weight=1e3)
    assert res.success and not res.collision and res.constraint_error < 1e-6
    assert "soft (weight 1000)" in res.message


def test_editor_fit_reproduce():
    t = np.linspace(0.0, 2.0, 400)
    demo = Demonstration(t, {"position": wave(400)}, {"label": "reach"})
    editor = LaplacianEditor(max_iter=20)
    assert editor.fit([demo]) is editor
    assert editor.Y_.shape == (400, 3) and editor.n_dims_ == 3 and editor.get_params()["max_iter"] == 20
    P = lte(demo, Constraints(goal=GOAL)).Y
    c = Constraints(goal=GOAL, obstacles=[Sphere(P[200], 0.08)])
    out = editor.reproduce(c)
    assert isinstance(out, Demonstration) and out.n_steps == 400 and np.array_equal(out.t, t)
    assert out.metadata["edit"]["success"] and not c.collides(out["position"])
    short = editor.reproduce(Constraints(goal=GOAL), n_steps=100)
    assert short.n_steps == 100 and np.allclose(short["position"][-1], GOAL)
    assert np.allclose(short.t[[0, -1]], [0.0, 2.0])
    same = editor.reproduce()
    assert np.abs(same["position"] - wave(400)).max() <= 1e-9
    arr = LaplacianEditor().fit(wave(50)).edit(Constraints(start=[0.1, 0.0, 0.1]))
    assert arr.success and arr.Y[0].tolist() == [0.1, 0.0, 0.1]


@pytest.mark.parametrize("call, match", [
    (lambda: LaplacianEditor().fit([wave(10), wave(10)]),
     r"LaplacianEditor learns from exactly one demonstration, got 2"),
    (lambda: LaplacianEditor().fit(Demonstration.from_array(wave(10), name="joints")),
     r"expected a 'position' stream, got streams \['joints'\]"),
    (lambda: LaplacianEditor().fit(wave(1)), r"demos\[0\]: LaplacianEditor needs at least 2 samples, got 1"),
    (lambda: LaplacianEditor().fit(wave(10)).reproduce(n_steps=1),
     r"n_steps: LaplacianEditor needs at least 2 samples, got 1"),
    (lambda: LaplacianEditor().fit(wave(10)).reproduce(n_steps=2.5), r"n_steps: expected an integer"),
    (lambda: LaplacianEditor(weight=-1, hard=False).fit(wave(10)).reproduce(),
     r"weight: expected a number > 0"),
])
def test_editor_errors(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_editor_not_fitted():
    with pytest.raises(NotFittedError):
        LaplacianEditor().reproduce()


def test_real_rail_reaching(data_dir):
    from skillbank.io import load_rail

    demo = load_rail(data_dir / "rail", classes=["reaching"])[0]
    Y = demo["position"]
    goal = Y[-1] + [0.05, -0.03, 0.02]
    free = lte(demo, Constraints(goal=goal)).Y
    c = Constraints(goal=goal, via=[(0.3, free[300] + [0.0, 0.0, 0.02])], obstacles=[Sphere(free[600], 0.03)])
    res = LaplacianEditor().fit(demo).edit(c)
    assert res.success and res.constraint_error <= 1e-12 and not c.collides(res.Y)
    assert np.array_equal(res.Y[0], Y[0])


def test_obstacle_around_a_pinned_end_is_reported_not_a_clash():
    """A sphere holding the (pinned) start: before issue 12 a run of one pinned sample followed by free
    outside samples was taken as movable, the start got an obstacle via-point and lte raised "obstacle
    via-point fixes sample 0 ... but a constraint already puts it at ...". Now it is reported as pinned."""
    t = np.linspace(0.0, 1.0, 60)
    Y = np.column_stack([t, np.sin(np.pi * t), 0.5 * t]) + 0.01
    for radius in (0.3, 1e9, 1e99):
        res = lte(Y, Constraints(obstacles=[Sphere([0.0, 0.0, 0.0], radius)]), t=t)
        assert not res.success and res.collision
        assert res.message.startswith("sample 0 is pinned by a constraint inside obstacle 0")
