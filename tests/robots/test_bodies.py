"""The UR5e's and the 2F-85's capsules contain robosuite's collision meshes at every configuration.

The meshes are robosuite 1.5.2's (MIT), read from the installed package as binary STL with numpy; MuJoCo
(also installed by the ``sim`` extra) places robosuite's bodies at the same joint angles. MuJoCo collides
a mesh as its convex hull, and a capsule contains a hull exactly when it contains the mesh's vertices,
so checking the vertices proves the envelope covers what the simulator collides.
"""

from __future__ import annotations

import importlib.util
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from skillbank.io import read_robot_h5
from skillbank.robots import GRIPPERS, ROBOTIQ_2F85, UR5e, clearance, robot_model
from skillbank.robots._clearance import _point_segment, segment_distance

mujoco = pytest.importorskip("mujoco")  # the sim extra: MuJoCo places robosuite's bodies

_SPEC = importlib.util.find_spec("robosuite")  # only its asset files are read: importing it is slow
if _SPEC is None:
    pytest.skip("needs robosuite's model files (the sim extra)", allow_module_level=True)
ASSETS = Path(_SPEC.submodule_search_locations[0]) / "models" / "assets"
#: robosuite's world is ROS's base_link: UR's base turned by pi about z.
TURN = np.diag([-1.0, -1.0, 1.0])
#: robosuite's collision mesh of each arm body, and our capsule that must contain it.
ARM = {"fixed_base_link": "base", "shoulder_link": "shoulder", "upper_arm_link": "upper_arm",
       "forearm_link": "forearm", "wrist_1_link": "wrist_1", "wrist_2_link": "wrist_2",
       "wrist_3_link": "wrist_3"}


def read_stl(path: Path) -> np.ndarray:
    """The distinct vertices ``(m, 3)`` of a binary STL file."""
    raw = path.read_bytes()
    n = int(np.frombuffer(raw, "<u4", 1, 80)[0])
    assert len(raw) == 84 + 50 * n, f"{path}: not a binary STL"
    record = np.dtype([("normal", "<f4", 3), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])
    return np.unique(np.frombuffer(raw, record, n, 84)["vertices"].reshape(-1, 3).astype(float), axis=0)


def collision_meshes(root: ET.Element, folder: Path) -> dict:
    """Per body name, its collision meshes' vertices in the body's frame (geom pos, mesh scale)."""
    meshes = {m.get("name"): m for m in root.iter("mesh")}  # the first of a repeated name, as below
    out = {}
    for body in root.iter("body"):
        for geom in body.findall("geom"):
            if geom.get("type") != "mesh" or geom.get("contype") == "0":
                continue
            mesh = meshes[geom.get("mesh")]
            scale = np.array([float(x) for x in mesh.get("scale", "1 1 1").split()])
            pos = np.array([float(x) for x in geom.get("pos", "0 0 0").split()])
            assert geom.get("quat") is None
            out.setdefault(body.get("name"), []).append(read_stl(folder / mesh.get("file")) * scale + pos)
    return {name: np.concatenate(v) for name, v in out.items()}


def body_pose(model, data, name):
    b = model.body(name).id
    return data.xmat[b].reshape(3, 3), data.xpos[b]


def excess(points: np.ndarray, capsule, frame: np.ndarray) -> float:
    """Largest distance (m) of ``points`` (world) outside ``capsule`` placed at ``frame``."""
    a = frame[:3, :3] @ np.asarray(capsule.a) + frame[:3, 3]
    b = frame[:3, :3] @ np.asarray(capsule.b) + frame[:3, 3]
    return float((_point_segment(a, b, points) - capsule.radius).max())


@pytest.fixture(scope="module")
def arm():
    path = ASSETS / "robots" / "ur5e" / "robot.xml"
    model = mujoco.MjModel.from_xml_path(str(path))
    return model, mujoco.MjData(model), collision_meshes(ET.parse(path).getroot(), path.parent)


@pytest.fixture(scope="module")
def gripper():
    """robosuite's 2F-85 on its own; its file names one mesh twice, which MuJoCo refuses: keep the first."""
    path = ASSETS / "grippers" / "robotiq_gripper_85.xml"
    root = ET.parse(path).getroot()
    asset, seen = root.find("asset"), set()
    for mesh in list(asset):
        if mesh.get("name") in seen:
            asset.remove(mesh)
        seen.add(mesh.get("name"))
    ET.SubElement(root, "compiler").set("meshdir", str(path.parent))
    model = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    return model, mujoco.MjData(model), collision_meshes(root, path.parent)


