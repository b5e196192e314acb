"""The joint-space motion planner (issue 43, item 1): OMPL's RRTConnect, checked by the whole robot's
clearance."""

from __future__ import annotations

import sys

import numpy as np
import pytest

pytest.importorskip("ompl")  # the extra skillbank[plan]

from skillbank.core import Box, Sphere  # noqa: E402
from skillbank.robots import MotionPlanningError, clearance, plan_motion, robot_model  # noqa: E402
from skillbank.robots._motion import _held_capsule, _ompl_path  # noqa: E402

DOWN = [0.0, 1.0, 0.0, 0.0]
TABLE = Box([-2.0, -2.0, -0.05], [2.0, 2.0, 0.0])
#: A 40 cm wall between two points over a table in front of the UR5e.
WALL = {"wall": Box([-0.6, -0.02, 0.0], [-0.3, 0.02, 0.40])}
#: A 30 cm wall with a shelf 8 cm over its top (no way straight over: the path changes branch).
SHELF = {"wall": Box([-0.6, -0.02, 0.0], [-0.3, 0.02, 0.30]),
         "shelf": Box([-0.75, -0.12, 0.38], [-0.35, 0.12, 0.41])}
GOAL_BLOCKED = (r"^motion planning: the goal \[[-\d., ]+\] is not clear: the robot's \w+ comes [\d.]+ mm "
                r"into block \(clearance margin 5 mm\)$")
START_BLOCKED = (r"^motion planning: the start \[[-\d., ]+\] is not clear: the robot's \w+ comes [\d.]+ mm "
                 r"into the_table \(clearance margin 5 mm\)$")
NO_PATH = (r"^motion planning: no collision-free path from \[[-\d., ]+\] to \[[-\d., ]+\] found by OMPL "
           r"RRTConnect in 0.001 s: (blocked by \w+ \(\d+ of the \d+ motions checked ran into it; .*\)|no "
           r"configuration).* \(clearance margin 5 mm\)$")


@pytest.fixture(scope="module")
def robot():
    return robot_model("ur5e")


def ends(robot, world=WALL, z=0.08):
    """Tool down 5 cm over each of two buttons either side of the wall, each on a clear branch (the same
    one when it is clear at both: with the shelf it is not, and the path changes branch)."""
    def clear(y):
        out = []
        for branch in robot.branch_names:
            q = robot.ik([-0.45, y, z], DOWN, branch=branch)
            d = clearance(robot, q[None], world, table=TABLE).min_distance
            if d > 0.006:
                out.append((branch, d, q))
        return out

    pairs = [((ba == bb, min(da, db)), a, b) for ba, da, a in clear(-0.3) for bb, db, b in clear(0.3)]
    _, a, b = max(pairs, key=lambda item: item[0])  # the same branch, else the clearest
    # the same pose, each joint turned to be nearest a's within the limits
    lo, hi = robot.limits.T
    near = a + (b - a + np.pi) % (2 * np.pi) - np.pi
    return a, np.where((near < lo) | (near > hi), b, near)


@pytest.mark.parametrize("world", [WALL, SHELF], ids=["wall", "shelf"])
def test_the_path_keeps_every_body_clear_along_its_densified_segments(robot, world):
    a, b = ends(robot, world)
    if world is WALL:  # the straight joint move goes through the wall (under the shelf it is clear)
        assert clearance(robot, np.stack([a, b]), world, table=TABLE).min_distance < 0
    path = plan_motion(robot, a, b, obstacles=world, table=TABLE, random_state=0)
    np.testing.assert_array_equal(path.joints[0], a)
    np.testing.assert_array_equal(path.joints[-1], b)
    # the joint segments between waypoints, densified finely: every body, the world and itself
    fine = clearance(robot, path.joints, world, table=TABLE, max_move=0.002)
    assert fine.min_distance >= 0.005 - 0.001  # the margin, up to the fine check's own bound
    assert path.clearance.min_distance >= 0.005
    assert path.planner == "RRTConnect" and path.n_checked > 0 and path.length > 0


def test_the_same_random_state_gives_the_same_path(robot):
    a, b = ends(robot)
    one = plan_motion(robot, a, b, obstacles=WALL, table=TABLE, random_state=3)
    two = plan_motion(robot, a, b, obstacles=WALL, table=TABLE, random_state=3)
    np.testing.assert_array_equal(one.joints, two.joints)


