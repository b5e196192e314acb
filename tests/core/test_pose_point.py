"""The one grammar of "which point of the robot the poses are of": canonical text, errors, round trips."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.core import Demonstration, check_pose_of, state_pose_of
from skillbank.core._pose_point import parse_pose_of


@pytest.mark.parametrize(("text", "canonical"), [
    ("flange", "flange"), (" flange ", "flange"),
    ("robotiq_2f85", "robotiq_2f85:tcp"), ("robotiq_2f85:tcp", "robotiq_2f85:tcp"),
    ("panda_hand:grip_site", "panda_hand:grip_site"),
    ("0,0,0.163", "0,0,0.163,0,0,0,1"), ("0.01,-0.02,0.1,0,0,0,1.005", "0.01,-0.02,0.1,0,0,0,1"),
])
def test_the_canonical_text(text, canonical):
    assert check_pose_of(text) == canonical
    assert check_pose_of(canonical) == canonical  # canonical text reads back as itself


@pytest.mark.parametrize(("value", "match"), [
    ("tcp", r"'tcp' alone does not say whose: name the gripper, as in robotiq_2f85:tcp"),
    ("0,0", r"got '0,0' \(2 numbers\)"),
    ("0,0,x", r"not numbers separated by commas"),
    ("0,0,nan", r"a number that is not finite"),
    ("0,0,11", r"an offset of more than 10 m from the flange"),
    ("0,0,0.1,0,0,0,0.5", r"a quaternion of norm 0.5, not 1"),
    ("Robotiq", r"not a gripper's name"),
    ("robotiq_2f85:fingertip", r"a gripper's point is one of \['tcp', 'grip_site'\]"),
    (0.163, r"a float, not text"),
])
def test_what_is_refused_says_the_grammar(value, match):
    with pytest.raises(ValueError, match=r"^pose_of: expected 'flange', GRIPPER, GRIPPER:tcp, .*" + match):
        check_pose_of(value)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.lists(st.floats(-2.0, 2.0, allow_nan=False), min_size=3, max_size=3),
       st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=4, max_size=4))
def test_an_offset_reads_back_as_the_same_numbers(x, q):
    q = np.asarray(q)
    if np.linalg.norm(q) < 0.1:
        q = np.array([0.0, 0.0, 0.0, 1.0])
    q = q / np.linalg.norm(q)
    text = check_pose_of(",".join(repr(float(v)) for v in (*x, *q)))
    _, x2, q2 = parse_pose_of(text)
    np.testing.assert_array_equal(x2, x)  # the text is exact: the shortest that reads back as the float
    np.testing.assert_allclose(q2, q, atol=1e-15)
    assert check_pose_of(text) == text


def test_stating_a_point_where_the_file_does_not_and_refusing_a_contradiction():
    said = Demonstration([0.0], {"position": [[0.0, 0.0, 0.0]]}, {"pose_of": "flange"})
    unsaid = Demonstration([0.0], {"position": [[0.0, 0.0, 0.0]]})
    assert state_pose_of([unsaid], "panda_hand")[0].metadata["pose_of"] == "panda_hand:tcp"
    assert state_pose_of([said], " flange")[0].metadata["pose_of"] == "flange"  # the same point: fine
    assert state_pose_of([said], None)[0].metadata["pose_of"] == "flange"
    with pytest.raises(ValueError, match=r"pose_of: f.h5 states its poses are of 'flange', and --pose-of / "
                                         r"pose_of says 'robotiq_2f85:tcp': leave pose_of out"):
        state_pose_of([said], "robotiq_2f85", source="f.h5")
