"""The UR5e model (issue 14, item 6): forward kinematics, the 8 IK branches, following one along a path.

Known answers come from the DH table by hand (the zero and ready poses), from the three-button
recording (tests/robots/test_recorded.py) and from a per-pose loop of the same formulas
(benchmarks/bench_ik.py).
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from skillbank.core import quaternion_angle, quaternion_to_matrix
from skillbank.robots import ROBOTS, UR5E_DH, KinematicsError, UR5e, robot_model

_BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
HOME = np.array(UR5e.home)
D1, _, _, D4, D5, D6 = UR5E_DH["d"]
A2, A3 = UR5E_DH["a"][1:3]


@pytest.fixture(scope="module")
def robot():
    return UR5e(tool="flange")  # the known poses are the flange's (UR's tool0)


@pytest.fixture(scope="module")
def loop():
    if str(_BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(_BENCHMARKS))
    return importlib.import_module("bench_ik")


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def _reach(q):
    """The shoulder singularity's measure by hand, the wrist centre's distance to the base-shoulder plane."""
    return A2 * np.cos(q[:, 1]) + A3 * np.cos(q[:, 1] + q[:, 2]) + D5 * np.sin(q[:, 1:4].sum(axis=1))


# ------------------------------------------------------------------ forward kinematics


def test_fk_known_poses(robot):
    # all zeros: the arm lies along -x; the flange looks along -y
    p, q = robot.fk(np.zeros(6))
    np.testing.assert_allclose(p, [A2 + A3, -(D4 + D6), D1 - D5], atol=1e-15)
    np.testing.assert_allclose(quaternion_to_matrix(q)[:, 2], [0.0, -1.0, 0.0], atol=1e-15)
    # the ready pose: upper arm up, forearm level, tool down
    p, q = robot.fk(HOME)
    np.testing.assert_allclose(p, [A3 - D5, -D4, D1 - A2 - D6], atol=1e-15)
    np.testing.assert_allclose(quaternion_to_matrix(q)[:, 2], [0.0, 0.0, -1.0], atol=1e-15)


def test_fk_is_vectorised_and_keeps_the_input_shape(robot):
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (50, 6))
    p, quat = robot.fk(q)
    assert p.shape == (50, 3) and quat.shape == (50, 4)
    one = [robot.fk(row) for row in q]
    np.testing.assert_allclose(p, [o[0] for o in one], atol=1e-15)
    np.testing.assert_allclose(quat, [o[1] for o in one], atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0, atol=1e-15)


def test_base_and_tool_frames(robot):
    turn = np.diag([-1.0, -1.0, 1.0, 1.0])  # ROS base_link: UR's base turned by pi about z
    tool = np.eye(4)
    tool[2, 3] = 0.15  # a gripper 15 cm along the flange's z
    moved = UR5e(base=turn, tool=tool)
    p0, q0 = robot.fk(HOME)
    p, q = moved.fk(HOME)
    np.testing.assert_allclose(p, [-p0[0], -p0[1], p0[2] - 0.15], atol=1e-15)
    back = moved.ik(p, q, q_seed=HOME)
    np.testing.assert_allclose(back, HOME, atol=1e-12)


# ------------------------------------------------------------------ all branches


def test_ready_pose_has_eight_distinct_branches(robot):
    sols = robot.ik_all(*robot.fk(HOME))
    assert sols.shape == (8, 6) and not np.isnan(sols).any()
    assert len({tuple(np.round(s, 6)) for s in sols}) == 8
    assert robot.branch_names[robot.branch_of(HOME)[0]] == "shoulder-right/elbow-up/wrist-down"


def test_branch_names_mean_their_geometry(robot):
    q = np.random.default_rng(4).uniform(-np.pi, np.pi, (2000, 6))
    q = q[np.min(list(robot.singularity(q).values()), axis=0) > 1e-3]
    names = np.array(robot.branch_names)[robot.branch_of(q)]
    frames = [np.tile(np.eye(4), (len(q), 1, 1))]
    for i in range(6):
        frames.append(frames[-1] @ np.array([_dh(t, i) for t in q[:, i]]))
    origin = [f[:, :3, 3] for f in frames]
    x1, z4, z6 = frames[1][:, :3, 0], frames[4][:, :3, 2], frames[6][:, :3, 2]
    # the arm's horizontal reach: along its plane, towards the wrist centre; n the normal of the arm's
    # plane seen with the reach to the right and up up
    reach = np.sign(np.sum(x1 * origin[5], axis=1))[:, None] * x1
    n = np.cross(reach, [0.0, 0.0, 1.0])
    # shoulder left: seen from above, the reach turns counter-clockwise from the line base -> wrist centre
    left = np.cross(origin[5], reach)[:, 2] > 0
    # elbow up: the elbow counter-clockwise of the line shoulder -> wrist 1 (above it when that runs out)
    up = np.sum(np.cross(origin[4] - origin[1], origin[2] - origin[1]) * n, axis=1) > 0
    # wrist down: the tool axis clockwise of the direction wrist 1 -> wrist 2 (down when that runs out)
    down = np.sum(z6 * np.cross(n, z4), axis=1) < 0
    assert len(q) > 1000
    assert np.array_equal(left, np.char.find(names, "shoulder-left") >= 0)
    assert np.array_equal(up, np.char.find(names, "elbow-up") >= 0)
    assert np.array_equal(down, np.char.find(names, "wrist-down") >= 0)


def _dh(theta, i):
    d, a, alpha = UR5E_DH["d"][i], UR5E_DH["a"][i], UR5E_DH["alpha"][i]
    ct, st_, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st_ * ca, st_ * sa, a * ct], [st_, ct * ca, -ct * sa, a * st_], [0, sa, ca, d],
                     [0, 0, 0, 1.0]])


_JOINTS = arrays(np.float64, (6,), elements=st.floats(-np.pi, np.pi, allow_nan=False))


@settings(max_examples=150, deadline=None)
@given(q=_JOINTS)
def test_property_every_branch_maps_back_to_the_pose(robot, q):
    p, quat = robot.fk(q)
    sols = robot.ik_all(p, quat)
    found = ~np.isnan(sols).any(axis=1)
    if found.any():
        back_p, back_q = robot.fk(sols[found])
        np.testing.assert_allclose(back_p, np.broadcast_to(p, back_p.shape), rtol=0, atol=1e-7)
        assert quaternion_angle(back_q, quat).max() < 1e-7
    # Away from the singularities q's own branch is found and gives q back (modulo 2 pi). Near them the
    # joints are ill-conditioned (errors ~ eps / measure^2); at the wrist singularity itself the pose
    # leaves the split between the wrist joints free (docs/robots.md).
    assume(min(m[0] for m in robot.singularity(q).values()) > 1e-3)
    b = robot.branch_of(q)[0]
    assert found[b]
    np.testing.assert_allclose(_wrap(sols[b] - q), 0.0, atol=1e-7)


def test_vectorised_ik_matches_the_per_pose_loop(robot, loop):
    q = np.random.default_rng(1).uniform(-np.pi, np.pi, (300, 6))
    T, _ = robot._poses(*robot.fk(q))
    vec = robot._ik(T)
    ref = loop.ik_loop(T)
    assert np.array_equal(np.isnan(vec), np.isnan(ref)) and np.isnan(vec).any()  # some branches cannot reach
    np.testing.assert_allclose(_wrap(vec - ref)[~np.isnan(ref)], 0.0, atol=1e-11)


# ------------------------------------------------------------------ following one branch


def _seeded(robot, q, **kwargs):
    return robot.ik(*robot.fk(q), q_seed=q[0], **kwargs)


def test_ik_follows_the_seeded_branch_and_returns_the_path(robot):
    s = np.linspace(0, 1, 200)[:, None]
    q = HOME + 0.5 * np.sin(2 * np.pi * s * np.arange(1, 7) / 4)
    out = _seeded(robot, q)
    np.testing.assert_allclose(out, q, atol=1e-10)
    # a single pose gives a single configuration
    np.testing.assert_allclose(robot.ik(*robot.fk(q[5]), q_seed=q[5]), q[5], atol=1e-10)


def test_ik_branch_by_name_or_index_and_default_from_home(robot):
    p, quat = robot.fk(HOME)
    sols = robot.ik_all(p, quat)
    for k, name in enumerate(robot.branch_names):
        by_name, by_index = robot.ik(p, quat, branch=name), robot.ik(p, quat, branch=k)
        np.testing.assert_allclose(by_name, by_index, atol=0)
        np.testing.assert_allclose(_wrap(by_name - sols[k]), 0.0, atol=1e-12)
        assert np.abs(by_name - HOME).max() <= np.pi  # the equivalent angles nearest the default seed
    np.testing.assert_allclose(robot.ik(p, quat), HOME, atol=1e-12)  # no branch, no seed: nearest home


def test_ik_takes_the_equivalent_angles_nearest_the_seed_within_limits(robot):
    seed = HOME + np.array([2 * np.pi, 0, 0, 0, 0, -2 * np.pi])
    out = robot.ik(*robot.fk(HOME), q_seed=seed)
    np.testing.assert_allclose(out, seed, atol=1e-12)
    # wrist 3 turning from 1.5 pi to 2.5 pi does not fit above the seed's turn: the whole path moves down 2 pi
    q = np.tile(HOME, (50, 1))
    q[:, 5] = np.linspace(1.5 * np.pi, 2.5 * np.pi, 50)
    out = _seeded(robot, q)
    np.testing.assert_allclose(out[:, 5], q[:, 5] - 2 * np.pi, atol=1e-10)
    np.testing.assert_allclose(out[:, :5], q[:, :5], atol=1e-10)


def test_unreachable_pose_names_the_sample(robot):
    p, quat = robot.fk(np.tile(HOME, (5, 1)))
    p[3] = [2.0, 0.0, 0.5]
    with pytest.raises(KinematicsError, match=r"^position: sample 3 is out of the arm's reach by 1.13 m \(no "
                                                r"solution on any branch\): bring it within reach$") as info:
        robot.ik(p, quat, q_seed=HOME)
    assert (info.value.index, info.value.reason) == (3, "unreachable")
    # the wrist centre on the base axis: the d4 offset makes it unreachable whatever the distance
    with pytest.raises(KinematicsError, match=r"sample 0 is out of the arm's reach"):
        robot.ik([0.0, 0.0, 0.5], quat[0])
    assert np.isnan(robot.ik_all([0.0, 0.0, 0.5], quat[0])).all()


def test_pose_out_of_one_branch_names_the_branches_that_reach_it(robot):
    q = np.random.default_rng(2).uniform(-np.pi, np.pi, (400, 6))
    p, quat = robot.fk(q)
    sols = robot.ik_all(p, quat)
    missing = np.isnan(sols).any(axis=2)
    i = int(np.flatnonzero(missing.any(axis=1))[0])
    b = int(np.flatnonzero(missing[i])[0])
    reachable = [robot.branch_names[k] for k in np.flatnonzero(~missing[i])]
    with pytest.raises(KinematicsError, match=rf"sample 0 is out on branch '{robot.branch_names[b]}'; the "
                                                rf"whole path is reachable on '{reachable[0]}'.*: choose one "
                                                r"with branch=\.\.\. \(--branch on the command line\)$"):
        robot.ik(p[i], quat[i], branch=b)
    # the branch named in the message is followed
    assert robot.branch_of(robot.ik(p[i], quat[i], branch=reachable[0]))[0] == robot.branch_names.index(
        reachable[0])


def test_a_path_no_one_branch_reaches_says_so(robot):
    q = np.random.default_rng(2).uniform(-np.pi, np.pi, (400, 6))
    p, quat = robot.fk(q)
    ok = ~np.isnan(robot.ik_all(p, quat)).any(axis=2)
    i, j = next((i, j) for i in range(400) for j in range(400)
                if ok[i].any() and ok[j].any() and not (ok[i] & ok[j]).any())
    b = int(np.flatnonzero(ok[i])[0])
    here = ", ".join(repr(robot.branch_names[k]) for k in np.flatnonzero(ok[j]))
    with pytest.raises(KinematicsError, match=rf"^position: sample 1 is out on branch "
                                              rf"'{robot.branch_names[b]}' \(reachable on {here}\); no one "
                                              r"branch reaches the whole path: change the path$") as info:
        robot.ik(p[[i, j]], quat[[i, j]], branch=b)
    assert (info.value.index, info.value.reason) == (1, "unreachable")


def _stretched_out(robot, q, distance, n=30):
    """A pose path from 0.1 m inside a stretched arm's reach (elbow at 0) to ``distance`` beyond it.

    The tool moves along the line from the shoulder to wrist 1's centre (in the arm's plane, so the base
    angle and the wrist keep their solution): wrist 1's centre moves by the same distance.
    """
    from skillbank.robots._ur5e import _dh

    q = np.array([q], dtype=float)
    T1 = _dh(q[:, 0], 0)
    T3 = T1 @ _dh(q[:, 1], 1) @ _dh(q[:, 2], 2)
    out = T3[0, :3, 3] - T1[0, :3, 3]
    out /= np.linalg.norm(out)
    p, quat = robot.fk(q[0])
    return np.linspace(p - 0.1 * out, p + distance * out, n), np.tile(quat, (n, 1))


@pytest.mark.parametrize("distance", [0.2, 0.05, 0.5])
@pytest.mark.parametrize("q", [[0.3, -0.7, 0.0, -0.9, 1.2, 0.4], [0.0, -1.2, 0.0, -1.5, -1.5, 0.0]])
def test_a_goal_beyond_reach_says_by_how_much_not_singularity(robot, q, distance):
    """The samples before it stretch the arm (the elbow singularity), but the reach is what to fix."""
    p, quat = _stretched_out(robot, q, distance)
    pattern = (r"^position: sample \d+ is out of the arm's reach \(no solution on any branch; \d+ such "
               r"samples, out by up to ([\d.]+) m at sample 29\): bring the path within reach$")
    with pytest.raises(KinematicsError, match=pattern) as info:
        robot.ik(p, quat)
    assert info.value.reason == "unreachable"
    shown = float(str(info.value).split("up to ")[1].split(" m")[0])
    assert shown == pytest.approx(distance, rel=5e-3)  # printed to 3 digits
    # the goal alone: one sample
    with pytest.raises(KinematicsError, match=rf"^position: sample 0 is out of the arm's reach by "
                                              rf"{distance:.3g} m"):
        robot.ik(p[-1], quat[-1])
    # 0.1 mm short of stretched (the elbow at 0.031 rad): within reach, so the singularity is reported
    inside, _ = _stretched_out(robot, q, -1e-4)
    with pytest.raises(KinematicsError, match=r"is near the elbow singularity"):
        robot.ik(inside, quat)


def test_reach_distance_of_a_wrist_too_near_the_base_axis(robot):
    # tool pointing down with the wrist centre on the base axis: d4 (0.1333 m) short of the base's reach
    quat = robot.fk(HOME)[1]
    T = np.eye(4)[None].copy()
    T[0, :3, :3] = np.array([[1.0, 0, 0], [0, -1, 0], [0, 0, -1]]) @ np.eye(3)
    T[0, :3, 3] = [0.0, 0.0, 0.5]
    assert np.isnan(robot.ik_all([0.0, 0.0, 0.5], quat)).all()
    assert robot._out_of_reach(T)[0] >= 0.1333 - 1e-12


@pytest.mark.parametrize("kind, joint, end, measure", [
    ("wrist", 4, -0.01, lambda q: np.abs(np.sin(q[:, 4]))),
    # the upper arm at 45 degrees, stretching the forearm out
    ("elbow", 2, 0.01, lambda q: np.abs(np.sin(q[:, 2]))),
    # leaning the upper arm back (tool kept down) brings the wrist centre over the base-shoulder plane
    ("shoulder", 1, -np.pi / 2 - 0.95, lambda q: np.abs(_reach(q))),
])
def test_path_into_a_singularity_names_the_first_sample_in_the_threshold(robot, kind, joint, end, measure):
    q = np.tile(HOME, (100, 1))
    if kind == "elbow":
        q[:, 1] = -np.pi / 4
    q[:, joint] = np.linspace(q[0, joint], end, 100)
    if kind == "shoulder":
        q[:, 3] = -np.pi / 2 - (q[:, 1] - HOME[1])  # keeps theta2 + theta3 + theta4 = -pi / 2
    k = int(np.flatnonzero(measure(q) < 0.05)[0])
    assert 0 < k < 99
    with pytest.raises(KinematicsError, match=rf"^position: sample {k} is near the {kind} singularity "
                                                r"\(.* < 0\.05; \d+ such samples\)$") as info:
        _seeded(robot, q)
    assert (info.value.index, info.value.reason) == (k, "singularity")
    # the thresholds are the model's parameters
    UR5e(singularity_thresholds={kind: 0.0}, tool="flange").ik(*robot.fk(q[: k + 1]), q_seed=q[0])


def test_crossing_the_wrist_singularity_between_samples_is_a_branch_flip(robot):
    q = np.tile(HOME, (4, 1))
    q[:, 4] = np.linspace(-0.5, 0.5, 4)  # |sin| >= 0.166 at every sample: no sample is near the singularity
    with pytest.raises(KinematicsError, match=r"^position: sample 2 would flip the branch from "
                                                r"'shoulder-right/elbow-up/wrist-down' to "
                                                r"'shoulder-right/elbow-up/wrist-up' \(joint '") as info:
        _seeded(robot, q)
    assert (info.value.index, info.value.reason) == (2, "branch flip")
    # sampled finely the same crossing passes through the threshold instead
    q = np.tile(HOME, (200, 1))
    q[:, 4] = np.linspace(-0.5, 0.5, 200)
    with pytest.raises(KinematicsError, match=r"near the wrist singularity"):
        _seeded(robot, q)


def test_a_jump_in_the_pose_path_is_an_error(robot):
    q = np.array([HOME, HOME + [2.0, 0, 0, 0, 0, 0]])
    match = (r"^position: sample 1: joint 'shoulder_pan_joint' would move by 2 rad in one sample on every "
             r"branch \(more than max_step=0\.5; the pose path jumps\)$")
    with pytest.raises(KinematicsError, match=match) as info:
        _seeded(robot, q)
    assert info.value.reason == "jump"
    np.testing.assert_allclose(UR5e(max_step=2.5, tool="flange").ik(*robot.fk(q), q_seed=HOME), q, atol=1e-12)


def test_a_joint_turning_beyond_its_range_is_a_limit_error(robot):
    q = np.tile(HOME, (200, 1))
    q[:, 5] = np.linspace(0.0, 5 * np.pi, 200)  # wrist 3 turns 2.5 times; its range is +-2 pi
    k = int(np.flatnonzero(q[:, 5] > 2 * np.pi)[0])
    match = (rf"^position: sample {k}: joint 'wrist_3_joint' would leave its limits \[-6\.283, 6\.283\] on "
             r"branch 'shoulder-right/elbow-up/wrist-down' \(the path turns it through 15\.71 rad\)$")
    with pytest.raises(KinematicsError, match=match) as info:
        _seeded(robot, q)
    assert info.value.reason == "joint limit"


# ------------------------------------------------------------------ bad input


@pytest.mark.parametrize("call, match", [
    (lambda r: r.fk(np.zeros(5)), r"q: expected 6 joint values per sample \(shoulder_pan_joint, .*\), got "
                                  r"shape \(5,\)"),
    (lambda r: r.fk([[0, 0, 0, 0, 0, np.nan]]), r"q: expected finite values"),
    (lambda r: r.ik([0.0, 0.0], [0, 0, 0, 1.0]), r"position: expected 3 coordinates per sample"),
    (lambda r: r.ik([0.3, 0.0, 0.3], [0, 0, 0, 2.0]), r"quaternion: expected unit quaternions"),
    (lambda r: r.ik([[0.3, 0.0, 0.3]] * 2, [[0, 0, 0, 1.0]]), r"quaternion: expected one per position "
                                                              r"\(shape \(2, 4\)\), got shape \(1, 4\)"),
    (lambda r: r.ik([0.3, 0.0, 0.3], [0, 0, 0, 1.0], branch="elbow-up"), r"branch: expected one of "
                                                                          r"\['shoulder-left/elbow-up/"),
    (lambda r: r.ik([0.3, 0.0, 0.3], [0, 0, 0, 1.0], branch=8), r"branch: expected .* below 8, got 8"),
    (lambda r: r.ik([0.3, 0.0, 0.3], [0, 0, 0, 1.0], branch=True), r"branch: expected .* got True"),
    (lambda r: r.ik([0.3, 0.0, 0.3], [0, 0, 0, 1.0], q_seed=np.zeros((2, 6))),
     r"q_seed: expected one configuration of 6 joints, got shape \(2, 6\)"),
    (lambda r: r.ik([0.3, 0.0, 0.3], [0, 0, 0, 1.0], q_seed=[0.0]), r"q_seed: expected 6 joint values"),
    (lambda r: UR5e(base=np.ones((4, 4))), r"base: expected a rigid transform"),
    (lambda r: UR5e(tool=np.eye(3)), r"tool: expected a 4 x 4 homogeneous transform, got shape \(3, 3\)"),
    (lambda r: UR5e(singularity_thresholds={"knee": 0.1}), r"singularity_thresholds: expected kinds among "
                                                           r"\['shoulder', 'elbow', 'wrist'\], got 'knee'"),
    (lambda r: UR5e(singularity_thresholds={"wrist": -1}), r"singularity_thresholds\['wrist'\]: expected a "
                                                           r"number >= 0, got -1"),
    (lambda r: UR5e(max_step=0), r"max_step: expected a number > 0, got 0"),
    (lambda r: UR5e(singularity_thresholds=0.1), r"singularity_thresholds: expected a mapping of kind to "
                                                 r"threshold, got 0\.1"),
    (lambda r: robot_model("ur10"), r"robot: expected one of \['ur5e', 'panda'\] or a URDF / MJCF file"),
])
def test_bad_input_is_one_clear_value_error(robot, call, match):
    with pytest.raises(ValueError, match=match):
        call(robot)


def test_registry_builds_the_model_with_its_parameters():
    assert ROBOTS["ur5e"] is UR5e
    tool = np.eye(4)
    tool[2, 3] = 0.1
    model = robot_model("ur5e", tool=tool)
    assert isinstance(model, UR5e) and np.array_equal(model.tool, tool)
    assert repr(model) == "UR5e(tool=...)" and repr(UR5e()) == "UR5e()"
    turn = [-2 * np.pi, 2 * np.pi]
    assert model.limits.tolist() == [turn, turn, [-np.pi, np.pi], turn, turn, turn]


def test_one_pose_is_solved_wherever_a_branch_reaches_it_even_near_a_singularity():
    """Issue 27: the one-pose IK refused 12-14 % of reachable poses as 'singularity'; one pose has no motion
    to race, so it is solved on the branch nearest the seed, reaching the pose to round-off."""
    robot = UR5e(tool="flange")
    q = np.random.default_rng(7).uniform(-np.pi, np.pi, (2000, 6))
    P, Q = robot.fk(q)
    for p, quat in zip(P, Q, strict=True):
        got_p, got_q = robot.fk(robot.ik(p, quat))
        assert np.abs(got_p - p).max() < 1e-9 and quaternion_angle(got_q, quat) < 1e-9
    # near the wrist singularity (|sin(wrist_2)| = 0.01 < 0.05): one pose is solved, a path into it is not
    near = np.array(HOME) + [0.0, 0.0, 0.0, 0.0, -np.pi / 2 + 0.01, 0.0]
    p, quat = robot.fk(near)
    np.testing.assert_allclose(robot.fk(robot.ik(p, quat, q_seed=near))[0], p, atol=1e-9)
    path_p, path_q = robot.fk(np.stack([HOME, near]))
    with pytest.raises(KinematicsError, match=r"sample 1 is near the wrist singularity"):
        robot.ik(path_p, path_q, q_seed=HOME)
