"""Synthetic demonstrations for the library tests."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank import Demonstration


def reach(start, goal, *, bend=0.0, n=60, seed=0):
    """A smooth point-to-point motion with an optional sideways bow (minimum-jerk timing)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n)
    s = 10 * t ** 3 - 15 * t ** 4 + 6 * t ** 5
    start, goal = np.asarray(start, float), np.asarray(goal, float)
    Y = start + s[:, None] * (goal - start)
    side = np.zeros_like(start)
    side[-1] = 1.0  # bow along the last axis
    Y = Y + bend * np.sin(np.pi * s)[:, None] * side * np.linalg.norm(goal - start)
    Y = Y + 1e-6 * rng.standard_normal(Y.shape)
    return Demonstration(t, {"position": Y}, {"source": f"synthetic-{seed}"})


def two_skills(n_each=6, seed=0):
    """``n_each`` straight reaches and ``n_each`` strongly bowed ones, random 3-D start and goal."""
    rng = np.random.default_rng(seed)
    demos = []
    for k in range(2 * n_each):
        start = rng.uniform(-1, 1, 3)
        goal = start + np.r_[rng.uniform(0.5, 1.0, 2) * rng.choice([-1, 1], 2), 0.0]
        demos.append(reach(start, goal, bend=0.0 if k < n_each else 0.8, seed=k))
    return demos


@pytest.fixture(scope="session")
def make_reach():
    """The :func:`reach` factory."""
    return reach


@pytest.fixture(scope="session")
def make_skills():
    """The :func:`two_skills` factory."""
    return two_skills
