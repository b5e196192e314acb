"""Shared pieces of the simulation tests: a robot, scenes built in code, short trajectories."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")  # the tests need the extra skillbank[sim]; CI installs it with [test]

from skillbank.core import Box, Demonstration  # noqa: E402
from skillbank.planning import Scene, SceneObject  # noqa: E402
from skillbank.robots import robot_model  # noqa: E402


@pytest.fixture(scope="session")
def ur5e():
    return robot_model("ur5e")


def scene(objects=(), obstacles=None, goal=(), table=None) -> Scene:
    return Scene(objects={o.name: o for o in objects}, obstacles=dict(obstacles or {}), init=[],
                 goal=list(goal), table=table)


def button(name, position, *, radius=0.02, travel=0.008) -> SceneObject:
    return SceneObject(name, "button", position=np.asarray(position, float), shape="button",
                       size=np.array([radius]), travel=travel)


def sweep(q0, joint, angle, duration, n=101) -> Demonstration:
    """Joint ``joint`` turned by ``angle`` at constant speed over ``duration`` from ``q0``."""
    t = np.linspace(0.0, duration, n)
    q = np.tile(np.asarray(q0, float), (n, 1))
    q[:, joint] += angle * t / duration
    return Demonstration(t, {"joints": q})


TABLE = Box([-1.0, -1.0, -0.05], [1.0, 1.0, 0.0])


def recorded_lift(folder, *, episodes: int, seed: int = 11):
    """A library of ``episodes`` scripted Lift demonstrations recorded from ``seed`` in ``folder``,
    clustered: its path."""
    from skillbank.pipeline import Library
    from skillbank.simulation import record  # robosuite, when a test asks for it

    out = folder / "lift.hdf5"
    record("robosuite:Lift", episodes=episodes, out=out, seed=seed)
    db = folder / "lift.db"
    with Library(db) as lib:
        lib.add_files([out])
        lib.cluster()
    return db
