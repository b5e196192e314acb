"""Free-space moves planned for the whole arm in a robosuite scene's own MuJoCo geometry (issue 43)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("robosuite")
pytest.importorskip("ompl")

from skillbank.robots import MotionPlanningError  # noqa: E402
from skillbank.simulation._evaluate import _Episode, _make  # noqa: E402
from skillbank.simulation._robosuite import import_robosuite  # noqa: E402
from skillbank.simulation._transit import (  # noqa: E402
    ArmScene,
    free_move,
    free_span,
    move_to,
    plan_transit,
    reachable,
)

# two corners of PickPlace's second bin, low enough that a straight move between them takes the fingers
# through the bin's dividers (their tops at z = 0.9 m)
A, B = np.array([0.0, 0.15, 0.88]), np.array([0.2, 0.41, 0.88])


@pytest.fixture(scope="module")
def env():
    environment = _make(import_robosuite(), "PickPlace", 900, 10 ** 6)
    yield environment
    environment.close()


def _line(a, b, quat, n=40):
    P = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
    return P, np.tile(quat, (n, 1)), np.full(n, -1.0)


def _way_across(here, quat, swing):
    """A 11 cm move whose middle (samples 10-30 of 40) swings out by ``swing`` (m) and back."""
    P, Q, G = _line(here, here + [0.05, 0.1, 0.0], quat)
    P[10:30] += np.sin(np.linspace(0, np.pi, 20))[:, None] * np.asarray(swing, float)
    return P, Q, G


def _touches(env) -> list:
    """The robot's (arm's or gripper's) geoms touching anything else now, by name."""
    m, d = env.sim.model, env.sim.data._data
    names = [m.geom_id2name(i) or m.body_id2name(m.geom_bodyid[i]) for i in range(m.ngeom)]
    robot = np.array([n.startswith(("robot0_", "gripper0_")) for n in names])
    g1, g2 = d.contact.geom1[:d.ncon], d.contact.geom2[:d.ncon]
    return [f"{names[a]}/{names[b]}" for a, b in zip(g1, g2, strict=True) if robot[a] != robot[b]]


def _drive(episode, P, Q):
    touched = []
    for p, q in zip(P, Q, strict=True):
        episode.step(p, q, -1.0)
        touched += _touches(episode.env)
    episode.settle(P[-1], Q[-1])
    return touched


def _run(env, planner, seed=0):
    """Reset, go to A (planned), then A -> B straight or planned: (touches on A -> B, report, tool end)."""
    obs = env.reset()
    episode = _Episode(env, obs, 10 ** 6)
    quat = np.array(obs["robot0_eef_quat"], float)
    P, Q, G = _line(np.array(obs["robot0_eef_pos"], float), A + [0, 0, 0.03], quat)
    P, Q, G, _ = free_move(env, episode.obs, P, Q, G, (0, len(P) - 1), random_state=seed)
    _drive(episode, P, Q)
    P, Q, G = _line(A + [0, 0, 0.03], A, quat, n=20)
    _drive(episode, P, Q)
    assert not _touches(env)
    P, Q, G = _line(np.array(episode.obs["robot0_eef_pos"], float), B, quat)
    report = None
    if planner == "ompl":
        P, Q, G, report = free_move(env, episode.obs, P, Q, G, (0, len(P) - 1), random_state=seed)
    return _drive(episode, P, Q), report, np.array(episode.obs["robot0_eef_pos"], float)


def test_a_straight_move_that_hits_the_bin_is_planned_clear(env):
    touched, _, _ = _run(env, "none")
    assert any("bin2" in t for t in touched)  # today's straight move: the fingers hit the divider
    touched, report, end = _run(env, "ompl")
    assert report["planned"] and report["samples"] > 0
    assert touched == []
    assert np.linalg.norm(end - B) < 0.01  # and it still arrives


def test_the_plan_is_deterministic_and_clear_at_every_checked_state(env):
    env.reset()
    scene = ArmScene(env)
    q0 = np.array(env.sim.data.qpos[scene.qadr], float)
    quat = scene.tool(q0)[1]
    qa, qb = scene.ik(A, quat, q0), None
    qb = scene.ik(B, quat, qa)
    assert scene.blocking(qa) is None and scene.blocking(qb) is None
    assert not scene.motion_clear(qa, qb)  # straight in joint space it hits the divider too
    J1, _ = plan_transit(scene, qa, qb, random_state=3)
    J2, _ = plan_transit(scene, qa, qb, random_state=3)
    np.testing.assert_array_equal(J1, J2)
    assert np.allclose(J1[0], qa) and np.allclose(J1[-1], qb)
    assert all(scene.motion_clear(a, b) for a, b in zip(J1[:-1], J1[1:], strict=True))


