"""The MuJoCo world matches the robot model: link frames, TCP, capsules, masses; the button spring."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from skillbank.robots import robot_model
from skillbank.simulation import LINK_MASSES, PRESS_FORCE, build_world
from skillbank.simulation._world import GRIPPER_MASSES

from .conftest import TABLE, button, scene


def _compiled(world):
    M = mujoco.MjModel.from_xml_string(world.xml)
    return M, mujoco.MjData(M)


def test_simulated_link_frames_are_the_models(ur5e):
    world = build_world(scene(), ur5e)
    M, d = _compiled(world)
    rng = np.random.default_rng(7)
    q = rng.uniform(-np.pi, np.pi, (20, 6))
    expected = ur5e.link_frames(q)
    tcp = expected[:, -1] @ ur5e.gripper_.tool()
    for k in range(len(q)):
        d.qpos[[M.jnt_qposadr[M.joint(j).id] for j in world.joints]] = q[k]
        mujoco.mj_kinematics(M, d)
        for i, site in enumerate(world.frames):
            s = M.site(site).id
            np.testing.assert_allclose(d.site_xpos[s], expected[k, i, :3, 3], atol=1e-9)
            np.testing.assert_allclose(d.site_xmat[s].reshape(3, 3), expected[k, i, :3, :3], atol=1e-9)
        np.testing.assert_allclose(d.site_xpos[M.site("tcp").id], tcp[k, :3, 3], atol=1e-9)


def test_collision_geoms_are_the_models_capsules(ur5e):
    world = build_world(scene(), ur5e)
    M, d = _compiled(world)
    q = np.array([0.3, -1.1, 1.2, -0.7, 1.4, 0.5])
    d.qpos[:6] = q
    mujoco.mj_kinematics(M, d)
    frames = ur5e.link_frames(q)[0]
    palm = [c for c in ur5e.bodies if "finger" not in c.name]
    assert palm
    for cap in palm:
        g = M.geom(cap.name).id
        T = frames[cap.frame]
        a, b = (T[:3, :3] @ np.asarray(p) + T[:3, 3] for p in (cap.a, cap.b))
        assert M.geom_size[g][0] == pytest.approx(cap.radius)
        np.testing.assert_allclose(d.geom_xpos[g], (a + b) / 2, atol=1e-9)
        if M.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE:
            assert 2 * M.geom_size[g][1] == pytest.approx(np.linalg.norm(b - a))


def test_link_masses_are_urs(ur5e):
    M, _ = _compiled(build_world(scene(), ur5e))
    masses = [M.body(f"link{i}").mass[0] for i in range(1, 6)]
    np.testing.assert_allclose(masses, LINK_MASSES["ur5e"][:5])
    assert all(M.body_gravcomp[M.body(f"link{i}").id] == 1 for i in range(1, 7))


def test_a_button_takes_its_press_force_at_half_travel(ur5e):
    """MuJoCo's own spring force on the plunger: F/2 at rest, F at half travel."""
    world = build_world(scene([button("b1", [0.4, 0.0, 0.1], travel=0.01)]), ur5e)
    M, d = _compiled(world)
    adr = M.jnt_qposadr[M.joint(world.buttons["b1"]["joint"]).id]
    dof = M.jnt_dofadr[M.joint(world.buttons["b1"]["joint"]).id]
    for depth, force in ((0.0, PRESS_FORCE / 2), (0.005, PRESS_FORCE)):
        d.qpos[adr] = depth
        d.qvel[:] = 0
        mujoco.mj_forward(M, d)
        assert -d.qfrc_passive[dof] == pytest.approx(force)  # against the press (the axis points down)


def test_base_and_table_do_not_collide(ur5e):
    world = build_world(scene(table=TABLE), ur5e)
    M, d = _compiled(world)
    d.qpos[:6] = ur5e.home
    mujoco.mj_forward(M, d)
    assert d.ncon == 0


@pytest.mark.parametrize("obj, match", [
    (button("b1", [0, 0, 0], radius=-0.01), r"objects.b1.size: expected \(radius,\)"),
    (button("b1", [0, 0, 0], travel=0.0), "objects.b1.travel: expected a positive distance"),
])
def test_bad_objects_are_refused(ur5e, obj, match):
    with pytest.raises(ValueError, match=match):
        build_world(scene([obj]), ur5e)