def set_opening(model, data, angle):
    """The 2F-85's linkage at knuckle angle ``angle`` (0 open, 0.8 closed): the inner finger kept parallel."""
    for side, knuckle in (("left", "finger_joint"), ("right", "right_outer_knuckle_joint")):
        for joint, sign in ((knuckle, 1.0), (f"{side}_inner_knuckle_joint", 1.0),
                            (f"{side}_inner_finger_joint", -1.0)):
            data.qpos[model.jnt_qposadr[model.joint(joint).id]] = sign * angle
    mujoco.mj_kinematics(model, data)


def test_robosuite_bodies_are_our_dh_frames_up_to_fixed_rotations(arm):
    """Same joint angles, same links: each body's pose in our frame is constant (to robosuite's 1.5 mm)."""
    model, data, _ = arm
    robot = UR5e(gripper="none")
    rng = np.random.default_rng(0)
    index = dict(zip(ARM, range(7), strict=True)) | {"right_hand": 6}
    seen = {}
    for q in rng.uniform(-np.pi, np.pi, (10, 6)):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        F = robot.link_frames(q)[0]
        for name, i in index.items():
            R, p = body_pose(model, data, name)
            local_R = F[i, :3, :3].T @ TURN @ R
            local_p = F[i, :3, :3].T @ (TURN @ p - F[i, :3, 3])
            seen.setdefault(name, []).append((local_R, local_p))
    for name, poses in seen.items():
        R = np.array([r for r, _ in poses])
        p = np.array([t for _, t in poses])
        np.testing.assert_allclose(R, np.broadcast_to(np.round(R[0]), R.shape), atol=1e-2, err_msg=name)
        assert np.ptp(p, axis=0).max() < 3e-3, name
    # robosuite's right_hand, where the gripper is mounted, is the flange: same axes, within 2 mm
    R, p = seen["right_hand"][0]
    np.testing.assert_allclose(R, np.eye(3), atol=1e-2)
    assert np.linalg.norm(p) < 2e-3


def test_arm_capsules_contain_every_collision_mesh_vertex(arm):
    model, data, meshes = arm
    robot = UR5e(gripper="none")
    capsules = {c.name: c for c in robot.bodies}
    assert set(capsules) == set(ARM.values()) and len(robot.bodies) == 7
    rng = np.random.default_rng(1)
    worst = dict.fromkeys(ARM.values(), -np.inf)
    for q in np.vstack([np.zeros(6), robot.home, rng.uniform(-np.pi, np.pi, (20, 6))]):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        F = robot.link_frames(q)[0]
        for body, name in ARM.items():
            R, p = body_pose(model, data, body)
            world = (meshes[body] @ R.T + p) @ TURN.T
            worst[name] = max(worst[name], excess(world, capsules[name], F[capsules[name].frame]))
    assert max(worst.values()) <= 0.0, worst
    # and the envelopes are tight: each capsule touches its mesh to within 2.5 mm somewhere
    assert min(worst.values()) > -2.5e-3, worst


def test_gripper_capsules_contain_the_2f85_over_its_whole_stroke(gripper):
    model, data, meshes = gripper
    capsules = {c.name: c for c in ROBOTIQ_2F85.capsules}
    part = {"robotiq_85_adapter_link": "gripper_body"}
    for side in ("left", "right"):
        for body in ("outer_knuckle", "inner_finger", "inner_knuckle"):
            part[f"{side}_{body}"] = f"finger_{side}"
    corners = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float)
    worst = dict.fromkeys(capsules, -np.inf)
    for angle in np.linspace(0.0, 0.8, 33):
        set_opening(model, data, angle)
        for body, name in part.items():  # the gripper's base frame is the flange (robosuite's right_hand)
            R, p = body_pose(model, data, body)
            worst[name] = max(worst[name], excess(meshes[body] @ R.T + p, capsules[name], np.eye(4)))
        for g in range(model.ngeom):  # the fingertip and pad boxes
            if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX and model.geom_contype[g]:
                side = model.geom(g).name.split("_")[0]
                R = data.geom_xmat[g].reshape(3, 3)
                points = (corners * model.geom_size[g]) @ R.T + data.geom_xpos[g]
                worst[f"finger_{side}"] = max(worst[f"finger_{side}"],
                                              excess(points, capsules[f"finger_{side}"], np.eye(4)))
    assert max(worst.values()) <= 0.0 and min(worst.values()) > -2e-3, worst