def test_a_blocked_goal_is_one_line_naming_the_obstacle(env):
    env.reset()
    scene = ArmScene(env)
    q0 = np.array(env.sim.data.qpos[scene.qadr], float)
    quat = scene.tool(q0)[1]
    inside = scene.ik([0.1, 0.28, 0.86], quat, q0)  # the fingers down through the divider's crossing
    with pytest.raises(MotionPlanningError, match=r"^transit planning: the goal \[.*\] is not clear: "
                                                  r"gripper0_\w+ comes .* bin2 \(geom \d+\)") as error:
        plan_transit(scene, q0, inside, random_state=0)
    assert "\n" not in str(error.value)


def test_a_held_object_moves_with_the_hand_and_is_checked(env):
    obs = env.reset()
    scene = ArmScene(env, held="Can")  # as if the can sat where it is, rigidly in the hand
    q0 = np.array(obs["robot0_joint_pos"], float)
    assert any(scene.names[g].startswith("Can") for g in np.flatnonzero(scene.moving))
    p, quat = scene.tool(q0)
    can = np.array(obs["Can_pos"], float)
    q = scene.ik(p + [0.0, 0.0, 0.05], quat, q0)
    scene.set(q)
    body = scene.model.body("Can_main").id
    np.testing.assert_allclose(scene.data.xpos[body], can + [0.0, 0.0, 0.05], atol=1e-3)
    with pytest.raises(ValueError, match="held: the scene has no object 'Mug'"):
        ArmScene(env, held="Mug")


def test_a_held_object_keeps_the_slack_it_has_in_the_hand_clear_too(env):
    obs = env.reset()
    q0 = np.array(obs["robot0_joint_pos"], float)
    tight, slack = ArmScene(env, held="Can"), ArmScene(env, held="Can", slack=0.02)
    p, quat = tight.tool(q0)
    q = tight.ik(p + [0.0, 0.0, 0.015], quat, q0)  # the can 1.5 cm above the bin's floor it stood on

    def can_near(scene):
        return [d for d, a, _ in scene.near(q) if scene.names[a].startswith("Can")]

    assert can_near(tight) == []  # clear by the margin, 1 cm
    assert can_near(slack) and 0.01 < min(can_near(slack)) < 0.03  # not by the margin and the slack
    said = slack.describe(slack.blocking(q))
    assert said.endswith("(held: it keeps 30 mm, the margin and its slack in the hand)"), said
    assert tight.blocking(q0) is not None and slack.blocking(q0) is not None
    with pytest.raises(ValueError, match=r"slack: expected a non-negative number of metres, got -0\.01"):
        ArmScene(env, held="Can", slack=-0.01)


def test_free_span_is_decided_by_the_gripper_and_the_phases():
    assert free_span(41, [-1] * 20 + [1] * 21) == (0, 20)  # a reach: up to its close-in
    assert free_span(41, [-1] * 41, let_go=True) == (0, 40)  # a retreat after a release: to its end
    assert free_span(5, [-1] * 5) == (0, 2) and free_span(4, [-1] * 4) is None  # too short to plan


@pytest.mark.parametrize("run", ["evaluate", "execute_plan"])
def test_a_planner_not_known_is_refused_before_the_library_is_read(tmp_path, run):
    from skillbank import simulation

    scene = "robosuite:Lift" if run == "evaluate" else "robosuite:PickPlace"
    with pytest.raises(ValueError, match=r"^planner: expected one of \['ompl', 'none'\], got 'rrt'$"):
        getattr(simulation, run)(tmp_path / "absent.db", scene, planner="rrt")


