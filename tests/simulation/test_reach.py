"""Commanded paths kept within the arm's reach margin, on robosuite's own UR5e (real scenes, no mock)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("robosuite")  # the extra skillbank[sim]

from skillbank.simulation._reach import _SPREAD, REACH_MARGIN, Reach  # noqa: E402


def _scene(robot="UR5e"):
    from skillbank.simulation._evaluate import _make
    from skillbank.simulation._robosuite import import_robosuite

    env = _make(import_robosuite(), "PickPlace", 0, 1000) if robot == "UR5e" else \
        import_robosuite().make("Lift", robots=[robot], has_renderer=False, has_offscreen_renderer=False,
                                use_camera_obs=False, ignore_done=True)
    return env, env.reset()


@pytest.fixture(scope="module")
def pickplace():
    env, obs = _scene()
    yield env, obs, Reach(env)
    env.close()


def _elbow(reach, P, Q, joints):
    branch = int(reach.model_.branch_of(joints)[0])
    return reach._measure(np.asarray(P, float), np.asarray(Q, float), branch)


def test_the_model_is_robosuites_arm_where_robosuite_put_it(pickplace):
    env, obs, reach = pickplace
    position, quaternion = reach.model_.fk(obs["robot0_joint_pos"])
    assert np.linalg.norm(position - obs["robot0_eef_pos"]) < 3e-3
    assert abs(abs(float(np.dot(quaternion, obs["robot0_eef_quat"]))) - 1) < 1e-4


def test_a_path_within_the_margin_is_kept_as_it_is(pickplace):
    env, obs, reach = pickplace
    here = np.asarray(obs["robot0_eef_pos"], float)
    P = here + np.linspace(0.0, 1.0, 30)[:, None] * [0.1, 0.0, -0.05]
    Q = np.tile(obs["robot0_eef_quat"], (30, 1))
    assert _elbow(reach, P, Q, obs["robot0_joint_pos"]).min() >= REACH_MARGIN
    np.testing.assert_array_equal(reach.keep(P, Q, obs["robot0_joint_pos"]), P)


def test_a_rise_at_the_far_side_of_the_second_bin_is_pulled_in_until_the_elbow_stays_bent(pickplace):
    """The can's place (robosuite's target for it, the bins' far corner) and straight up from it: the
    UR5e's elbow straightens on the way up. Kept: every pose's elbow measure is at least the margin but
    for the last half second's, which ease back to the path's end, the pull is horizontal and towards
    the base axis, and the path stays as smooth as it was."""
    env, obs, reach = pickplace
    joints = np.asarray(obs["robot0_joint_pos"], float)
    place = np.asarray(env.target_bin_placements[env.object_to_id["can"]], float) + [0.0, 0.0, 0.18]
    Q = np.tile(obs["robot0_eef_quat"], (40, 1))
    P = place + np.clip(np.linspace(0.0, 1.5, 40), 0, 1)[:, None] * [0.0, 0.0, 0.12]  # up, then held
    before = _elbow(reach, P, Q, joints)
    assert before.min() < REACH_MARGIN  # the case is one the margin is for
    kept = reach.keep(P, Q, joints)
    # the end is where the task needs the tool: kept, the pull easing out over the last half second
    np.testing.assert_array_equal(kept[-1], P[-1])
    assert _elbow(reach, kept[:-_SPREAD], Q[:-_SPREAD], joints).min() >= REACH_MARGIN - 1e-9
    np.testing.assert_array_equal(kept[:, 2], P[:, 2])
    axis = reach.model_.base[:2, 3]
    inward = np.linalg.norm(P[:, :2] - axis, axis=1) - np.linalg.norm(kept[:, :2] - axis, axis=1)
    assert (inward >= -1e-12).all() and inward.max() > 0.0
    # pulled along the line to the base axis: the direction from the axis is unchanged
    d0, d1 = P[:, :2] - axis, kept[:, :2] - axis
    np.testing.assert_allclose(np.cross(d0, d1), 0.0, atol=1e-12)
    assert np.abs(np.diff(kept, axis=0)).max() <= np.abs(np.diff(P, axis=0)).max() + 0.01


def test_an_arm_without_a_registered_model_is_left_as_it_is():
    env, obs = _scene("Panda")
    try:
        reach = Reach(env)
        assert reach.model_ is None
        P = np.asarray(obs["robot0_eef_pos"], float) + np.zeros((3, 3))
        np.testing.assert_array_equal(reach.keep(P, np.tile(obs["robot0_eef_quat"], (3, 1)),
                                                 obs["robot0_joint_pos"]), P)
    finally:
        env.close()


def test_a_retreat_after_letting_go_keeps_no_pose_and_is_pulled_in_from_where_it_starts(pickplace):
    """The same rise, as the segment that leaves a can let go over its place: nothing needs the tool at
    its end, so every pose keeps the margin but the first, where the tool is, which the pull eases in
    from; a pose the task needs in the middle (where the gripper acts) is kept where it is."""
    env, obs, reach = pickplace
    joints = np.asarray(obs["robot0_joint_pos"], float)
    place = np.asarray(env.target_bin_placements[env.object_to_id["can"]], float) + [0.0, 0.0, 0.18]
    Q = np.tile(obs["robot0_eef_quat"], (40, 1))
    P = place + np.clip(np.linspace(0.0, 1.5, 40), 0, 1)[:, None] * [0.0, 0.0, 0.12]
    leaving = reach.keep(P, Q, joints, need=Reach.needed(-np.ones(40), let_go=True))
    np.testing.assert_allclose(leaving[0], P[0], atol=0.01)  # eased in from where the tool is
    assert _elbow(reach, leaving[_SPREAD:], Q[_SPREAD:], joints).min() >= REACH_MARGIN - 1e-9
    middle = reach.keep(P, Q, joints, need=20)
    np.testing.assert_array_equal(middle[20], P[20])
    assert _elbow(reach, middle[20 + _SPREAD:], Q[20 + _SPREAD:], joints).min() >= REACH_MARGIN - 1e-9


@pytest.mark.parametrize(("grip", "let_go", "need"), [
    ([-1, -1, 1, 1], False, 2),  # closes: the pose where it closes
    ([1, 1, -1], True, 2),  # lets go: where it opens
    ([1, 1, 1], False, 2),  # carries: where the carry ends
    ([-1, -1, -1], False, 2),  # reaches: where the reach ends
    ([-1, -1, -1], True, -1),  # leaves what it let go of: none
])
def test_the_pose_a_path_needs_is_where_its_gripper_acts(grip, let_go, need):
    assert Reach.needed(grip, let_go=let_go) == need
