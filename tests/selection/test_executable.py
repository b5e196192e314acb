"""Executable reuse: pose (position and orientation), gripper and other streams, timing, limits, joints."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank import Constraints, Demonstration, Sphere
from skillbank.core import exp_map, quaternion_angle
from skillbank.editing import relative_rotations
from skillbank.robots import KinematicsError, UR5e, rate_ratio
from skillbank.selection import METHODS, make_executable, peak_rates, reuse

DOWN = [1.0, 0.0, 0.0, 0.0]  # tool z pointing down in the UR base frame
TOL = {"lte": 1e-9, "ja": 1e-6, "promp": 1e-6, "elmap": 1e-9, "dmp": 1e-3}


def reach(k, n=90, t0=20.0):
    """A UR5e-reachable reach (metres, base frame) that turns the tool 60 degrees about its axis, closes the
    gripper at phase 0.6 and records a force; on the clock of a longer recording (starting at t0)."""
    s = np.linspace(0.0, 1.0, n)
    start, goal = np.array([0.35, -0.35, 0.35]), np.array([0.45, 0.05, 0.2])
    bow = (0.02 + 0.01 * k) * np.sin(np.pi * s)
    P = start + np.outer(s, goal - start) + np.c_[0 * s, 0 * s, bow]
    Q = exp_map(np.c_[0.1 * np.sin(np.pi * s), 0 * s, (1.0 + 0.05 * k) * s], reference=DOWN)
    gripper = (s >= 0.6).astype(float)[:, None] * 255.0
    t = t0 + np.linspace(0.0, 2.0 + 0.1 * k, n) + 0.002 * np.sin(7 * s)  # an uneven clock
    q_ref = UR5e().ik(P, Q, q_seed=UR5e.home)
    # the poses are the UR5e's default tool's, the 2F-85's TCP (its joints are their inverse kinematics)
    return Demonstration(t, {"position": P, "orientation": Q, "gripper": gripper,
                             "force": np.c_[s, s ** 2, 0 * s], "joints": q_ref},
                         {"pose_of": "robotiq_2f85:tcp"})


SKILL = [reach(k) for k in range(3)]
GOAL = np.array([0.47, 0.08, 0.18])
GOAL_Q = exp_map([0.0, 0.2, 0.4], reference=SKILL[0]["orientation"][-1])
START_Q = exp_map([0.1, 0.0, -0.2], reference=SKILL[0]["orientation"][0])


@pytest.fixture(scope="module")
def results():
    task = Constraints(goal=GOAL, start_orientation=START_Q, goal_orientation=GOAL_Q)
    return {m: reuse(SKILL, task, method=m, random_state=0) for m in METHODS}


@pytest.mark.parametrize("method", METHODS)
def test_every_method_meets_position_and_orientation(results, method):
    res = results[method]
    traj = res.trajectory
    assert res.constraint_error <= TOL[method] and res.orientation_error <= 1e-9
    assert quaternion_angle(traj["orientation"][[0, -1]], [START_Q, GOAL_Q]).max() <= 1e-9
    q = traj["orientation"]
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    assert (np.einsum("ij,ij->i", q[1:], q[:-1]) > 0).all()
    assert traj.t[0] == 0.0 and np.all(np.diff(traj.t) > 0)
    assert set(traj.stream_names) == {"position", "orientation", "gripper", "force"}
    assert any("joints: the recorded joints" in n for n in res.notes)
    assert any("force: carried from primitive" in n for n in res.notes)


@pytest.mark.parametrize("method", METHODS)
def test_rotation_profile_kept_against_the_unconstrained_reproduction(results, method):
    """The orientation analogue of the shape metric: each relative rotation between successive samples
    changes by the step of the correction field: in total by at most the corrections at the two ends, per
    step by at most twice their mean step (the blend is flat at the ends and steepest in the middle)."""
    plain = reuse(SKILL, Constraints(goal=GOAL), method=method, random_state=0).trajectory["orientation"]
    ours = results[method].trajectory["orientation"]
    change = quaternion_angle(exp_map(relative_rotations(ours)), exp_map(relative_rotations(plain)))
    total = quaternion_angle(ours[0], plain[0]) + quaternion_angle(ours[-1], plain[-1])
    assert change.sum() <= total * (1 + 1e-6)  # the corrections' blend, spread over the path
    assert change.max() <= 2 * total / (len(ours) - 1)


def test_gripper_switches_at_the_mapped_phase_and_stays_discrete(results):
    for res in results.values():
        g = res.trajectory["gripper"].ravel()
        assert set(np.unique(g)) == {0.0, 255.0}
        # the best candidate closes at 60 % of its samples' phase by time; the reproduction at the same phase
        best = SKILL[res.used[0]]
        switch_t = (best.t[np.argmax(best["gripper"][:, 0] > 0)] - best.t[0]) / (best.t[-1] - best.t[0])
        first = res.trajectory.t[np.argmax(g > 0)] / res.trajectory.t[-1]
        step = np.diff(res.trajectory.t).max() / res.trajectory.t[-1]
        assert switch_t <= first < switch_t + step + 1e-12


def test_duration_sets_the_time_base():
    res = reuse(SKILL, Constraints(goal=GOAL, end_velocity=[0.0, 0.0, 0.0]), method="promp", duration=5.0)
    assert res.trajectory.t[0] == 0.0 and res.trajectory.t[-1] == 5.0
    assert res.velocity_error < 1e-6
    default = reuse(SKILL, Constraints(goal=GOAL), method="ja")
    assert default.trajectory.t[-1] == pytest.approx(SKILL[default.used[0]].duration)


def test_limits_are_met_by_slowing_down_without_changing_the_path():
    task = Constraints(goal=GOAL, goal_orientation=GOAL_Q)
    free = reuse(SKILL, task, method="ja", robot="ur5e")
    limits = {"velocity": 0.05, "acceleration": 0.2, "angular_velocity": 0.3, "joint_velocity": 0.4,
              "joint_acceleration": [2.0, 2.0, 2.0, 3.0, 3.0, 3.0]}
    slow = reuse(SKILL, task, method="ja", robot="ur5e", limits=limits)
    assert slow.time_scale > 1.0 and any("time stretched" in n for n in slow.notes)
    for name in ("position", "orientation", "joints", "gripper"):
        # the same path to round-off: two runs of numpy's SIMD loops may differ in the last bit with
        # where their arrays start in memory (seen once in CI: 3.5e-18 in one quaternion component)
        np.testing.assert_allclose(slow.trajectory[name], free.trajectory[name], rtol=0, atol=1e-12)
    np.testing.assert_allclose(slow.trajectory.t, free.trajectory.t * slow.time_scale, rtol=1e-15)
    peaks = peak_rates(slow.trajectory)
    assert peaks == slow.peaks
    assert peaks["position"]["velocity"] <= 0.05 and peaks["position"]["acceleration"] <= 0.2
    assert peaks["orientation"]["velocity"] <= 0.3 and peaks["joints"]["velocity"] <= 0.4
    dq = np.diff(slow.trajectory["joints"], axis=0) / np.diff(slow.trajectory.t)[:, None]
    assert (np.abs(dq).max(axis=0) <= 0.4).all()
    # one limit is met exactly (to round-off): the stretch is no larger than needed
    ratios = [peaks["position"]["velocity"] / 0.05, np.sqrt(peaks["position"]["acceleration"] / 0.2),
              peaks["orientation"]["velocity"] / 0.3, peaks["joints"]["velocity"] / 0.4]
    dt = np.diff(slow.trajectory.t)
    dd = np.diff(dq, axis=0) / (0.5 * (dt[1:] + dt[:-1]))[:, None]
    ratios.append(np.sqrt((np.abs(dd) / [2.0, 2.0, 2.0, 3.0, 3.0, 3.0]).max()))
    assert max(ratios) == pytest.approx(1.0, abs=1e-9)


def test_a_duration_too_short_for_the_limits_is_stretched_with_a_note():
    task = Constraints(goal=GOAL)
    res = reuse(SKILL, task, method="ja", duration=0.5, limits={"velocity": 0.01})
    assert res.time_scale > 1.0 and res.trajectory.t[-1] == pytest.approx(0.5 * res.time_scale, rel=1e-12)
    assert peak_rates(res.trajectory)["position"]["velocity"] == pytest.approx(0.01, rel=1e-9)
    note = next(n for n in res.notes if n.startswith("time stretched"))
    assert note == (f"time stretched by {res.time_scale:.4g} to meet velocity 0.01: 0.5 s -> "
                    f"{res.trajectory.t[-1]:.6g} s")


@pytest.mark.parametrize("law", ["toppra", "uniform"])
def test_the_robots_own_limits_always_apply(law):
    """1 ns asked for: timed to the UR5e's 180 deg/s and 180 deg/s^2, one of them met exactly (the time
    law meets it as the exports measure it: finite differences and a ROS 2 bag's numpy.gradient)."""
    task = Constraints(goal=GOAL, goal_orientation=GOAL_Q)
    res = reuse(SKILL, task, method="ja", robot="ur5e", duration=1e-9, time_law=law)
    J, t = res.trajectory["joints"], res.trajectory.t
    v = np.diff(J, axis=0) / np.diff(t)[:, None]
    a = np.diff(v, axis=0) / (0.5 * (t[2:] - t[:-2]))[:, None]
    ratio = max(np.abs(v).max() / np.pi, np.sqrt(np.abs(a).max() / np.pi))
    if law == "toppra":
        measured = rate_ratio(t, J, velocity=np.pi, acceleration=np.pi)
        assert ratio <= 1.0 and measured == pytest.approx(1.0, abs=1e-9)
        note = next(n for n in res.notes if n.startswith("time law toppra"))
        own = "3.142 (the ur5e's own limit)"
        head = (f"time law toppra (TOPP-RA, path kept) for joint_velocity {own} and joint_acceleration "
                f"{own}: 1e-09 s -> {t[-1]:.6g} s (a uniform stretch: ")
        assert note.startswith(head), note
        assert res.trajectory.metadata["timing"] == {"law": "toppra", "limits": {
            "joint_velocity": [np.pi] * 6, "joint_acceleration": [np.pi] * 6}}
        return
    assert ratio <= 1.0 and ratio == pytest.approx(1.0, abs=1e-9)
    note = next(n for n in res.notes if n.startswith("time stretched"))
    assert note.endswith(f"(the ur5e's own limit): 1e-09 s -> {t[-1]:.6g} s"), note
    assert note.startswith(f"time stretched by {res.time_scale:.4g} to meet joint_")
    # a given limit above the robot's: the robot's applies, and a note says so
    fast = reuse(SKILL, task, method="ja", robot="ur5e", duration=1e-9, limits={"joint_velocity": 10.0},
                 time_law=law)
    assert "joint_velocity: 10 is above the ur5e's own limit 3.142; the robot's limit applies" in fast.notes
    np.testing.assert_array_equal(fast.trajectory.t, t)
    # a tighter given limit is met as given
    slow = reuse(SKILL, task, method="ja", robot="ur5e", limits={"joint_velocity": 0.2})
    dq = np.diff(slow.trajectory["joints"], axis=0) / np.diff(slow.trajectory.t)[:, None]
    assert np.abs(dq).max() <= 0.2