def test_a_goal_inside_an_obstacle_is_one_line_naming_it(robot):
    a, b = ends(robot)
    block = {"block": Sphere(robot.fk(b)[0] + [0.0, 0.0, 0.1], 0.08)}  # round the wrist at the goal
    with pytest.raises(MotionPlanningError, match=GOAL_BLOCKED):
        plan_motion(robot, a, b, obstacles={**WALL, **block}, table=TABLE, random_state=0)


def test_a_start_in_collision_is_one_line_naming_it(robot):
    a, b = ends(robot)
    with pytest.raises(MotionPlanningError, match=START_BLOCKED):
        plan_motion(robot, robot.ik([-0.45, -0.3, -0.01], DOWN, q_seed=a), b, obstacles=WALL, table=TABLE,
                    label=lambda other: other.replace("table", "the_table"))


def test_no_path_in_time_is_one_line_naming_the_start_the_goal_and_what_blocked(robot):
    a, b = ends(robot)
    with pytest.raises(MotionPlanningError, match=NO_PATH):
        plan_motion(robot, a, b, obstacles=WALL, table=TABLE, time_limit=0.001, random_state=0)


def test_a_held_object_is_checked_like_a_body(robot):
    a, b = ends(robot)
    ball = Sphere([0.0, 0.0, 0.02], 0.02)  # 2 cm past the fingertips, along the tool axis
    capsule = _held_capsule(robot, ball)
    np.testing.assert_allclose(capsule.a, [0.0, 0.0, 0.163 + 0.02])  # in the flange frame
    assert capsule.radius == 0.02 and capsule.frame == robot.n_joints
    # a held object reaching the table at the start: refused, naming it
    with pytest.raises(MotionPlanningError, match=r"^motion planning: the start .* the robot's held comes "):
        plan_motion(robot, a, b, obstacles=WALL, table=TABLE, held=Sphere([0.0, 0.0, 0.06], 0.03))
    path = plan_motion(robot, a, b, obstacles=WALL, table=TABLE, held=ball, random_state=0)
    pose = robot.link_frames(path.joints)[:, -1]
    centre = np.einsum("nij,j->ni", pose[:, :3, :3], capsule.a) + pose[:, :3, 3]
    assert np.all(centre[:, 2] >= 0.02 + 0.005 - 1e-9)  # the ball stays above the table at the waypoints
    box = _held_capsule(robot, Box([-0.02, -0.03, 0.0], [0.02, 0.03, 0.1]))
    corners = np.array([[x, y, z] for x in (-0.02, 0.02) for y in (-0.03, 0.03) for z in (0.0, 0.1)])
    corners[:, 2] += 0.163
    seg_a, seg_b = np.asarray(box.a), np.asarray(box.b)
    s = np.clip((corners - seg_a) @ (seg_b - seg_a) / np.dot(seg_b - seg_a, seg_b - seg_a), 0, 1)
    gap = np.linalg.norm(seg_a + s[:, None] * (seg_b - seg_a) - corners, axis=1)
    assert np.all(gap <= box.radius + 1e-9)  # the capsule holds the box's corners


