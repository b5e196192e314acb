"""Robots from URDF and MJCF: the chain, FK against MuJoCo and the analytic UR5e, numerical IK, bad files."""

from __future__ import annotations

import os

import numpy as np
import pytest

from skillbank.core._rotations import quaternion_to_matrix
from skillbank.robots import (
    DESCRIPTIONS,
    UR5E_DH,
    ChainModel,
    KinematicsError,
    UR5e,
    clearance,
    enclosing_capsule,
    load_description,
    robot_model,
)

mujoco = pytest.importorskip("mujoco")  # the extra skillbank[sim]; CI installs it with [test]


def _dh_origin(i: int) -> tuple[str, str]:
    """``xyz`` and ``rpy`` of ``Tz(d_i) Tx(a_i) Rx(alpha_i)``: the UR5e's fixed transform after joint i."""
    d, a, alpha = UR5E_DH["d"][i], UR5E_DH["a"][i], UR5E_DH["alpha"][i]
    return f"{a!r} 0 {d!r}", f"{alpha!r} 0 0"


def ur5e_urdf(folder, *, extra="") -> str:
    """A UR5e from the manufacturer's DH table: link i+1 at the DH transform of joint i, tool0 last."""
    links = ["base", "shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3", "tool0"]
    lines = ['<robot name="ur5e_dh">'] + [f'  <link name="{name}"/>' for name in links]
    for i, joint in enumerate(UR5e.joint_names):
        xyz, rpy = ("0 0 0", "0 0 0") if i == 0 else _dh_origin(i - 1)
        lines.append(f'  <joint name="{joint}" type="revolute"><parent link="{links[i]}"/>'
                     f'<child link="{links[i + 1]}"/><origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="0 0 1"/>'
                     f'<limit lower="{UR5e.lower[i]!r}" upper="{UR5e.upper[i]!r}" effort="150" '
                     'velocity="3.14"/></joint>')
    xyz, rpy = _dh_origin(5)
    lines.append(f'  <joint name="flange" type="fixed"><parent link="wrist_3"/><child link="tool0"/>'
                 f'<origin xyz="{xyz}" rpy="{rpy}"/></joint>')
    lines += [extra, "</robot>"]
    path = folder / "ur5e.urdf"
    path.write_text("\n".join(lines))
    return path


def random_joints(model, n, seed=0):
    rng = np.random.default_rng(seed)
    lo, hi = np.clip(model.limits[:, 0], -np.pi, None), np.clip(model.limits[:, 1], None, np.pi)
    return rng.uniform(lo, hi, size=(n, model.n_joints))


# ---------------------------------------------------------------------------------------------- FK


def test_the_ur5e_read_from_its_dh_urdf_is_the_analytic_model(tmp_path):
    described = robot_model(ur5e_urdf(tmp_path))
    analytic = UR5e(tool="flange", gripper="none")
    assert described.joint_names == analytic.joint_names and described.chain.tool_frame == "tool0"
    q = random_joints(analytic, 500)
    for (p, qt), (p0, q0) in [(described.fk(q), analytic.fk(q))]:
        assert np.abs(p - p0).max() < 1e-9
        assert np.abs(quaternion_to_matrix(qt) - quaternion_to_matrix(q0)).max() < 1e-9
    # the frames are the DH frames too: joint i turns about frame i-1's z axis (docs/robots.md)
    np.testing.assert_allclose(described.link_frames(q)[:, 1:], analytic.link_frames(q)[:, 1:], atol=1e-9)
    np.testing.assert_allclose(described.limits, analytic.limits, atol=1e-6)