def test_the_chosen_branch_is_followed():
    task = Constraints(goal=GOAL, goal_orientation=GOAL_Q)
    robot = UR5e()
    default = reuse(SKILL, task, method="ja", robot="ur5e")
    recorded = robot.branch_of(SKILL[0]["joints"][:1])[0]
    assert set(robot.branch_of(default.trajectory["joints"])) == {recorded}
    reachable = ~np.isnan(robot.ik_all(default.trajectory["position"], default.trajectory["orientation"])
                          ).any(axis=2).any(axis=0)
    others = [b for b in np.flatnonzero(reachable) if b != recorded]
    assert others
    for b in others[:2]:
        res = reuse(SKILL, task, method="ja", robot="ur5e", branch=robot.branch_names[b])
        J = res.trajectory["joints"]
        assert set(robot.branch_of(J)) == {b}
        np.testing.assert_allclose(robot.fk(J)[0], res.trajectory["position"], atol=1e-9)
        # the branch's name is the signs: the elbow's and the wrist's relative to the shoulder's
        elbow_up = np.sign(np.sin(J[:, 2]) * _reach(J)) < 0
        assert set(elbow_up) == {"elbow-up" in robot.branch_names[b]}


def _reach(q):
    t2, t23, t234 = q[:, 1], q[:, 1] + q[:, 2], q[:, 1] + q[:, 2] + q[:, 3]
    return -0.425 * np.cos(t2) - 0.3922 * np.cos(t23) + 0.0997 * np.sin(t234)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"t": np.linspace(0.0, 0.5, 90), "limits": {"velocity": 0.01}},
     r"limits: velocity 0.01 cannot be met on the 0.5 s time base given: it needs at least \d+"),
    ({"duration": 1e-12}, r"duration: expected seconds in \[1e-09, 1e\+09\], got 1e-12 \(a short duration is "
                          r"stretched to the robot's limits anyway: give at least 1e-09 s\)"),
    ({"duration": 2e9}, r"duration: expected seconds in \[1e-09, 1e\+09\], got 2e\+09 \(split a longer task"),
    ({"duration": float("nan")}, r"duration: expected a number > 0, got nan"),
    ({"branch": "elbow-up"}, r"branch: an inverse-kinematics branch needs a robot"),
    ({"robot": "ur5e", "branch": "elbow-up"},
     r"branch: expected one of \['shoulder-left/elbow-up/wrist-up', .*"
     r"'shoulder-right/elbow-down/wrist-down'\] or an index below 8, got 'elbow-up'"),
    ({"limits": {"velocity": 1e-320}},
     r"limits\['velocity'\]: expected at least 1e-09 \(a smaller limit stretches any motion past 1e\+09 s\), "
     r"got 1e-320"),
    ({"robot": "ur5e", "limits": {"joint_velocity": 1e-9}},
     r"limits: joint_velocity 1e-09 would stretch the motion to [\d.e+]+ s, more than 1e\+09 s: give a "
     r"larger limit"),
    ({"robot": "ur5e", "limits": {"joint_velocity": [1.0, 2.0]}},
     r"limits\['joint_velocity'\]: expected one number, or one per joint of ur5e \(6\), got 2"),
    ({"limits": {"velocity": 0.01}, "task": Constraints(goal=GOAL, end_velocity=[0.1, 0.0, 0.0])},
     r"limits: velocity 0.01 needs the motion slowed down .* non-zero end velocity"),
    ({"limits": {"speed": 1.0}}, r"limits: expected keys among \['velocity'"),
    ({"limits": {"velocity": -1.0}}, r"limits\['velocity'\]: expected a number > 0"),
    ({"limits": {"joint_velocity": [1.0, 0.0]}}, r"limits\['joint_velocity'\]: expected numbers > 0"),
    ({"limits": [1.0]}, r"limits: expected a dict"),
    ({"duration": 0.0}, r"duration: expected a number > 0"),
    ({"duration": 1.0, "t": np.linspace(0, 1, 20)}, r"duration: give a duration or a time base t, not both"),
    ({"robot": "ur3"}, r"robot: expected one of \['ur5e', 'panda'\] or a URDF / MJCF file, got 'ur3'"),
])
def test_timing_errors(kwargs, match):
    task = kwargs.pop("task", Constraints(goal=GOAL))
    with pytest.raises(ValueError, match=match):
        reuse(SKILL, task, method="ja", **kwargs)


