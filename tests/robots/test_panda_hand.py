"""The Franka hand on the Panda: its capsules contain robosuite's hand and fingers at every opening and arm
configuration, its TCP and closing axis are robosuite's, and the registered panda mounts and checks it.

robosuite 1.5.2's ``grippers/panda_gripper.xml`` (MIT) is mounted on its ``robots/panda/robot.xml`` as
robosuite mounts it (the gripper's world body inside the arm's ``right_hand``, no offset), here with
MuJoCo's own ``MjSpec.attach``; MuJoCo places every body. MuJoCo collides a mesh as its convex hull, and a
capsule contains a hull exactly when it contains the mesh's vertices.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from skillbank.core import Sphere
from skillbank.robots import GRIPPERS, PANDA_HAND, clearance, robot_model
from skillbank.robots._chain import self_collision_skip
from skillbank.robots._clearance import _point_segment, segment_distance

mujoco = pytest.importorskip("mujoco")  # the sim extra

_SPEC = importlib.util.find_spec("robosuite")  # only its asset files are read: importing it is slow
if _SPEC is None:
    pytest.skip("needs robosuite's model files (the sim extra)", allow_module_level=True)
ASSETS = Path(_SPEC.submodule_search_locations[0]) / "models" / "assets"
#: robosuite's gripper bodies (prefixed as robosuite prefixes them) -> our capsule that must contain them
PART = {"gripper0_right_gripper": "hand", "gripper0_leftfinger": "finger_left",
        "gripper0_finger_joint1_tip": "finger_left", "gripper0_rightfinger": "finger_right",
        "gripper0_finger_joint2_tip": "finger_right"}
CORNERS = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float)


@pytest.fixture(scope="module")
def mounted():
    """robosuite's Panda with its hand mounted in ``right_hand``, compiled by MuJoCo."""
    arm = mujoco.MjSpec.from_file(str(ASSETS / "robots" / "panda" / "robot.xml"))
    hand = mujoco.MjSpec.from_file(str(ASSETS / "grippers" / "panda_gripper.xml"))
    arm.body("right_hand").add_frame().attach_body(hand.body("right_gripper"), "gripper0_", "")
    model = arm.compile()
    return model, mujoco.MjData(model)


def place(model, data, q, opening):
    """The arm at joints ``q`` and each finger ``opening`` metres out (0 closed, 0.04 fully open)."""
    data.qpos[[model.joint(f"joint{i}").qposadr[0] for i in range(1, 8)]] = q
    data.qpos[model.joint("gripper0_finger_joint1").qposadr[0]] = opening
    data.qpos[model.joint("gripper0_finger_joint2").qposadr[0]] = -opening
    mujoco.mj_kinematics(model, data)


def gripper_points(model, data) -> dict:
    """Per capsule name, the world points whose hull is what MuJoCo collides: mesh vertices, box corners."""
    out = {}
    for g in range(model.ngeom):
        body = model.body(model.geom_bodyid[g]).name
        if body not in PART or not (model.geom_contype[g] or model.geom_conaffinity[g]):
            continue
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = model.geom_dataid[g]
            start = model.mesh_vertadr[mesh]
            local = model.mesh_vert[start:start + model.mesh_vertnum[mesh]]
        else:
            assert model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX, model.geom(g).name
            local = CORNERS * model.geom_size[g]
        out.setdefault(PART[body], []).append(local @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g])
    return {name: np.concatenate(p) for name, p in out.items()}


def flange_of(model, data) -> np.ndarray:
    T = np.eye(4)
    b = model.body("right_hand").id
    T[:3, :3], T[:3, 3] = data.xmat[b].reshape(3, 3), data.xpos[b]
    return T


def excess(points, capsule, frame) -> float:
    """Largest distance (m) of ``points`` outside ``capsule`` placed at ``frame``."""
    a = frame[:3, :3] @ np.asarray(capsule.a) + frame[:3, 3]
    b = frame[:3, :3] @ np.asarray(capsule.b) + frame[:3, 3]
    return float((_point_segment(a, b, points) - capsule.radius).max())


