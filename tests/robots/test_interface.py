"""Adding a robot is one RobotModel subclass and one registry line: a planar two-link arm, end to end."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.core import exp_map
from skillbank.robots import ROBOTS, KinematicsError, RobotModel, Singularity, robot_model


class Planar(RobotModel):
    """Two unit links turning about z; the tool's orientation is the sum of the angles about z."""

    name = "planar"
    joint_names = ("shoulder", "elbow")
    lower = (-np.pi, -np.pi)
    upper = (np.pi, np.pi)
    branch_names = ("elbow-left", "elbow-right")
    home = (0.0, 1.0)
    SINGULARITIES = {"elbow": Singularity("|sin(elbow)|", 0.05)}

    def _fk(self, q):
        T = np.tile(np.eye(4), (q.shape[0], 1, 1))
        a, b = q[:, 0], q[:, 0] + q[:, 1]
        T[:, 0, 0], T[:, 0, 1], T[:, 1, 0], T[:, 1, 1] = np.cos(b), -np.sin(b), np.sin(b), np.cos(b)
        T[:, 0, 3], T[:, 1, 3] = np.cos(a) + np.cos(b), np.sin(a) + np.sin(b)
        return T

    def _ik(self, T):
        x, y = T[:, 0, 3], T[:, 1, 3]
        c2 = (x**2 + y**2 - 2) / 2
        t2 = np.array([1.0, -1.0])[None, :] * np.arccos(np.clip(c2, -1, 1))[:, None]
        t1 = np.arctan2(y, x)[:, None] - np.arctan2(np.sin(t2), 1 + np.cos(t2))
        sols = np.stack([t1, t2], axis=-1)
        return np.where((np.abs(c2) <= 1)[:, None, None], (sols + np.pi) % (2 * np.pi) - np.pi, np.nan)

    def _singularity(self, q):
        return {"elbow": np.abs(np.sin(q[:, 1]))}


def test_a_new_robot_is_one_class_and_one_registry_line(monkeypatch):
    monkeypatch.setitem(ROBOTS, "planar", Planar)
    robot = robot_model("planar")
    q = np.column_stack([np.linspace(0.0, 1.0, 30), np.linspace(1.0, 2.0, 30)])
    position, quaternion = robot.fk(q)
    np.testing.assert_allclose(quaternion, exp_map(np.column_stack([np.zeros((30, 2)), q.sum(axis=1)])),
                               atol=1e-15)
    np.testing.assert_allclose(robot.ik(position, quaternion), q, atol=1e-12)  # the branch of home
    mirrored = robot.ik(position, quaternion, branch="elbow-right")
    np.testing.assert_allclose(mirrored[:, 1], -q[:, 1], atol=1e-12)
    assert robot.branch_of(q).tolist() == [0] * 30
    # straightening the elbow: the interface's own singularity check, by the subclass's measure
    q[:, 1] = np.linspace(1.0, 0.0, 30)
    with pytest.raises(KinematicsError, match=r"sample 28 is near the elbow singularity \(\|sin\(elbow\)\|"):
        robot.ik(*robot.fk(q))
    with pytest.raises(KinematicsError, match=r"sample 0 is out of the arm's reach"):
        robot.ik([3.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0])


def test_the_interface_is_abstract():
    with pytest.raises(TypeError, match=r"abstract"):
        RobotModel()
