"""Poses of one point of the robot converted, exactly, to a robot's tool (issue 41, item 1)."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.core import Demonstration, quaternion_angle
from skillbank.io import read_robot_h5
from skillbank.robots import GRIPPERS, pose_point, robot_model, to_tool, tool_point

RNG = np.random.default_rng(41)


def _random_joints(n=200):
    return RNG.uniform(-np.pi, np.pi, (n, 6))


def _demo(position, orientation, pose_of):
    meta = {} if pose_of is None else {"pose_of": pose_of}
    return Demonstration(np.arange(len(position), dtype=float),
                         {"position": position, "orientation": orientation}, meta)


@pytest.mark.parametrize(("source", "target"), [
    ("flange", None), ("flange", "robotiq_2f85"), (None, "flange"), ("robotiq_2f85", "flange"),
    ("0.01,0.02,0.2,0,0,0.3826834323650898,0.9238795325112867", None),
])
def test_a_pose_of_one_point_becomes_the_tools_exactly(source, target):
    """FK of the same joints with the source's point as the tool, converted, is FK with the target's tool:
    position and orientation, whatever the configuration (the conversion is one rigid transform)."""
    q = _random_joints()
    tool = None if source is None else pose_point(source).transform
    src_model, dst_model = robot_model("ur5e", tool=tool), robot_model("ur5e", tool=target)
    p, quat = src_model.fk(q)
    demo = _demo(p, quat, tool_point(src_model))
    out, notes = to_tool(demo, dst_model)
    want_p, want_q = dst_model.fk(q)
    assert np.abs(out["position"] - want_p).max() < 1e-12
    assert quaternion_angle(out["orientation"], want_q).max() < 1e-7
    assert out.metadata["pose_of"] == tool_point(dst_model)
    again, more = to_tool(out, dst_model)
    assert again is out and more == []  # already the tool's: unchanged, no note


def test_the_three_button_recording_is_the_flanges_and_its_tcp_is_163_mm_along_the_tool(data_dir):
    """The paper's recording states its point (UR's tool0); reused on the UR5e its poses become the 2F-85's
    TCP: FK of the recorded joints with the default tool equals the converted poses within the recording's
    own FK accuracy (0.8 mm and 0.2 degrees at the flange; measured 0.98 mm at the TCP), and the converted
    path lies 163 mm from the recorded one (before, the TCP was put on the recorded flange path)."""
    path = data_dir / "seed" / "three_button_pressing_demo.h5"
    demo = read_robot_h5(path)
    assert demo.metadata["pose_of"] == "flange"
    robot = robot_model("ur5e")
    tcp, notes = to_tool(demo, robot)
    assert notes == ["pose_of: poses of the flange converted to ur5e's tool robotiq_2f85:tcp (163 mm)"]
    p, quat = robot.fk(demo["joints"])
    # the recording's flange is 0.8 mm and 0.2 degrees from FK; 0.163 m out, the angle adds up to 0.6 mm
    assert np.linalg.norm(p - tcp["position"], axis=1).max() < 0.8e-3 + 0.163 * np.radians(0.21)
    assert np.degrees(quaternion_angle(quat, tcp["orientation"])).max() < 0.21
    np.testing.assert_allclose(np.linalg.norm(tcp["position"] - demo["position"], axis=1), 0.163, atol=1e-12)


def test_another_grippers_point_is_taken_as_the_robots_grippers_same_point():
    """A Panda recording's grip site reused on the UR5e (2F-85): the grip sites coincide, not the flanges;
    a note says so. The same gripper's point goes through the flange."""
    ur5e = robot_model("ur5e")
    p, quat = np.array([[0.4, 0.1, 0.3]]), np.array([[1.0, 0.0, 0.0, 0.0]])  # tool pointing down
    out, notes = to_tool(_demo(p, quat, "panda_hand:grip_site"), ur5e)
    # the 2F-85's TCP is 18 mm beyond its grip site, along the tool's z (down here)
    np.testing.assert_allclose(out["position"], [[0.4, 0.1, 0.3 - 0.018]], atol=1e-12)
    assert notes[0] == ("pose_of: poses of the panda_hand's grip_site taken as the robotiq_2f85's grip_site "
                        "(another gripper: where the hand works is kept, not its flange)")
    same, _ = to_tool(_demo(p, quat, "robotiq_2f85:grip_site"), ur5e)
    np.testing.assert_allclose(same["position"], out["position"], atol=1e-12)


def test_the_grippers_grip_sites_are_robosuites():
    assert GRIPPERS["robotiq_2f85"].grip_site == (0.0, 0.0, 0.145)  # robosuite's eef site, 18.75 mm above
    assert GRIPPERS["panda_hand"].grip_site == (0.0, 0.0, 0.097)    # 9 mm above its TCP
    # the registered Panda's default tool is its hand's grip site, by name
    assert tool_point(robot_model("panda")) == "panda_hand:grip_site"


def test_an_unknown_point_is_an_error_never_a_guess():
    demo = _demo(np.zeros((2, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (2, 1)), None)
    with pytest.raises(ValueError, match=r"^pose_of: the primitive 3's poses are of an unknown point of the "
                                         r"robot, and ur5e needs its tool's \(robotiq_2f85:tcp\): say which "
                                         r"point of the robot its poses are of with --pose-of flange"):
        to_tool(demo, robot_model("ur5e"), what="primitive 3")
    with pytest.raises(ValueError, match=r"pose_of: unknown gripper 'shadow_hand' in 'shadow_hand'; known "
                                         r"grippers are \['robotiq_2f85', 'panda_hand'\]"):
        pose_point("shadow_hand")
    # without a 3-D pose there is nothing to convert: inverse kinematics says what is missing
    plain = Demonstration([0.0, 1.0], {"position": np.zeros((2, 3))})
    assert to_tool(plain, robot_model("ur5e"))[0] is plain