def test_the_ur5e_jaws_slide_where_the_2f85s_fingers_are(ur5e):
    """The 2F-85's simulated jaws slide along the flange's y, each towards the side its finger's capsule
    lies on (robosuite's left finger on -y): the simulation's fingers are where the clearance check's are."""
    assert ur5e.gripper_.axis == (0.0, -1.0, 0.0)
    caps = {c.name: c for c in ur5e.gripper_.capsules}
    assert caps["finger_left"].a[1] < 0 < caps["finger_right"].a[1]
    M, d = _compiled(build_world(scene(), ur5e))
    d.qpos[:6] = ur5e.home
    mujoco.mj_kinematics(M, d)
    y = ur5e.link_frames(np.asarray(ur5e.home))[0, -1, :3, 1]
    np.testing.assert_allclose(d.xaxis[M.joint("finger_left_joint").id], -y, atol=1e-9)
    np.testing.assert_allclose(d.xaxis[M.joint("finger_right_joint").id], y, atol=1e-9)


def test_the_panda_has_its_hand_and_two_jaws_that_slide_along_its_axis_and_close_on_command():
    panda = robot_model("panda")
    world = build_world(scene(), panda)
    M, d = _compiled(world)
    assert world.fingers == ("finger_left_joint", "finger_right_joint")
    assert world.stroke == pytest.approx(0.08)
    assert world.owner["hand"] == ("robot", "hand")
    # the hand's mass is robosuite's (hand, fingers, pads: 0.52 kg) on the last link with its own 1 kg
    assert GRIPPER_MASSES["panda_hand"] == pytest.approx(0.52)
    last = M.body_subtreemass[M.body("link7").id]
    assert last == pytest.approx(panda.link_masses[-1] + 0.52)
    q = np.asarray(panda.home)
    arm = [M.jnt_qposadr[M.joint(j).id] for j in world.joints]
    jaws = [M.jnt_qposadr[M.joint(j).id] for j in world.fingers]
    grip = [M.actuator(f"grip_{side}").id for side in ("left", "right")]
    d.qpos[arm], d.qpos[jaws] = q, 0.04  # fully open
    mujoco.mj_forward(M, d)
    flange = panda.link_frames(q)[0, -1]
    axis = flange[:3, :3] @ np.asarray(panda.gripper_.axis)  # the flange's y in the world
    np.testing.assert_allclose(axis, flange[:3, 1], atol=1e-12)
    for joint, sign in zip(world.fingers, (1.0, -1.0), strict=True):
        np.testing.assert_allclose(d.xaxis[M.joint(joint).id], sign * axis, atol=1e-9)
    pads = [d.geom_xpos[M.geom(f"finger_{side}").id].copy() for side in ("left", "right")]
    # open: the pads' inner faces the stroke apart, across the TCP along the axis
    tcp = (flange @ panda.gripper_.tool())[:3, 3]
    inner = [(p - tcp) @ axis - s * 0.004 for p, s in zip(pads, (1.0, -1.0), strict=True)]
    np.testing.assert_allclose(inner, [0.04, -0.04], atol=1e-9)
    # closing on command: hold the arm, the jaws' targets 0; they meet at the TCP
    d.ctrl[:] = 0.0
    for j, name in enumerate(world.joints):
        d.ctrl[M.actuator(f"servo_{name}").id] = q[j]
    d.ctrl[grip] = 0.0
    for _ in range(500):
        mujoco.mj_step(M, d)
    assert np.abs(d.qpos[jaws]).max() < 1e-3
    closed = [d.geom_xpos[M.geom(f"finger_{side}").id] for side in ("left", "right")]
    moved = [c - p for c, p in zip(closed, pads, strict=True)]
    for m_, s in zip(moved, (-1.0, 1.0), strict=True):  # each moved along the axis only, towards the middle
        assert m_ @ axis == pytest.approx(s * 0.04, abs=2e-3)
        assert np.linalg.norm(m_ - (m_ @ axis) * axis) < 2e-3


@pytest.mark.parametrize("axis", [(0.0, 0.0, 1.0), (1.0, 1.0, 0.0), (float("nan"), 0.0, 0.0)])
def test_a_gripper_axis_that_is_not_a_unit_vector_across_the_flanges_z_is_refused(axis):
    from skillbank.robots import ROBOTIQ_2F85, UR5e

    model = UR5e(gripper=ROBOTIQ_2F85._replace(name="tilted", axis=axis))
    with pytest.raises(ValueError, match=r"^gripper tilted: axis: expected a unit vector perpendicular to "
                                         r"the flange's z \(the jaws slide across the approach\), got \["):
        build_world(scene(), model)