def test_orientation_constraint_without_orientation_streams():
    plain = [Demonstration(d.t, {"position": d["position"]}) for d in SKILL]
    with pytest.raises(ValueError, match=r"no usable candidate: 0: no 'orientation' stream for the "
                                         r"orientation constraints \(streams \['position'\]\)"):
        reuse(plain, Constraints(goal_orientation=GOAL_Q), method="ja")
    with pytest.raises(ValueError, match=r"constraints: orientation constraints need an 'orientation'"):
        make_executable(plain[0], plain, Constraints(goal_orientation=GOAL_Q))
    # a mixed skill: the candidates without orientation are set aside, with the reason
    res = reuse([plain[0], SKILL[1]], Constraints(goal_orientation=GOAL_Q), method="ja", ids=["a", "b"])
    assert res.used == ["b"] and "no 'orientation' stream" in res.rejected["a"]


def test_arrays_still_work_and_get_no_other_streams():
    s = np.linspace(0.0, 1.0, 50)
    res = reuse([np.c_[s, s]], Constraints(goal=[1.0, 2.0]), method="lte", duration=2.0)
    assert res.trajectory.stream_names == ["position"] and res.trajectory.t[-1] == 2.0
    assert set(res.peaks) == {"position"} and "joints" not in res.to_dict()


