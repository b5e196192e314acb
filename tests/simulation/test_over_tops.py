"""An adapted approach's travel lifted over the objects' tops, on robosuite's own scene (no mock)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("robosuite")  # the extra skillbank[sim]

from skillbank.simulation._evaluate import CLOSE_IN, OVER, _make, _over_tops  # noqa: E402
from skillbank.simulation._robosuite import _box, _gripper, import_robosuite  # noqa: E402


@pytest.fixture(scope="module")
def pickplace():
    env = _make(import_robosuite(), "PickPlace", 0, 1000)
    obs = env.reset()
    yield env, obs
    env.close()


def _geometry(env, obs, name):
    model = next(m for m in env.model.mujoco_objects if m.name == name)
    lo, hi = _box(env.sim, model.contact_geoms)
    hand_lo, hand_hi = _box(env.sim, _gripper(env).contact_geoms)
    tool = np.asarray(obs["robot0_eef_pos"], float)
    return lo, hi, tool[2] - hand_lo[2]


def _sweep(obs, through, height, n=60):
    """From the tool, straight across ``through`` (a point) and 0.3 m past it, at ``height``; the first
    half crosses it."""
    tool = np.asarray(obs["robot0_eef_pos"], float)
    end = tool + 2.0 * (np.r_[through[:2], height] - tool)
    u = np.linspace(0.0, 1.0, n)[:, None]
    P = tool + u * (end - tool)
    P[:, 2] = np.where(u[:, 0] < 0.05, tool[2] + u[:, 0] / 0.05 * (height - tool[2]), height)
    return P


def test_a_sweep_through_the_tallest_box_passes_over_its_top_and_is_left_alone_elsewhere(pickplace):
    env, obs = pickplace
    lo, hi, depth = _geometry(env, obs, "Cereal")
    centre = (lo + hi) / 2
    P = _sweep(obs, centre, hi[2] - 0.03)  # 3 cm below the box's top: through it
    G = -np.ones(len(P))
    lifted = _over_tops(P, G, env, obs)
    above = np.all((P[:, :2] > lo[:2]) & (P[:, :2] < hi[:2]), axis=1)
    first = np.arange(len(P)) < CLOSE_IN[0] * (len(P) - 1)
    assert (above & first).any()
    # over the box, the fingertips clear its top by OVER
    assert np.all(lifted[above & first, 2] - depth >= hi[2] + OVER - 1e-9)
    # only heights change, never down; the pinned second half is the demonstration's
    np.testing.assert_array_equal(lifted[:, :2], P[:, :2])
    assert np.all(lifted[:, 2] >= P[:, 2])
    np.testing.assert_array_equal(lifted[~first][-5:], P[~first][-5:])
    # smooth: no step larger than the sweep's own between samples, raised gradually
    assert np.abs(np.diff(lifted[:, 2])).max() < 0.35 * (hi[2] + OVER + depth - P[:, 2].min())


def test_a_path_above_every_top_or_with_the_gripper_closed_is_unchanged(pickplace):
    env, obs = pickplace
    lo, hi, depth = _geometry(env, obs, "Cereal")
    high = _sweep(obs, (lo + hi) / 2, hi[2] + depth + OVER + 0.01)
    np.testing.assert_array_equal(_over_tops(high, -np.ones(len(high)), env, obs), high)
    low = _sweep(obs, (lo + hi) / 2, hi[2] - 0.03)
    np.testing.assert_array_equal(_over_tops(low, np.ones(len(low)), env, obs), low)  # closed on nothing


def test_what_the_tool_starts_over_is_left_as_the_demonstration_leaves_it(pickplace):
    """A retreat from what was just let go of starts around it: no raise for that object."""
    env, obs = pickplace
    lo, hi, depth = _geometry(env, obs, "Cereal")
    centre = (lo + hi) / 2
    here = {**obs, "robot0_eef_pos": np.r_[centre[:2], hi[2] - 0.03]}
    P = here["robot0_eef_pos"] + np.linspace(0.0, 1.0, 40)[:, None] * [0.0, 0.0, 0.2]
    np.testing.assert_array_equal(_over_tops(P, -np.ones(len(P)), env, here), P)