def test_the_capsules_contain_the_hand_and_the_fingers_over_the_stroke_at_random_configurations(mounted):
    model, data = mounted
    robot = robot_model("panda")
    capsules = {c.name: c for c in PANDA_HAND.capsules}
    rng = np.random.default_rng(5)
    qs = np.vstack([robot.home, rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (12, 7))])
    worst = dict.fromkeys(capsules, -np.inf)
    for q in qs:
        flange = robot.link_frames(q)[0, -1]
        for opening in np.linspace(0.0, 0.04, 9):
            place(model, data, q, opening)
            # robosuite's right_hand is the model's flange, at every configuration
            np.testing.assert_allclose(flange_of(model, data), flange, atol=1e-9)
            points = gripper_points(model, data)
            assert set(points) == set(capsules)
            for name, P in points.items():
                worst[name] = max(worst[name], excess(P, capsules[name], flange))
    assert max(worst.values()) <= 0.0, worst
    # tight: grown by the rounding only, each capsule touches its part to within 2 mm
    assert min(worst.values()) > -2e-3, worst


def test_the_fingers_slide_along_the_hands_axis_in_the_flange_frame(mounted):
    model, data = mounted
    place(model, data, robot_model("panda").home, 0.0)
    R = flange_of(model, data)[:3, :3]
    for joint, sign in (("gripper0_finger_joint1", 1.0), ("gripper0_finger_joint2", -1.0)):
        j = model.joint(joint).id
        axis = R.T @ data.xaxis[j]  # the joint's axis in the flange frame
        lo, hi = model.jnt_range[j]
        # finger 1 (robosuite's leftfinger) opens towards +axis, finger 2 towards -axis, 0.04 m each
        opening = sign * axis * (hi if sign > 0 else lo)
        np.testing.assert_allclose(opening / np.linalg.norm(opening), PANDA_HAND.axis, atol=1e-6)
        assert np.linalg.norm(opening) == pytest.approx(PANDA_HAND.stroke / 2)


def test_the_tcp_is_where_the_closed_fingertips_meet(mounted):
    model, data = mounted
    robot = robot_model("panda", gripper="none")
    place(model, data, robot.home, 0.0)
    inv = np.linalg.inv(flange_of(model, data))
    local = {name: P @ inv[:3, :3].T + inv[:3, 3] for name, P in gripper_points(model, data).items()}
    left, right = local["finger_left"], local["finger_right"]
    # the fingertips end 0.106 m along the flange's z, the fingers meet in its x-z plane, centred on z
    assert left[:, 2].max() == pytest.approx(PANDA_HAND.tcp[2], abs=1e-3)
    assert right[:, 2].max() == pytest.approx(PANDA_HAND.tcp[2], abs=1e-3)
    assert abs(left[:, 1].min()) < 1e-3 and abs(right[:, 1].max()) < 1e-3
    tips = np.vstack([P[P[:, 2] > P[:, 2].max() - 1e-3] for P in (left, right)])
    np.testing.assert_allclose(tips[:, :2].mean(axis=0), PANDA_HAND.tcp[:2], atol=1e-3)
    # robosuite's grip site, the registered tool point, is 9 mm above: between the pads
    site = inv[:3, :3] @ data.site_xpos[model.site("gripper0_grip_site").id] + inv[:3, 3]
    np.testing.assert_allclose(site, [0.0, 0.0, 0.097], atol=1e-9)
    np.testing.assert_allclose(robot_model("panda").tool[:3, 3], site, atol=1e-9)
    # fully open the fingers' inner faces are the stroke apart
    place(model, data, robot.home, 0.04)
    local = {name: P @ inv[:3, :3].T + inv[:3, 3] for name, P in gripper_points(model, data).items()}
    gap = local["finger_left"][:, 1].min() - local["finger_right"][:, 1].max()
    assert gap == pytest.approx(PANDA_HAND.stroke, abs=2e-3)