def test_recorded_derivatives_are_not_carried_onto_the_new_path():
    # RAIL stores velocity and acceleration: they describe the demonstration, not the adapted path
    s = np.linspace(0.0, 1.0, 60)
    t = 2.0 * s
    P = np.c_[s, s ** 2, 0 * s]
    demo = Demonstration(t, {"position": P, "velocity": np.gradient(P, t, axis=0), "force": np.c_[s, s, s]})
    res = reuse([demo], Constraints(goal=[1.2, 0.5, 0.1]), method="lte")
    assert res.trajectory.stream_names == ["position", "force"]
    assert any(n.startswith("velocity: the recorded velocity of primitive 0 was dropped") for n in res.notes)


def test_robot_joints_reproduce_the_pose_path_on_the_recorded_branch():
    task = Constraints(goal=GOAL, goal_orientation=GOAL_Q)
    res = reuse(SKILL, task, method="promp", robot="ur5e", random_state=0, limits={"joint_velocity": 1.0})
    traj = res.trajectory
    robot = UR5e()
    position, quaternion = robot.fk(traj["joints"])
    assert np.abs(position - traj["position"]).max() < 1e-9
    assert quaternion_angle(quaternion, traj["orientation"]).max() < 1e-9
    assert traj.metadata["joint_names"] == list(robot.joint_names)
    # the branch of the best candidate's recorded joints, within limits, continuous
    best = SKILL[res.used[0]]
    assert robot.branch_of(traj["joints"][0]) == robot.branch_of(best["joints"][0])
    assert (traj["joints"] >= robot.limits[:, 0]).all() and (traj["joints"] <= robot.limits[:, 1]).all()
    assert np.abs(np.diff(traj["joints"], axis=0)).max() < 0.1
    doc = res.to_dict()
    assert doc["joint_names"] == list(robot.joint_names)
    assert doc["peak_joint_velocity"] == pytest.approx(res.peaks["joints"]["velocity"])
    assert doc["peak_joint_velocity"] <= 1.0


