"""``Obstacle.first_contact`` finds the sample ``collides`` decides on: the first inside, or the first
segment that crosses the inside (a coarse path that jumps over a thin obstacle)."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.core import Box, Sphere


def _straightforward(ob, Y) -> int:
    for i in range(len(Y)):
        if ob.signed_distance(Y[i][None])[0] < 0.0:
            return i
        if i + 1 < len(Y) and ob.segment_hits(Y[i:i + 2])[0]:
            return i
    return -1


@pytest.mark.parametrize("ob", [Sphere([0.0, 0.0, 0.0], 0.3), Box([-0.2, -0.05, -0.3], [0.2, 0.05, 0.3])])
def test_first_contact_is_the_loops_answer_and_agrees_with_collides(ob):
    rng = np.random.default_rng(3)
    for _ in range(300):
        Y = rng.uniform(-1.0, 1.0, (int(rng.integers(1, 8)), 3))
        k = ob.first_contact(Y)
        assert k == _straightforward(ob, Y)
        assert (k >= 0) == ob.collides(Y)


def test_a_segment_over_a_thin_wall_is_found_at_its_first_end():
    wall = Box([-0.01, -1.0, -1.0], [0.01, 1.0, 1.0])
    assert wall.first_contact([[-1.0, 0.0, 0.0], [-0.5, 0.0, 0.0], [0.5, 0.0, 0.0]]) == 1
    assert wall.first_contact([[-1.0, 0.0, 0.0], [-0.5, 0.0, 0.0]]) == -1