def test_bad_arguments_are_refused(robot):
    a, b = ends(robot)
    with pytest.raises(ValueError, match=r"^planner: expected one of \['rrtconnect'"):
        plan_motion(robot, a, b, planner="astar")
    with pytest.raises(ValueError, match=r"^q_goal: expected joints within the limits of robot ur5e, got "
                                         r"elbow_joint = 4 rad"):
        plan_motion(robot, a, [0.0, -1.0, 4.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"^held: expected a 3-D skillbank.core Sphere or Box"):
        plan_motion(robot, a, b, held="ball")
    with pytest.raises(ValueError, match=r"^random_state: expected an integer seed or None"):
        plan_motion(robot, a, b, table=TABLE, random_state=1.5)
    with pytest.raises(ValueError, match=r"^simplify: expected True or False, got 0.5$"):
        plan_motion(robot, a, b, simplify=0.5)


def test_without_ompl_one_line_names_the_extra(robot, monkeypatch):
    a, b = ends(robot)
    monkeypatch.setitem(sys.modules, "ompl", None)
    with pytest.raises(ImportError, match=r"^motion planning needs OMPL: pip install 'skillbank\[plan\]'$"):
        plan_motion(robot, a, b, obstacles=WALL, table=TABLE)


@pytest.mark.parametrize("planner", ["lbkpiece", "kpiece"])
def test_other_ompl_planners_find_the_way_over_the_wall(robot, planner):
    a, b = ends(robot)
    path = plan_motion(robot, a, b, obstacles=WALL, table=TABLE, planner=planner, random_state=0)
    assert path.clearance.min_distance >= 0.005


def test_any_of_several_starts_and_goals_will_do(robot):
    """The wrist turned the long way round must fold the gripper onto the forearm to reach the goal; the
    same pose a whole turn away need not (a wall with a post, the start over b1 as the chain found it)."""
    post = {"wall": Box([-0.6, -0.02, 0.0], [-0.3, 0.02, 0.32]), "post": Sphere([-0.2, 0.0, 0.45], 0.04)}
    a = np.array([0.339, -0.9035, 1.306, -5.115, -4.712, 1.91])
    b = np.array([2.803, -2.242, -1.311, -4.301, -1.571, 1.232])
    turned = a + [0.0, 0.0, 0.0, 0.0, 2 * np.pi, 0.0]  # the same pose
    np.testing.assert_allclose(robot.fk(turned)[0], robot.fk(a)[0], atol=1e-12)
    with pytest.raises(MotionPlanningError, match=r"no collision-free path from \[0.339, .*\] to \[2.803, "):
        plan_motion(robot, a, b, obstacles=post, table=TABLE, time_limit=1.0, random_state=0)
    path = plan_motion(robot, [a, turned], b, obstacles=post, table=TABLE, random_state=0)
    np.testing.assert_array_equal(path.joints[0], turned)  # it starts on one given, exactly
    np.testing.assert_array_equal(path.joints[-1], b)
    assert path.clearance.min_distance >= 0.005


#: Two joints in [-1, 1]: a disc of radius 0.5 about the origin is blocked.
SQUARE = np.array([[-1.0, 1.0], [-1.0, 1.0]])


def _free(q):
    return bool(np.linalg.norm(q) > 0.5)


def _free_motion(a, b):
    return all(_free(a + s * (b - a)) for s in np.linspace(0.0, 1.0, 101))


def test_the_one_ompl_set_up_goes_round_what_the_callers_checks_refuse():
    """``_ompl_path`` (plan_motion's and the simulation's transits' one OMPL set-up) knows nothing of robots:
    a disc in a two-joint space, checked by plain callables."""
    a, b = np.array([[-0.8, 0.0]]), np.array([[0.8, 0.0], [0.8, 0.9]])
    Q, planning, simplifying = _ompl_path(SQUARE, a, b, _free, _free_motion, failure=lambda: "unused",
                                          random_state=0)
    np.testing.assert_array_equal(Q[0], a[0])  # on ends given, exactly
    assert any(np.array_equal(Q[-1], g) for g in b)
    assert all(_free_motion(p, q) for p, q in zip(Q[:-1], Q[1:], strict=True))
    assert np.all(Q >= -1.0) and np.all(Q <= 1.0) and planning >= 0.0 and simplifying >= 0.0
    again, _, _ = _ompl_path(SQUARE, a, b, _free, _free_motion, failure=lambda: "unused", random_state=0)
    np.testing.assert_array_equal(again, Q)  # the same seed, the same path
    raw, _, _ = _ompl_path(SQUARE, a, b, _free, _free_motion, failure=lambda: "unused", simplify=False,
                           planner="KPIECE1", random_state=0)
    assert all(_free_motion(p, q) for p, q in zip(raw[:-1], raw[1:], strict=True))


def test_the_one_ompl_set_up_raises_the_callers_message_when_no_path_is_found():
    walled = []  # the goal is inside a ring: no motion reaches it

    def ring_motion(p, q):
        walled.append(1)
        return all(abs(np.linalg.norm(p + s * (q - p)) - 0.6) > 0.05 for s in np.linspace(0.0, 1.0, 101))

    with pytest.raises(MotionPlanningError, match=r"^no way in after \d+ motions checked$") as error:
        _ompl_path(SQUARE, np.array([[-0.9, -0.9]]), np.array([[0.0, 0.0]]), lambda q: True, ring_motion,
                   failure=lambda: f"no way in after {len(walled)} motions checked", time_limit=0.2,
                   random_state=0)
    # the message is asked for after the search: it can count every check that ran
    assert walled and str(error.value) == f"no way in after {len(walled)} motions checked"
