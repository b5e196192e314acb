"""robosuite's latched Door: recorded, its joints found from the recorded poses, opened in new scenes.

Real robosuite episodes on the Panda: the scripted recorder presses the handle's lever down past the latch
and pulls the door about its hinge; success is the environment's own check (the hinge past 0.3 rad).
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("robosuite")  # the extra skillbank[sim]

from skillbank.core import fit_joint  # noqa: E402
from skillbank.core._rotations import quaternion_conjugate, quaternion_multiply, quaternion_to_matrix  # noqa: E402
from skillbank.io import reported_body, with_object_poses  # noqa: E402
from skillbank.pipeline import Library  # noqa: E402
from skillbank.simulation import evaluate, record  # noqa: E402
from skillbank.simulation._robosuite import TASKS, _env_args, _episode, import_robosuite  # noqa: E402
from skillbank.simulation._support import articulated  # noqa: E402


@pytest.fixture(scope="module")
def door_episode():
    """One scripted Door episode on the Panda, run here so the model's own joints can be read beside it."""
    suite = import_robosuite()
    env = suite.make("Door", **_env_args("Door", 1000, 3, "Panda")["env_kwargs"])
    try:
        rows, ok = _episode(env, TASKS["Door"], np.random.default_rng(3))
        m, d = env.sim.model, env.sim.data
        joints = {name: (np.array(d.xaxis[m.joint_name2id(name)]), np.array(d.xanchor[m.joint_name2id(name)]))
                  for name in ("Door_hinge", "Door_latch_joint")}
        obs = with_object_poses(env, env._get_observations(force_update=True))
        parts = {name: articulated(env, obs, name) for name in ("door", "handle")}
    finally:
        env.close()
    stream = {k: np.stack([o[k] for o in rows["obs"]]) for k in rows["obs"][0]}
    return ok, stream, joints, parts


def _off(axis, point, true_axis, true_point):
    """Degrees between two axes and metres from the true line's point to the fitted line."""
    degrees = np.degrees(np.arccos(min(1.0, abs(float(axis @ true_axis)))))
    d = true_point - point
    return degrees, float(np.linalg.norm(d - (d @ axis) * axis))


def test_the_door_is_opened_and_its_turns_are_read_from_the_simulator(door_episode):
    ok, stream, _, parts = door_episode
    assert ok
    # robosuite shows the door's and the handle's positions only: their turns come from the model's bodies
    for name in ("door", "handle"):
        q = stream[f"{name}_quat"]
        assert q.shape == (len(stream["door_pos"]), 4) and np.allclose(np.linalg.norm(q, axis=1), 1.0)
    assert parts == {"door": True, "handle": True}  # parts of an articulated object, not loose ones


def test_the_hinge_found_from_the_door_poses_is_the_models_within_2_degrees_and_1_cm(door_episode):
    _, stream, joints, _ = door_episode
    p, q = stream["door_pos"], stream["door_quat"]
    moved = np.flatnonzero(np.linalg.norm(p - p[0], axis=1) > 1e-4)
    start = max(int(moved[0]) - 1, 0)
    joint = fit_joint(p[start:], q[start:])
    assert joint.kind == "revolute"
    degrees, metres = _off(joint.axis, joint.point, *joints["Door_hinge"])
    assert degrees < 2.0 and metres < 0.01
    assert joint.values[-1] > 0.3  # opened as far as the task asks