def test_tcp_is_where_the_closed_fingertips_end(gripper):
    model, data, _ = gripper
    set_opening(model, data, 0.8)  # closed: the pads meet
    tips = [model.geom(f"{side}_fingertip_collision").id for side in ("left", "right")]
    corners = np.array([[i, j, 1.0] for i in (-1, 1) for j in (-1, 1)])
    ends = np.vstack([(corners * model.geom_size[g]) @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
                      for g in tips])
    np.testing.assert_allclose(ends[:, 2], ROBOTIQ_2F85.tcp[2], atol=1e-3)
    np.testing.assert_allclose(ends[:, :2].mean(axis=0), ROBOTIQ_2F85.tcp[:2], atol=1e-6)
    gap = np.abs(data.geom_xpos[tips[0], 1] - data.geom_xpos[tips[1], 1])
    assert gap < 0.01
    # robosuite's eef site is the pads' middle: half a fingertip (18.75 mm) above the TCP
    eef = data.xpos[model.body("eef").id]
    assert eef[2] == pytest.approx(ROBOTIQ_2F85.tcp[2] - 0.01875, abs=1e-3)
    set_opening(model, data, 0.0)  # open: the pads 85 mm apart, the stroke
    pads = [data.geom_xpos[model.geom(f"{side}_fingerpad_collision").id] for side in ("left", "right")]
    assert abs(pads[1][1] - pads[0][1]) - 2 * 0.001 == pytest.approx(ROBOTIQ_2F85.stroke, abs=2e-3)


def test_tool_names_give_the_gripper_tcp_which_is_the_default():
    tcp = ROBOTIQ_2F85.tool()
    assert np.array_equal(UR5e().tool, tcp)  # positions are where the fingertips meet
    assert np.array_equal(UR5e(gripper="none").tool, np.eye(4))  # no gripper: the flange
    assert np.array_equal(UR5e().gripper_.tool(), tcp)
    for tool in ("robotiq_2f85", "tcp", None):
        model = robot_model("ur5e", tool=tool)
        assert np.array_equal(model.tool, tcp)
        flange, _ = UR5e(tool="flange").fk(UR5e.home)
        position, _ = model.fk(UR5e.home)
        # at home the tool points down: the TCP is 0.163 m below the flange
        np.testing.assert_allclose(position, flange - [0.0, 0.0, 0.163], atol=1e-9)
    assert np.array_equal(robot_model("ur5e", tool="flange").tool, np.eye(4))
    assert GRIPPERS["robotiq_2f85"] is ROBOTIQ_2F85 and UR5e(gripper="none").bodies == UR5e.BODIES


@pytest.mark.parametrize(("params", "match"), [
    ({"tool": "tcp", "gripper": "none"}, r"tool: 'tcp' is the mounted gripper's tool centre point, but no "
                                         r"gripper is mounted"),
    ({"tool": "hand"}, r"tool: expected a 4 x 4 transform, 'flange', 'tcp' or a gripper's name among "
                       r"\['robotiq_2f85', 'panda_hand'\], got 'hand'"),
    ({"gripper": "2f85"}, r"gripper: expected 'default', 'none' or one of \['robotiq_2f85', 'panda_hand'\], "
                          r"got '2f85'"),
])
def test_bad_tool_or_gripper(params, match):
    with pytest.raises(ValueError, match=match):
        UR5e(**params)


def test_self_collision_pairs_skip_joined_and_listed_pairs():
    robot = UR5e()
    pairs = robot.self_collision_pairs()
    frames = {c.name: c.frame for c in robot.bodies}
    assert all(abs(frames[a] - frames[b]) > 1 for a, b in pairs)
    assert not {frozenset(p) for p in pairs} & {frozenset(p) for p in UR5e.SELF_COLLISION_SKIP}
    assert ("forearm", "wrist_3") in pairs and ("upper_arm", "finger_left") in pairs
    assert ("wrist_3", "gripper_body") not in pairs and ("wrist_2", "finger_left") not in pairs  # joined
    assert len(pairs) == 24
    # the listed pairs: envelopes within a few cm of each other everywhere, or never near (the class's notes)
    rng = np.random.default_rng(2)
    F = robot.link_frames(rng.uniform(-np.pi, np.pi, (20000, 6)))
    capsule = {c.name: c for c in robot.bodies}

    def between(a, b):
        ca, cb = capsule[a], capsule[b]
        ends = [F[:, c.frame, :3, :3] @ np.asarray(x) + F[:, c.frame, :3, 3]
                for c in (ca, cb) for x in (c.a, c.b)]
        return segment_distance(*ends) - ca.radius - cb.radius

    for a, b, most in (("base", "upper_arm", 0.011), ("forearm", "wrist_2", 0.032),
                       ("wrist_1", "wrist_3", 0.010)):
        assert between(a, b).max() < most + 1e-3, (a, b)
    for b, least in (("gripper_body", 0.032), ("finger_left", 0.056), ("finger_right", 0.056)):
        assert between("wrist_1", b).min() > least - 2e-3, b


def test_the_recorded_three_button_demonstration_does_not_collide_with_itself(data_dir):
    """The real arm did not hit itself; its envelopes, with the gripper, do not either."""
    demo = read_robot_h5(data_dir / "seed" / "three_button_pressing_demo.h5")
    result = clearance(UR5e(), demo["joints"], t=demo.t)
    assert result.min_distance > 0.0
    assert result.first_contact() is None