def test_the_registered_panda_mounts_the_hand():
    robot = robot_model("panda")
    assert robot.gripper_ is PANDA_HAND and GRIPPERS["panda_hand"] is PANDA_HAND
    names = [c.name for c in robot.bodies]
    assert names[-3:] == ["hand", "finger_left", "finger_right"]
    assert all(c.frame == robot.n_joints for c in robot.bodies[-3:])
    assert PANDA_HAND.fingers == ("finger_left", "finger_right") and "robosuite 1.5.2" in PANDA_HAND.source
    # the default tool stays robosuite's grip site (what its recordings report); the TCP on request
    np.testing.assert_allclose(robot.tool[:3, 3], [0.0, 0.0, 0.097], atol=1e-12)
    np.testing.assert_allclose(robot_model("panda", tool="tcp").tool, PANDA_HAND.tool(), atol=1e-12)
    bare = robot_model("panda", gripper="none")
    assert bare.gripper_ is None and [c.name for c in bare.bodies] == names[:-3]
    np.testing.assert_allclose(bare.tool[:3, 3], [0.0, 0.0, 0.097], atol=1e-12)
    # a description read from a file mounts none unless told
    file = robot_model(bare.chain.source, tool_frame="right_hand")
    assert file.gripper_ is None
    given = robot_model(bare.chain.source, tool_frame="right_hand", gripper="panda_hand")
    assert given.gripper_ is PANDA_HAND


def test_self_collision_keeps_the_rule_with_the_hand_and_home_is_clear():
    robot = robot_model("panda")
    # the rule: every pair more than one frame apart, except those overlapping at every sampled configuration
    assert robot.SELF_COLLISION_SKIP == self_collision_skip(robot.bodies, robot._frames, robot.limits)
    pairs = {frozenset(p) for p in robot.self_collision_pairs()}
    hand = {"hand", "finger_left", "finger_right"}
    assert frozenset(("link5", "hand")) in pairs and frozenset(("link4", "finger_left")) in pairs
    assert not any(p & hand for p in pairs if frozenset(p) & {"link6", "link6_2", "link7"})  # joined
    home = clearance(robot, np.array([robot.home]))
    assert home.min_distance > 0 and home.first_contact() is None
    assert min(v for k, v in home.per_pair.items() if set(k) & hand) > 0.03


def test_every_hand_to_arm_contact_of_robosuites_meshes_is_a_capsule_overlap(mounted):
    """Conservative: at random configurations and openings, wherever MuJoCo finds robosuite's hand meshes
    touching the arm's, the capsules overlap too."""
    model, data = mounted
    robot = robot_model("panda")
    rng = np.random.default_rng(6)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (400, 7))
    mesh = np.zeros(len(q), bool)
    for k in range(len(q)):
        place(model, data, q[k], rng.uniform(0.0, 0.04))
        mujoco.mj_collision(model, data)
        for c in data.contact[:data.ncon]:
            a, b = (model.body(model.geom_bodyid[g]).name for g in (c.geom1, c.geom2))
            mesh[k] |= (a in PART) != (b in PART)
    F = robot.link_frames(q)
    capsule = {c.name: c for c in robot.bodies}
    ours = np.zeros(len(q), bool)
    for a, b in robot.self_collision_pairs():
        if (a in PANDA_HAND.fingers or a == "hand") != (b in PANDA_HAND.fingers or b == "hand"):
            ca, cb = capsule[a], capsule[b]
            ends = [F[:, c.frame, :3, :3] @ np.asarray(x) + F[:, c.frame, :3, 3]
                    for c in (ca, cb) for x in (c.a, c.b)]
            ours |= segment_distance(*ends) < ca.radius + cb.radius
    assert mesh.any() and not (mesh & ~ours).any()


def test_the_clearance_counts_the_hand():
    """A ball 20 mm beside the hand's capsule, off the flange's x: the hand is what comes nearest."""
    robot = robot_model("panda")
    q = np.array([robot.home])
    flange = robot.link_frames(q)[0, -1]
    cap = PANDA_HAND.capsules[0]
    middle = flange[:3, :3] @ ((np.asarray(cap.a) + np.asarray(cap.b)) / 2) + flange[:3, 3]
    ball = Sphere(middle + flange[:3, 0] * (cap.radius + 0.02 + 0.01), 0.01)
    result = clearance(robot, q, {"ball": ball}, self_collision=False)
    assert result.per_pair[("hand", "ball")] == pytest.approx(0.02, abs=1e-9)
    assert result.body == "hand" and result.min_distance == pytest.approx(0.02, abs=1e-9)
    without = clearance(robot_model("panda", gripper="none"), q, {"ball": ball}, self_collision=False)
    assert without.min_distance > 0.03 and "hand" not in {k[0] for k in without.per_pair}