@pytest.mark.parametrize("name", sorted(DESCRIPTIONS))
def test_fk_of_every_registered_description_is_mujocos_own(name):
    model = robot_model(name, tool="flange")  # the tool frame's body itself
    m = mujoco.MjModel.from_xml_path(model.chain.source)
    d = mujoco.MjData(m)
    body = m.body(model.chain.tool_frame).id
    q = random_joints(model, 200, seed=1)
    position, quaternion = model.fk(q)
    R = quaternion_to_matrix(quaternion)
    adr = [m.jnt_qposadr[m.joint(j).id] for j in model.joint_names]
    for k in range(q.shape[0]):
        d.qpos[adr] = q[k]
        mujoco.mj_kinematics(m, d)
        assert np.abs(d.xpos[body] - position[k]).max() < 1e-9
        assert np.abs(d.xmat[body].reshape(3, 3) - R[k]).max() < 1e-9


def test_a_site_can_be_the_tool_frame_and_fk_is_vectorised(tmp_path):
    path = ur5e_urdf(tmp_path)
    model = robot_model(path, tool_frame="wrist_3")
    q = random_joints(model, 7)
    single = np.array([model.fk(row)[0] for row in q])
    np.testing.assert_allclose(model.fk(q)[0], single, atol=1e-15)
    flange = robot_model(path).fk(q)[0]
    assert np.abs(np.linalg.norm(flange - model.fk(q)[0], axis=1) - UR5E_DH["d"][5]).max() < 1e-9


# ------------------------------------------------------------------------------------ collision bodies


def test_the_capsules_contain_every_collision_vertex_at_random_configurations():
    model = robot_model("panda")
    m = mujoco.MjModel.from_xml_path(model.chain.source)
    d = mujoco.MjData(m)
    q = random_joints(model, 20, seed=2)
    adr = [m.jnt_qposadr[m.joint(j).id] for j in model.joint_names]
    frames = model.link_frames(q)
    worst = -np.inf
    for k in range(q.shape[0]):
        d.qpos[adr] = q[k]
        mujoco.mj_kinematics(m, d)
        for g in range(m.ngeom):
            collides = m.geom_contype[g] or m.geom_conaffinity[g]
            if not collides or m.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH:
                continue
            body = m.body(m.geom_bodyid[g]).name
            mesh = m.geom_dataid[g]
            local = m.mesh_vert[m.mesh_vertadr[mesh]:m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
            world = local @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g]
            caps = [c for c in model.bodies if c.name == body or c.name.startswith(body + "_")]
            assert caps, body
            inside = np.full(world.shape[0], -np.inf)
            for c in caps:
                T = frames[k, c.frame]
                a, b = T[:3, :3] @ c.a + T[:3, 3], T[:3, :3] @ c.b + T[:3, 3]
                ab = b - a
                s = np.clip((world - a) @ ab / max(ab @ ab, 1e-300), 0, 1)
                dist = np.linalg.norm(world - (a + s[:, None] * ab), axis=1)
                inside = np.maximum(inside, c.radius - dist)
            worst = max(worst, -inside.min())
    assert worst <= 1e-9  # every vertex inside one of its link's capsules


def test_enclosing_capsule_contains_its_balls_and_is_tight_on_a_segment():
    rng = np.random.default_rng(3)
    P = rng.normal(size=(300, 3)) * [0.3, 0.05, 0.02]
    radii = rng.uniform(0, 0.01, 300)
    a, b, r = enclosing_capsule(P, radii)
    ab = np.subtract(b, a)
    s = np.clip((P - a) @ ab / (ab @ ab), 0, 1)
    assert (np.linalg.norm(P - (a + s[:, None] * ab), axis=1) + radii <= r + 1e-12).all()
    a, b, r = enclosing_capsule([[0, 0, 0], [1, 0, 0]], [0.1, 0.1])
    assert r == pytest.approx(0.1, abs=1e-5)
    assert np.linalg.norm(np.subtract(b, a)) == pytest.approx(1.0, abs=1e-4)


def test_the_panda_at_home_is_clear_of_itself():
    model = robot_model("panda")
    assert clearance(model, np.array([model.home])).min_distance > 0


# ---------------------------------------------------------------------------------------------- IK