def test_robot_errors_name_the_sample():
    with pytest.raises(KinematicsError, match=r"robot ur5e: position: sample \d+ is out (of|on branch)"):
        reuse(SKILL, Constraints(goal=[1.5, 0.0, 0.2]), method="ja", robot="ur5e")
    plain = [Demonstration(d.t, {"position": d["position"]}) for d in SKILL]
    with pytest.raises(ValueError, match=r"robot: ur5e inverse kinematics needs an 'orientation' stream"):
        reuse(plain, Constraints(goal=GOAL), method="ja", robot="ur5e")
    flat = [Demonstration(d.t, {"position": d["position"][:, :2], "orientation": d["orientation"]})
            for d in SKILL]
    with pytest.raises(ValueError, match=r"robot: ur5e inverse kinematics needs 3-D positions, got 2-D"):
        reuse(flat, Constraints(), method="ja", robot="ur5e")


def test_obstacles_and_orientation_together():
    mid = SKILL[0]["position"][45]
    task = Constraints(goal=GOAL, goal_orientation=GOAL_Q, obstacles=[Sphere(mid + [0.0, 0.0, 0.005], 0.02)])
    res = reuse(SKILL, task, method="promp", random_state=0)
    assert not res.collision and res.orientation_error <= 1e-9 and res.constraint_error < 1e-6


def test_three_button_reach_to_a_new_button_with_a_new_orientation(data_dir):
    """The recorded moves between presses as the skill: a new goal 3 cm away, the tool turned 10 degrees about
    its axis there; joints for the UR5e on the recorded branch, FK giving back the pose path."""
    from skillbank.io import load

    demo = load(data_dir / "seed" / "three_button_pressing_demo.h5")
    moves = [demo.slice(a, b) for a, b in ((1385, 2074), (2074, 2775), (2775, 3351))]
    best = moves[0]
    goal = best["position"][-1] + [0.03, -0.02, 0.0]
    goal_q = exp_map([0.0, 0.0, np.radians(10.0)], reference=best["orientation"][-1])
    res = reuse(moves, Constraints(goal=goal, goal_orientation=goal_q), method="ja", robot="ur5e",
                ids=[3, 4, 5], limits={"joint_velocity": 0.5})
    traj = res.trajectory
    assert traj.t[0] == 0.0 and res.constraint_error < 1e-9 and res.orientation_error < 1e-9
    robot = UR5e()
    position, quaternion = robot.fk(traj["joints"])
    assert np.abs(position - traj["position"]).max() < 1e-9
    assert quaternion_angle(quaternion, traj["orientation"]).max() < 1e-9
    recorded = demo.slice(1385, 2074) if res.used == [3] else moves[[3, 4, 5].index(res.used[0])]
    assert robot.branch_names[int(robot.branch_of(traj["joints"][0])[0])] == "shoulder-left/elbow-up/wrist-up"
    assert robot.branch_of(recorded["joints"][0]) == robot.branch_of(traj["joints"][0])
    assert set(np.unique(traj["gripper"])) <= set(np.unique(recorded["gripper"]))
    assert res.peaks["joints"]["velocity"] <= 0.5
    assert {"force", "torque"} <= set(traj.stream_names)
