"""clearing_move: the tool motion that moves one body of the arm away from an obstacle, by what it lacks."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.core import Box, Sphere
from skillbank.robots import UR5e, clearance, clearing_move

ROBOT = UR5e()
# the home pose and two from the three-button recording's range: elbow up, wrist down
CONFIGS = [np.array(ROBOT.home, float), np.array([0.3, -1.2, 1.6, -2.0, -1.57, 0.2]),
           np.array([-0.6, -1.9, 1.9, -1.5, -1.57, -0.4])]


def _body(name):
    return next(b for b in ROBOT.bodies if b.name == name)


def _ball_on(q, name, direction, overlap=0.01, radius=0.03):
    """A ball that overlaps body ``name``'s middle by ``overlap`` from ``direction`` (world frame)."""
    b = _body(name)
    F = ROBOT.link_frames(q)[0, b.frame]
    mid = F[:3, :3] @ (0.5 * (np.asarray(b.a) + np.asarray(b.b))) + F[:3, 3]
    u = np.asarray(direction, float) / np.linalg.norm(direction)
    return Sphere(mid + u * (b.radius + radius - overlap), radius)


def _distance(q, name, obstacle):
    return clearance(ROBOT, q[None], {"x": obstacle}, self_collision=False).per_pair[(name, "x")]


CASES = [(q, name, d) for q in CONFIGS for name in ("upper_arm", "forearm", "wrist_1", "gripper_body")
         for d in ((0, 0, 1), (1, 0, 0), (0, -1, 0))]


def test_the_move_gains_what_the_body_lacks_to_first_order():
    """36 cases (3 poses x 4 bodies x 3 sides): most have a move, and each move gains about the lack."""
    found = 0
    for q, name, direction in CASES:
        ball = _ball_on(q, name, direction)
        before = _distance(q, name, ball)
        assert before < 0  # the ball overlaps the body
        lack = 0.02
        move = clearing_move(ROBOT, q, name, ball, lack)
        if move is None:  # the tool barely moves the body relative to the ball here, or too far away
            continue
        found += 1
        p, quat = ROBOT.fk(q)
        moved = ROBOT.ik((p + move)[None], quat[None], q_seed=q)[0]
        gained = _distance(moved, name, ball) - before
        assert 0.6 * lack < gained < 1.4 * lack, (name, direction)  # first order: the arm bends
        assert np.linalg.norm(move) <= 0.25
    assert found >= 30


def test_a_body_the_tool_cannot_move_gives_none():
    """The shoulder turns about its own axis: no tool motion takes it away from a ball beside it."""
    q = CONFIGS[0]
    assert clearing_move(ROBOT, q, "shoulder", _ball_on(q, "shoulder", (1, 0, 0)), 0.02) is None
    assert clearing_move(ROBOT, q, "base", _ball_on(q, "base", (1, 0, 0)), 0.02) is None


def test_a_move_longer_than_max_move_gives_none():
    q = CONFIGS[0]
    ball = _ball_on(q, "forearm", (0, 0, 1))
    assert clearing_move(ROBOT, q, "forearm", ball, 0.02, max_move=1e-4) is None


def test_a_box_works_as_a_sphere_does():
    q = CONFIGS[0]
    ball = _ball_on(q, "forearm", (0, 0, 1))
    box = Box(ball.center - ball.radius, ball.center + ball.radius)
    move = clearing_move(ROBOT, q, "forearm", box, 0.02)
    assert move is not None and move[2] < 0  # the forearm goes down, away from a box above it


@pytest.mark.parametrize("kwargs, match", [
    ({"body": "elbow"}, r"body: expected one of the model's bodies \[.*'forearm'.*\], got 'elbow'"),
    ({"obstacle": [0, 0, 1]}, r"obstacle: expected an Obstacle \(Sphere, Box\), got list"),
    ({"lack": 0.0}, r"lack"),
    ({"lack": -0.01}, r"lack"),
    ({"q": [0.0, 1.0]}, r"q: expected 6 joint angles, got shape \(2,\)"),
])
def test_bad_arguments_are_one_clear_error(kwargs, match):
    args = {"q": CONFIGS[0], "body": "forearm", "obstacle": Sphere([0, 0, 1], 0.1), "lack": 0.01, **kwargs}
    with pytest.raises(ValueError, match=match):
        clearing_move(ROBOT, args["q"], args["body"], args["obstacle"], args["lack"])
