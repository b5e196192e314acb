"""The grip sites skillbank names are robosuite's: read from its own model, on each recorded arm."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.io import ROBOSUITE_POSE_OF
from skillbank.robots import pose_point

pytest.importorskip("robosuite")  # the extra skillbank[sim]


@pytest.mark.parametrize("robot", ["Panda", "UR5e"])
def test_the_point_robosuite_reports_is_the_named_grip_site(robot):
    from skillbank.simulation._robosuite import _env_args, import_robosuite, robot_frames

    suite = import_robosuite()
    env = suite.make("Lift", **_env_args("Lift", 10, 0, robot)["env_kwargs"])
    try:
        env.reset()
        frames = robot_frames(env)
    finally:
        env.close()
    named = ROBOSUITE_POSE_OF[robot.lower()]
    assert frames["pose_of"] == named
    # the named point's transform is what robosuite's grip site and end-effector body are, to 1e-6
    np.testing.assert_allclose(np.array(frames["tool"]), pose_point(named).transform, atol=1e-6)