def test_a_free_span_is_planned_and_one_beyond_reach_is_driven_as_adapted(env):
    obs = env.reset()
    quat = np.array(obs["robot0_eef_quat"], float)
    here = np.array(obs["robot0_eef_pos"], float)
    # a wandering way across, high over the bins: the span is replaced by the planned move, which ends
    # where the skill's own part after it begins
    P, Q, G = _way_across(here, quat, [0.0, 0.0, 0.08])
    P2, Q2, G2, report = free_move(env, obs, P, Q, G, (5, 34))
    assert report["planned"] and report["why"] == "planned" and report["span"] == (5, 34)
    np.testing.assert_array_equal(P2[:6], P[:6])
    np.testing.assert_array_equal(P2[-5:], P[-5:])
    assert len(P2) == 6 + report["samples"] + 5
    np.testing.assert_allclose(P2[5 + report["samples"]], P[34], atol=1e-3)  # it ends where the skill goes on
    assert (P2[6:6 + report["samples"], 2] < P[10:30, 2].max() - 0.03).all()  # not the wandering hump
    P, Q, G = _line(here, here + [0.05, 0.1, 0.0], quat, n=8)  # 11 cm in all: shorter than 5 cm apart
    assert free_move(env, obs, P, Q, G, (3, 4))[3]["why"] == "short"
    P, Q, G = _line(here, here + [2.0, 0.0, 0.0], quat)  # two metres out: beyond the arm's reach
    P2, _, _, report = free_move(env, obs, P, Q, G, (30, 39))
    assert report["why"].startswith("out of reach at sample") and P2 is P


def test_a_transit_between_skills_is_planned_for_the_whole_arm(env):
    """From low in one compartment of bin2 to the far corner of another: the planned move arrives, and no
    robot geom touches the bin on the way; the same seed, the same move."""
    obs = env.reset()
    episode = _Episode(env, obs, 10 ** 6)
    quat = np.array(obs["robot0_eef_quat"], float)
    P, Q, _, _ = move_to(env, episode.obs, A + [0, 0, 0.03], quat, random_state=0)
    _drive(episode, P, Q)
    P, Q, _ = _line(A + [0, 0, 0.03], A, quat, n=20)[:2] + (None,)
    _drive(episode, P, Q)
    P1, Q1, seconds, _ = move_to(env, episode.obs, B, quat, random_state=0)
    P2, _, _, _ = move_to(env, episode.obs, B, quat, random_state=0)
    np.testing.assert_array_equal(P1, P2)
    assert seconds > 0 and np.linalg.norm(P1[-1] - B) < 1e-3
    assert _drive(episode, P1, Q1) == []
    assert np.linalg.norm(np.array(episode.obs["robot0_eef_pos"], float) - B) < 0.01


def test_a_transit_out_of_reach_is_one_line(env):
    obs = env.reset()
    quat = np.array(obs["robot0_eef_quat"], float)
    with pytest.raises(MotionPlanningError, match=r"^transit planning: the tool pose \[2\.0, 0\.0, 1\.0\] m "
                                                  r"is out of the arm's reach from \[.*\]$"):
        move_to(env, obs, [2.0, 0.0, 1.0], quat)


def test_which_goal_poses_the_arm_can_take(env):
    obs = env.reset()
    here, quat = np.array(obs["robot0_eef_pos"], float), np.array(obs["robot0_eef_quat"], float)
    can = reachable(env, obs)
    assert can(here + [0.1, 0.3, -0.1], quat)  # over the second bin
    assert not can(here + [2.0, 0.0, 0.0], quat)  # two metres out


def test_the_arm_against_itself_is_a_collision(env):
    """A UR5e folded onto itself (its upper arm through its second wrist link) is not clear, and a goal
    there is refused in one line naming both; the fingers' own touching parts are not collisions."""
    obs = env.reset()
    scene = ArmScene(env)
    q0 = np.array(obs["robot0_joint_pos"], float)
    assert scene.blocking(q0) is None
    assert all(scene.moving[a] and scene.moving[b] and "gripper0" in scene.names[a]
               for a, b in scene.touching)
    folded = np.array([-2.52, -0.97, -2.96, -4.72, 2.14, 1.85])
    hit = scene.blocking(folded)
    assert hit is not None and {scene.names[hit[1]], scene.names[hit[2]]} == {"robot0_upperarm_col",
                                                                             "robot0_wrist2_col"}
    with pytest.raises(MotionPlanningError, match=r"^transit planning: the goal \[.*\] is not clear: "
                                                  r"robot0_\w+ comes [\d.]+ mm into robot0_\w+"):
        plan_transit(scene, q0, folded, random_state=0)


