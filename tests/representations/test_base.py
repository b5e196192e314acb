"""The shared interface: input handling, time base, constraints, obstacle post-editing."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.core import Constraints, Sphere, resample
from skillbank.core._params import NotFittedError
from skillbank.editing import lte
from skillbank.representations import DMP, ElasticMap, JerkAccuracy, ProMP
from skillbank.representations._base import as_constraints, edit_summary

ALL = [JerkAccuracy, ProMP, ElasticMap, DMP]


def test_resample_is_linear_in_phase():
    Y = np.array([[0.0, 0.0], [1.0, 2.0], [4.0, 4.0]])
    out = resample(Y, 5)
    np.testing.assert_allclose(out, [[0, 0], [0.5, 1], [1, 2], [2.5, 3], [4, 4]])
    np.testing.assert_array_equal(resample(Y, 3), Y)


@pytest.mark.parametrize("cls", ALL)
def test_output_is_demonstration_on_demo_time_base(cls, arc):
    model = cls().fit(arc)
    out = model.reproduce()
    assert isinstance(out, Demonstration)
    assert out.stream_names == ["position"]
    np.testing.assert_allclose(out.t, arc.t)
    assert out.metadata["representation"] == cls.__name__
    short = model.reproduce(n_steps=101)
    assert short["position"].shape == (101, 2)
    np.testing.assert_allclose(short.t, np.linspace(0.0, 2.0, 101))


@pytest.mark.parametrize("cls", ALL)
def test_plain_array_and_uneven_time(cls, arc):
    Y = arc["position"]
    a = cls().fit(Y).reproduce()
    np.testing.assert_allclose(a.t, np.arange(Y.shape[0], dtype=float))
    # Uneven time: interpolated onto an even grid between the same end times.
    t = np.linspace(0, 1, Y.shape[0]) ** 1.2 * 2.0
    out = cls().fit(Demonstration(t, {"position": Y})).reproduce()
    np.testing.assert_allclose(out.t, np.linspace(0.0, 2.0, Y.shape[0]))


def test_time_base_of_several_demos(arc):
    Y = arc["position"]
    d1 = Demonstration(np.linspace(0.0, 2.0, 300), {"position": Y})
    d2 = Demonstration(np.linspace(1.0, 5.0, 200), {"position": resample(Y, 200)})
    d3 = Demonstration(np.linspace(0.5, 3.5, 250), {"position": resample(Y, 250)})
    model = ProMP().fit([d1, d2, d3])
    np.testing.assert_allclose(model.t_, np.linspace(0.5, 3.5, 250))
    assert model.n_demos_ == 3 and model.n_dims_ == 2


@pytest.mark.parametrize("cls", ALL)
def test_input_errors(cls, arc):
    with pytest.raises(ValueError, match="demos: expected at least one"):
        cls().fit([])
    with pytest.raises(ValueError, match="demos: expected a Demonstration"):
        cls().fit("demo.csv")
    with pytest.raises(ValueError, match=r"demos\[0\]: expected a 'position' stream"):
        cls().fit(Demonstration(arc.t, {"joints": arc["position"]}))
    with pytest.raises(ValueError, match=r"demos\[0\]: expected finite values"):
        cls().fit(np.array([[0.0, np.nan]] * 10))
    too_few = cls.min_samples - 1
    message = rf"demos\[0\]: {cls.__name__} needs at least \d+ samples, got {too_few}"
    with pytest.raises(ValueError, match=message):
        cls().fit(np.zeros((too_few, 2)))
    with pytest.raises(NotFittedError, match="not fitted yet"):
        cls().reproduce()
    model = cls().fit(arc)
    with pytest.raises(ValueError, match="constraints: expected a skillbank.Constraints or None, got dict"):
        model.reproduce({"goal": [0, 0]})
    with pytest.raises(ValueError, match="constraints: goal has 3 dimensions but the trajectory has 2"):
        model.reproduce(Constraints(goal=[0.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match="n_steps: expected an integer > 0, got 0"):
        model.reproduce(n_steps=0)
    with pytest.raises(ValueError, match=f"n_steps: {cls.__name__} needs at least"):
        model.reproduce(n_steps=too_few)


@pytest.mark.parametrize("cls", [ProMP, ElasticMap, DMP])
def test_several_demos_must_share_dimensions(cls, arc):
    with pytest.raises(ValueError, match=r"demos\[1\]: expected 2 dimensions like demos\[0\], got 3"):
        cls().fit([arc, np.zeros((50, 3))])


def test_one_demo_methods_reject_several(arc):
    with pytest.raises(ValueError, match="JerkAccuracy learns from exactly one demonstration, got 2"):
        JerkAccuracy().fit([arc, arc])


def test_as_constraints():
    assert as_constraints(None).is_empty
    c = Constraints(goal=[1.0])
    assert as_constraints(c) is c


# ------------------------------------------------------------------ obstacles
def test_obstacles_are_post_edited_with_lte(arc):
    """Post-editing is exactly LTE of the plain reproduction with its own start and goal held."""
    model = JerkAccuracy().fit(arc)
    plain = model.reproduce()
    c = Constraints(obstacles=[Sphere(plain["position"][150], 0.1)])
    out = model.reproduce(c)
    expected = lte(plain["position"], c.with_defaults(plain["position"]), t=plain.t)
    np.testing.assert_array_equal(out["position"], expected.Y)
    assert out.metadata["edit"] == edit_summary(expected) and out.metadata["edit"]["success"]


def test_failed_obstacle_editing_warns(arc):
    model = ProMP().fit(arc)
    goal = model.reproduce()["position"][-1]
    # the goal, a hard constraint, lies inside the obstacle: no collision-free edit exists
    with pytest.warns(UserWarning, match="obstacle editing did not succeed: sample .* is pinned"):
        out = model.reproduce(Constraints(obstacles=[Sphere(goal, 0.1)]))
    assert out.metadata["edit"]["success"] is False and out.metadata["edit"]["collision"] is True


def test_no_obstacles_no_edit(arc):
    out = ElasticMap().fit(arc).reproduce(Constraints(goal=[0.0, 0.0]))
    assert "edit" not in out.metadata and out.metadata["representation"] == "ElasticMap"


@pytest.mark.parametrize("cls", ALL)
def test_real_lte_moves_the_reproduction_out_of_an_obstacle(cls, arc):
    model = cls().fit(arc)
    plain = model.reproduce()["position"]
    sphere = Sphere(plain[150], 0.15)
    c = Constraints(goal=plain[-1] + [0.05, 0.0], obstacles=[sphere])
    assert c.collides(plain)
    out = model.reproduce(c)
    assert out.metadata["edit"]["success"]
    assert not c.collides(out["position"])
    assert c.position_error(out["position"]) < 1e-6
