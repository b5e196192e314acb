"""The UR5e model against the three-button recording, and the reader's joints in kinematic-chain order.

The file's ``transform_positions`` / ``transform_orientations`` are the flange pose in UR's base frame
(scalar-last quaternions); its joints are stored in the alphabetical order of ROS ``joint_states``.
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from skillbank.core import quaternion_angle
from skillbank.io import FormatError, read_robot_h5
from skillbank.io._robot_h5 import UR_JOINT_NAMES, UR_JOINT_STATES_ORDER
from skillbank.robots import UR5e


@pytest.fixture(scope="module")
def buttons(data_dir):
    return read_robot_h5(data_dir / "seed" / "three_button_pressing_demo.h5")


def test_reader_gives_the_joints_in_chain_order_with_their_names(buttons, data_dir):
    assert buttons.metadata["joint_names"] == list(UR5e.joint_names) == list(UR_JOINT_NAMES)
    with h5py.File(data_dir / "seed" / "three_button_pressing_demo.h5", "r") as h5:
        stored = h5["joint_state_info/joint_positions"][()]
    # the file's first sample (elbow, shoulder_lift, shoulder_pan, wrist_1, wrist_2, wrist_3)
    np.testing.assert_array_equal(buttons["joints"][0], stored[0, [2, 1, 0, 3, 4, 5]])


def test_fk_of_the_recorded_joints_gives_the_recorded_flange_pose(buttons):
    robot = UR5e(tool="flange")
    position, quaternion = robot.fk(buttons["joints"])
    distance = np.linalg.norm(position - buttons["position"], axis=1)
    angle = np.degrees(quaternion_angle(quaternion, buttons["orientation"]))
    assert distance.max() <= 1e-3 and angle.max() <= 0.5  # measured: 0.79 mm, 0.20 degrees
    assert np.median(distance) < 0.6e-3 and np.median(angle) < 0.15
    # the frame is UR's base (DH frame 0), not ROS's base_link turned by pi about z
    turned, _ = UR5e(base=np.diag([-1.0, -1.0, 1.0, 1.0]), tool="flange").fk(buttons["joints"])
    assert np.linalg.norm(turned - buttons["position"], axis=1).min() > 0.5
    # the stored (alphabetical) order is not the chain order
    alphabetical, _ = robot.fk(buttons["joints"][:, [2, 1, 0, 3, 4, 5]])
    assert np.linalg.norm(alphabetical - buttons["position"], axis=1).max() > 0.1


def test_ik_of_the_recorded_poses_round_trips_on_the_recorded_branch(buttons):
    robot = UR5e(tool="flange")
    joints = buttons["joints"]
    branches = robot.branch_of(joints)
    assert set(branches.tolist()) == {0} and robot.branch_names[0] == "shoulder-left/elbow-up/wrist-up"
    out = robot.ik(buttons["position"], buttons["orientation"], q_seed=joints[0])
    assert out.shape == joints.shape and set(robot.branch_of(out).tolist()) == {0}
    position, quaternion = robot.fk(out)
    assert np.linalg.norm(position - buttons["position"], axis=1).max() <= 1e-4  # measured: 5e-13 m
    assert quaternion_angle(quaternion, buttons["orientation"]).max() <= 1e-9
    # the recorded joints themselves, to the model's 0.8 mm: within 3e-3 rad (and the same turn)
    assert np.abs(out - joints).max() < 5e-3
    # without a seed the branch nearest the ready pose is taken (another one) and followed as well
    other = robot.ik(buttons["position"], buttons["orientation"])
    assert set(robot.branch_of(other).tolist()) == {robot.branch_of(UR5e.home)[0]} != {0}


def _write(path, joints, n=20):
    t = 1_700_000_000.25 + 0.006 * np.arange(n)
    clock = np.column_stack([np.floor(t), np.round((t - np.floor(t)) * 1e9)])
    with h5py.File(path, "w") as h5:
        h5["joint_state_info/joint_positions"] = joints
        h5["joint_state_info/joint_time"] = clock
        h5["transform_info/transform_positions"] = np.zeros((n, 3))
        h5["transform_info/transform_orientations"] = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
        h5["transform_info/transform_time"] = clock
    return path


def test_reader_joint_order_on_written_files(tmp_path):
    n = 20
    columns = 0.01 * np.arange(n)[:, None] + np.arange(6)[None, :]  # column k holds k + small
    demo = read_robot_h5(_write(tmp_path / "ur.h5", columns))
    # six columns: a UR driver's alphabetical order, put in chain order
    expected = [UR_JOINT_STATES_ORDER.index(name) for name in UR_JOINT_NAMES]
    assert expected == [2, 1, 0, 3, 4, 5]
    np.testing.assert_array_equal(demo["joints"], columns[:, expected])
    # names given in the file's order: reordered when they are a UR's
    given = ["wrist_3_joint", "wrist_2_joint", "wrist_1_joint", "elbow_joint", "shoulder_lift_joint",
             "shoulder_pan_joint"]
    demo = read_robot_h5(tmp_path / "ur.h5", joint_names=given)
    np.testing.assert_array_equal(demo["joints"], columns[:, ::-1])
    assert demo.metadata["joint_names"] == list(UR_JOINT_NAMES)
    # other names keep the stored order
    names = [f"j{k}" for k in range(6)]
    demo = read_robot_h5(tmp_path / "ur.h5", joint_names=names)
    np.testing.assert_array_equal(demo["joints"], columns)
    assert demo.metadata["joint_names"] == names
    # another number of columns, no names: numbered, stored order
    demo = read_robot_h5(_write(tmp_path / "two.h5", columns[:, :2]))
    assert demo.metadata["joint_names"] == ["joint_0", "joint_1"]
    np.testing.assert_array_equal(demo["joints"], columns[:, :2])


def test_reader_joint_names_errors(tmp_path):
    path = _write(tmp_path / "ur.h5", np.zeros((20, 6)))
    with pytest.raises(FormatError, match=r"cannot read '.*ur\.h5': expected 2 joint columns to match "
                                          r"joint_names, found 6 in 'joint_state_info/joint_positions'"):
        read_robot_h5(path, joint_names=["a", "b"])
    for bad in ("elbow", ["a", "a", "b", "c", "d", "e"], ["a", ""], [], [1, 2]):
        with pytest.raises(ValueError, match=r"^joint_names: expected a list of distinct non-empty names"):
            read_robot_h5(path, joint_names=bad)


def test_scalar_first_orientation_option(data_dir, tmp_path):
    # the same file with its quaternions stored (w, x, y, z) reads back the same with scalar_first=True
    import shutil

    src = data_dir / "seed" / "three_button_pressing_demo.h5"
    copy = tmp_path / "wxyz.h5"
    shutil.copy(src, copy)
    with h5py.File(copy, "r+") as h5:
        q = h5["transform_info/transform_orientations"][...]
        h5["transform_info/transform_orientations"][...] = q[:, [3, 0, 1, 2]]
    a, b = read_robot_h5(src), read_robot_h5(copy, scalar_first=True)
    np.testing.assert_allclose(a["orientation"], b["orientation"], atol=1e-12)
    assert np.all(np.einsum("ij,ij->i", a["orientation"][1:], a["orientation"][:-1]) >= 0)