def test_a_planned_move_is_timed_by_the_time_law_to_its_limits(env):
    """A radian of the wrist's last joint alone (the tool point barely moves): TOPP-RA from rest to rest
    at 0.8 rad/s and 1 rad/s^2 takes 1 / 0.8 + 0.8 = 2.05 s, 41 control steps at 20 Hz; a sweep of the
    first joint is stretched until the tool keeps to 0.25 m/s."""
    from skillbank.simulation._transit import JOINT_ACCELERATION, JOINT_SPEED, TOOL_SPEED, _timed

    obs = env.reset()
    scene = ArmScene(env)
    q0 = np.array(obs["robot0_joint_pos"], float)
    wrist = q0 + np.r_[np.zeros(len(q0) - 1), 1.0]
    P, Q, _ = _timed(scene, np.stack([q0, wrist]))
    # its duration to a control step (the law's exact fit leaves a few ulps over 2.05 s)
    assert abs(len(P) - (1.0 / JOINT_SPEED + JOINT_SPEED / JOINT_ACCELERATION) * 20) <= 1
    np.testing.assert_allclose(Q[-1], scene.tool(wrist)[1], atol=1e-9)
    sweep = q0 + np.r_[1.0, np.zeros(len(q0) - 1)]
    P, _, _ = _timed(scene, np.stack([q0, sweep]))
    speed = np.linalg.norm(np.diff(np.vstack([scene.tool(q0)[0], P]), axis=0), axis=1) * 20
    assert speed.max() <= TOOL_SPEED * 1.05 and speed.max() > TOOL_SPEED * 0.8


def test_a_way_across_beyond_reach_is_planned_to_the_first_close_in_pose_the_arm_takes(env):
    """A person's way across swings a metre and a half out (moved onto a new scene): the free span's end
    is out of the arm's reach, so the planned move goes on to the first pose of the close-in it takes,
    and the path goes on from there as adapted."""
    obs = env.reset()
    quat = np.array(obs["robot0_eef_quat"], float)
    here = np.array(obs["robot0_eef_pos"], float)
    P, Q, G = _way_across(here, quat, [1.5, 0.0, 0.0])
    P2, Q2, G2, report = free_move(env, obs, P, Q, G, (5, 20))
    assert report["planned"] and report["span"][0] == 5
    b = report["span"][1]
    assert b > 20 and np.linalg.norm(P[b] - P[b - 1]) > 0  # on along the close-in, past the span's end
    assert len(P2) == 6 + report["samples"] + len(P) - b - 1
    np.testing.assert_allclose(P2[5 + report["samples"]], P[b], atol=1e-3)
    np.testing.assert_array_equal(P2[6 + report["samples"]:], P[b + 1:])


def test_an_arm_with_a_joint_to_spare_is_driven_through_the_joints_its_plan_checked():
    """The Panda's seven joints leave one to spare: driven along the planned tool poses alone, the
    operational-space controller spends it on the joints of its reset, and the arm passes through joints
    the plan never checked for clearance (0.3 rad away at the end, the tool where it should be); held at
    the plan's joints, it ends where the plan does."""
    env = _make(import_robosuite(), "PickPlace", 900, 10 ** 6, robot="Panda")
    try:
        ends = []
        for posture in (True, False):
            obs = env.reset()
            episode = _Episode(env, obs, 10 ** 6)
            goal = np.array([0.1, 0.3, 1.0])  # above bin2, clear of everything
            P, Q, _, J = move_to(env, episode.obs, goal, np.array(obs["robot0_eef_quat"], float),
                                 random_state=0)
            for p, q, joints in zip(P, Q, J, strict=True):
                episode.step(p, q, -1.0, posture=joints if posture else None)
            for _ in range(20):
                episode.step(P[-1], Q[-1], -1.0)
            ends.append((float(np.abs(np.array(episode.obs["robot0_joint_pos"]) - J[-1]).max()),
                         float(np.linalg.norm(np.array(episode.obs["robot0_eef_pos"]) - goal))))
    finally:
        env.close()
    (held, held_miss), (drifted, drifted_miss) = ends
    assert held < 0.05 and drifted > 0.2
    assert held_miss < 0.003 and drifted_miss < 0.003