def _smooth_path(model, n, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, n)[:, None]
    q0 = np.asarray(model.home)
    return q0 + 0.3 * np.sin(2 * np.pi * t * rng.uniform(0.5, 1.5, model.n_joints)) \
        * rng.uniform(0.3, 1.0, model.n_joints)


def test_ik_follows_a_pose_path_continuously_on_the_panda():
    model = robot_model("panda")
    q = _smooth_path(model, 2000)
    position, quaternion = model.fk(q)
    solved = model.ik(position, quaternion, q_seed=q[0])
    p, qt = model.fk(solved)
    assert np.linalg.norm(p - position, axis=1).max() < 2e-6
    assert np.abs(np.diff(solved, axis=0)).max() < 0.05  # continuous: no sample leaves its neighbours
    assert ((solved >= model.limits[:, 0]) & (solved <= model.limits[:, 1])).all()
    # with the recorded joints as the reference, the redundancy follows them
    followed = model.ik(position, quaternion, q_seed=q[0], q_reference=q)
    assert np.abs(followed - q).max() < 0.01


def test_the_vectorised_path_agrees_with_a_loop_of_the_same_solver():
    model = robot_model("panda")
    q = _smooth_path(model, 300, seed=4)
    position, quaternion = model.fk(q)
    whole = model.ik(position, quaternion, q_seed=q[0])
    loop = model.ik_loop(position, quaternion, q_seed=q[0])
    assert np.abs(whole - loop).max() < 0.05
    assert np.linalg.norm(model.fk(loop)[0] - position, axis=1).max() < 2e-6


def test_ik_of_the_dh_urdf_recovers_the_joints_the_analytic_model_gives(tmp_path):
    described = robot_model(ur5e_urdf(tmp_path))
    analytic = UR5e(tool="flange", gripper="none")
    q = np.array(analytic.home) + np.linspace(0, 0.4, 200)[:, None] * [1, -0.5, 0.6, 0.3, 0.5, 1]
    position, quaternion = analytic.fk(q)
    np.testing.assert_allclose(described.ik(position, quaternion, q_seed=q[0]), q, atol=1e-5)


def test_ik_errors_name_the_sample_and_the_reason(tmp_path):
    model = robot_model("panda")
    p, qt = model.fk(model.home)
    far = np.array([p, p + [0, 0, 0.01], p + [2.0, 0, 0]])
    with pytest.raises(KinematicsError, match=r"sample 2 is out of the arm's reach by about 1\.\d+ m") as e:
        model.ik(far, np.tile(qt, (3, 1)))
    assert e.value.index == 2 and e.value.reason == "unreachable"
    jump = np.array([p, p + [0.0, 0.3, -0.2]])
    with pytest.raises(KinematicsError, match=r"sample 1: joint '\w+' would move by .* rad in one") as e:
        model.ik(jump, np.tile(qt, (2, 1)))
    assert e.value.reason == "jump"
    # the elbow (joint4) at its upper limit, -0.0698: a pose the stretched arm cannot reach
    stretched = np.array(model.home)
    stretched[3] = -0.0698
    ps, qs = model.fk(stretched)
    with pytest.raises(KinematicsError, match=r"joint 'joint4' is held at its limit|out of the arm's reach"):
        model.ik(ps + [0.0, 0.0, 0.05], qs, q_seed=stretched)
    with pytest.raises(ValueError, match=r"q_reference: expected one row per pose \(1\), got 2"):
        model.ik(p, qt, q_reference=[model.home, model.home])
    with pytest.raises(ValueError, match="branch: expected one of \\['seeded'\\]"):
        model.ik(p, qt, branch="elbow-up")


# ---------------------------------------------------------------------------------------------- bad files