def test_the_latch_found_from_the_handle_in_the_doors_frame_is_the_models(door_episode):
    _, stream, joints, _ = door_episode
    Rd = quaternion_to_matrix(stream["door_quat"])
    # the handle in the door's frame, mapped back to the world with the door's first pose
    local_p = np.einsum("nji,nj->ni", Rd, stream["handle_pos"] - stream["door_pos"])
    local_q = quaternion_multiply(quaternion_conjugate(stream["door_quat"]), stream["handle_quat"])
    first_p, first_q = stream["door_pos"][0], stream["door_quat"][0]
    p = local_p @ quaternion_to_matrix(first_q).T + first_p
    q = quaternion_multiply(np.broadcast_to(first_q, local_q.shape), local_q)
    turned = np.flatnonzero(np.linalg.norm(p - p[0], axis=1) > 1e-4)
    joint = fit_joint(p[max(int(turned[0]) - 1, 0):], q[max(int(turned[0]) - 1, 0):])
    assert joint.kind == "revolute"
    # the model's latch, read as the episode ended (the door open), in the door's first pose
    axis, anchor = joints["Door_latch_joint"]
    back = quaternion_to_matrix(first_q) @ Rd[-1].T
    axis, anchor = back @ axis, back @ (anchor - stream["door_pos"][-1]) + first_p
    degrees, metres = _off(joint.axis, joint.point, axis, anchor)
    assert degrees < 2.0 and metres < 0.01
    assert joint.values.max() > 1.2  # pressed past the latch


def test_a_door_is_opened_in_new_scenes_from_one_recorded_demonstration(tmp_path):
    out = tmp_path / "door.hdf5"
    record("robosuite:Door", episodes=1, out=out, seed=0, robot="Panda")
    db = tmp_path / "door.db"
    with Library(db) as lib:
        lib.add_files([out])
        lib.cluster()
    report = evaluate(db, "robosuite:Door", episodes=2, seed=7000, robot="Panda")
    assert report["successes"] == 2, report["per_episode"]
    rigid = evaluate(db, "robosuite:Door", episodes=1, seed=7000, robot="Panda", method="rigid")
    assert rigid["episodes"] == 1  # the baseline runs the same episodes


def test_an_observed_position_nothing_stands_at_gets_no_turn():
    class _Data:
        xpos = np.zeros((2, 3))
        site_xpos = np.zeros((0, 3))
        xmat = np.tile(np.eye(3).ravel(), (2, 1))

    class _Sim:
        data = type("D", (), {"_data": _Data()})()

    env = type("E", (), {"sim": _Sim()})()
    obs = {"ghost_pos": np.array([1.0, 2.0, 3.0]), "robot0_eef_pos": np.zeros(3)}
    assert "ghost_quat" not in with_object_poses(env, obs)
    assert reported_body(env, obs, "ghost") is None
    at_origin = with_object_poses(env, {"thing_pos": np.zeros(3)})
    assert np.allclose(at_origin["thing_quat"], [0, 0, 0, 1])


def test_a_door_is_opened_from_one_human_like_demonstration_in_robosuites_raw_format(tmp_path):
    """A person-like operator presses the lever and pulls the door with a SpaceMouse's pushes (its fingers
    give; its hand leads the lever); the file is robosuite's raw collection format, read by replaying it.
    Reproduced by following the lever and the door about their joints at the pace they keep."""
    from skillbank.simulation import record_human

    out = tmp_path / "door_human.hdf5"
    record_human("robosuite:Door", episodes=1, out=out, seed=0, robot="Panda", max_tries=3)
    db = tmp_path / "door_human.db"
    with Library(db) as lib:
        lib.add_files([out])
        lib.cluster()
        demo = lib.demonstration(lib.demonstration_ids()[0])
    assert {"door_quat", "handle_quat"} <= set(demo.streams)  # read from the replayed simulator
    report = evaluate(db, "robosuite:Door", episodes=2, seed=900, robot="Panda")
    assert report["successes"] == 2, report["per_episode"]


def test_a_person_like_episode_that_loses_the_lever_is_not_kept_and_says_so(tmp_path):
    from skillbank.simulation import record_human

    # seed 5's operator loses track on the way in (its taps stop moving the hand): the episode is given
    # up, as a picking person's third miss is, not a traceback
    with pytest.raises(ValueError, match=r"only 0 of 1 human-like episodes succeeded"):
        record_human("robosuite:Door", episodes=1, out=tmp_path / "lost.hdf5", seed=5, robot="Panda",
                     max_tries=1)
    assert not (tmp_path / "lost.hdf5").exists()