def test_a_description_may_not_name_a_file_outside_its_folder(tmp_path):
    inner = tmp_path / "robot"
    inner.mkdir()
    (tmp_path / "secret.stl").write_bytes(b"solid x\nendsolid x\n")
    mesh = '<link name="extra"><collision><geometry><mesh filename="{}"/></geometry></collision></link>'
    for name in ("../secret.stl", "package://../../secret.stl", str(tmp_path / "secret.stl")):
        path = ur5e_urdf(inner, extra=mesh.format(name))
        with pytest.raises(ValueError, match=r"mesh .* lies outside the description's folder"):
            robot_model(path)
    mjcf = inner / "arm.xml"
    for body in ('<include file="../other.xml"/>', '<asset><mesh name="m" file="../secret.stl"/></asset>',
                 '<compiler meshdir="/etc"/>'):
        mjcf.write_text(f"<mujoco>{body}<worldbody/></mujoco>")
        with pytest.raises(ValueError, match="lies outside the description's folder"):
            robot_model(mjcf)
    link = inner / "meshes"
    os.symlink(tmp_path, link)  # a link out of the folder is outside too
    mjcf.write_text('<mujoco><asset><mesh name="m" file="meshes/secret.stl"/></asset><worldbody/></mujoco>')
    with pytest.raises(ValueError, match="lies outside the description's folder"):
        robot_model(mjcf)


def test_bad_descriptions_get_one_clear_error(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot><link name='a'>")
    with pytest.raises(ValueError, match="not well-formed XML"):
        robot_model(bad)
    bad.write_text("<scene/>")
    with pytest.raises(ValueError, match=r"expected a URDF \(<robot>\) or MJCF \(<mujoco>\) document, got"):
        robot_model(bad)
    bad.write_text('<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="revolute">'
                   '<parent link="a"/><child link="c"/></joint></robot>')
    with pytest.raises(ValueError, match="MuJoCo cannot read this URDF"):
        robot_model(bad)
    bad.write_text('<robot name="r"><link name="a"/><link name="b"/><joint name="slide" type="prismatic">'
                   '<parent link="a"/><child link="b"/><axis xyz="1 0 0"/>'
                   '<limit lower="0" upper="1" effort="1" velocity="1"/></joint></robot>')
    with pytest.raises(ValueError, match="joint 'slide' is a slide joint; skillbank's robot models chain "
                                         "revolute joints only"):
        robot_model(bad)
    fingers = '<mujoco><worldbody><body name="hand"><joint name="j" axis="0 0 1"/><geom size="0.1"/>' \
              '<body name="left"><joint name="l" axis="0 1 0"/><geom size="0.01"/></body>' \
              '<body name="right"><joint name="r" axis="0 1 0"/><geom size="0.01"/></body></body>' \
              '</worldbody></mujoco>'
    two = tmp_path / "two.xml"
    two.write_text(fingers)
    with pytest.raises(ValueError, match=r"ends in several links with 2 joints before them \('left', 'right'"
                                         r"\); name the tool frame \(--tool-frame LINK"):
        robot_model(two)
    assert robot_model(two, tool_frame="hand").joint_names == ("j",)
    with pytest.raises(ValueError, match="tool frame: .* has no link, body or site 'palm'; its links are ha"):
        robot_model(two, tool_frame="palm")
    with pytest.raises(ValueError, match="is neither a registered robot nor a description file"):
        robot_model(tmp_path / "missing.urdf")
    with pytest.raises(ValueError, match=r"robot: expected one of \['ur5e', 'panda'\] or a URDF / MJCF file"):
        robot_model("kuka")
    with pytest.raises(ValueError, match="tool frame: ur5e is a built-in model whose flange is fixed"):
        robot_model("ur5e", tool_frame="tool0")
    with pytest.raises(ValueError, match="chain: expected a KinematicChain"):
        ChainModel("panda")


def test_load_description_is_cached_and_reread_when_the_file_changes(tmp_path):
    path = ur5e_urdf(tmp_path)
    assert load_description(path) is load_description(path)
    os.utime(path, (1, 1))
    assert load_description(path).joint_names == UR5e.joint_names
