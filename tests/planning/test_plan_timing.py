"""A plan's joint trajectory timed by the time law (issue 43, item 4): each step's joint path by TOPP-RA
(``robots.time_law``, the one reuse uses), the chain's step boundaries kept, every export within the limits
it states (read back), and never slower than the uniform stretch the chain used before."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.io import load, read_npz, write_trajectory
from skillbank.io._trajectory_export import blended_joints
from skillbank.planning import _chain, plan_task, scene_from_dict
from skillbank.robots import UR5e, rate_ratio
from skillbank.selection._execution import robot_limits

from .conftest import button_scene

#: The four-button task of test_plan.py: the three-button skill, four new buttons around a post.
BUTTONS = [[-0.3, -0.45, 0.12], [0.0, -0.6, 0.1], [0.25, -0.55, 0.11], [0.35, -0.4, 0.13]]
POST = "sphere:0.194,-0.648,0.168,0.02"
#: What a step's note says when the time law timed it: the duration before, after, and the uniform stretch's.
LAW_NOTE = re.compile(r"time law toppra \(TOPP-RA, path kept\) for .*: ([0-9.e+-]+) s -> ([0-9.e+-]+) s "
                      r"\(a uniform stretch: ([0-9.e+-]+) s\)")


@pytest.fixture(scope="module")
def four_buttons(button_library):
    doc = button_scene(BUTTONS, goal=["b4", "b2", "b1", "b3"], orientation=[0.0, 0.94, -0.33, 0.08],
                       obstacles={"post": POST}, start=[-0.356, -0.416, 0.176])
    doc["start"]["orientation"] = [0.038, 0.955, -0.283, 0.078]
    return plan_task(button_library.store, scene_from_dict(doc), robot="ur5e", limits={"joint_velocity": 1.0})


def _stated(timing):
    limits = timing["limits"]
    return np.asarray(limits["joint_velocity"]), np.asarray(limits["joint_acceleration"])


def _peaks(J, t):
    """Per-joint peak speed and acceleration by finite differences (what a CSV holds)."""
    v = np.diff(J, axis=0) / np.diff(t)[:, None]
    a = np.diff(v, axis=0) / (0.5 * (t[2:] - t[:-2]))[:, None]
    return np.abs(v).max(axis=0), np.abs(a).max(axis=0)


def test_every_step_is_timed_by_the_law_no_slower_than_the_uniform_stretch(four_buttons):
    res = four_buttons
    traj = res.trajectory
    assert traj.metadata["timing"]["law"] == "toppra"
    assert traj.metadata["timing"]["steps"] == ["toppra"] * 4
    # the step boundaries as before: each step starts on the previous one's last sample
    assert res.steps[0].start == 0 and res.steps[-1].stop == traj.n_steps
    for a, b in zip(res.steps[:-1], res.steps[1:], strict=True):
        assert b.start == a.stop - 1
    for step in res.steps:
        [(before, after, uniform)] = [tuple(map(float, m.groups())) for n in step.notes
                                      if (m := LAW_NOTE.search(n))]
        seconds = float(traj.t[step.stop - 1] - traj.t[step.start])
        assert seconds == pytest.approx(after, rel=1e-5)
        assert before <= after < uniform  # never faster than asked, faster than the stretch
    vmax, amax = _stated(traj.metadata["timing"])
    assert rate_ratio(traj.t, traj["joints"], velocity=vmax, acceleration=amax) <= 1.0 + 1e-9
    assert vmax.tolist() == [1.0] * 6 and amax.tolist() == [np.pi] * 6  # the given one, the UR5e's own


def test_every_export_of_a_plan_states_its_limits_and_keeps_within_them(four_buttons, tmp_path):
    """CSV, URScript, NPZ and a ROS 2 bag of the planned trajectory, each read back."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore
    from ruamel.yaml import YAML

    traj = four_buttons.trajectory
    expected = json.loads(json.dumps(traj.metadata["timing"]))
    vmax, amax = _stated(expected)
    # CSV: read back by skillbank's reader, the timing as metadata; the samples within both limits
    back = load(write_trajectory(traj, tmp_path / "plan.csv"))
    assert back.metadata["timing"] == expected
    speed, accel = _peaks(back["joints"], back.t)
    assert (speed <= vmax * (1 + 1e-9)).all() and (accel <= amax * (1 + 1e-9)).all()
    assert max((speed / vmax).max(), np.sqrt((accel / amax).max())) > 0.999  # to the limits, not slower
    # URScript: the header states them, the servoj steps keep within them (up to blended_joints' drift
    # correction and the 9 printed decimals)
    for rate in (125.0, 500.0):
        text = write_trajectory(traj, tmp_path / f"plan{rate:g}.script", rate=rate).read_text()
        line = next(x for x in text.splitlines() if x.startswith("# skillbank timing: "))
        assert json.loads(line[len("# skillbank timing: "):]) == expected
        steps = np.array([x.strip()[len("servoj(["):x.strip().index("]")].split(",")
                          for x in text.splitlines() if x.strip().startswith("servoj(")], dtype=float)
        times = np.minimum(np.arange(len(steps)) / rate, traj.t[-1])
        written_v, written_a = _peaks(steps[:-1], times[:-1])
        drift = np.abs(blended_joints(traj.t, traj.t, traj["joints"]) - traj["joints"]).max()
        assert (written_v <= vmax + drift / traj.t[-1] + 2e-9 * rate).all()
        assert (written_a <= amax * (1 + 1e-9) + 4e-9 * rate**2).all()
    # NPZ: the metadata
    assert read_npz(write_trajectory(traj, tmp_path / "plan.npz")).metadata["timing"] == expected
    # ROS 2 bag: custom_data, and every JointTrajectory point's velocities and accelerations
    bag = write_trajectory(traj, tmp_path / "bag", format="rosbag")
    info = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert json.loads(info["custom_data"]["skillbank_timing"]) == expected
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        [(conn, _, raw)] = [m for m in reader.messages() if m[0].topic == "/joint_trajectory"]
        msg = reader.deserialize(raw, conn.msgtype)
    V = np.array([p.velocities for p in msg.points])
    A = np.array([p.accelerations for p in msg.points])
    assert (np.abs(V) <= vmax * (1 + 1e-9)).all() and (np.abs(A) <= amax * (1 + 1e-9)).all()


def test_a_plan_without_a_robot_states_no_timing(described_library):
    from .conftest import BUTTONS_DOC

    res = plan_task(described_library.store, scene_from_dict(BUTTONS_DOC))
    assert "timing" not in res.trajectory.metadata


@st.composite
def _joint_paths(draw):
    """A smooth random joint path of the UR5e (a few cosines per joint), a time base, and its limits."""
    n = draw(st.integers(20, 200))
    s = np.linspace(0.0, 1.0, n)
    amp = np.array(draw(st.lists(st.floats(-2.0, 2.0), min_size=12, max_size=12))).reshape(2, 6)
    J = amp[0] * (1 - np.cos(np.pi * s))[:, None] / 2 + amp[1] * np.sin(2 * np.pi * s)[:, None] / 4
    duration = draw(st.floats(0.05, 20.0))
    velocity = draw(st.floats(0.2, 4.0))
    return s * duration, J, {"joint_velocity": velocity}


# TOPP-RA solves a small LP per gridpoint: tens of milliseconds an example, more on a loaded machine
@settings(deadline=None, max_examples=40, derandomize=True)
@given(_joint_paths(), st.sampled_from(["rest", "given"]))
def test_a_steps_timing_meets_the_limits_never_faster_than_asked_nor_slower_than_the_stretch(path, ends):
    """At rest at its ends (a step that joins the next at rest) or at its time base's speed there (one
    bound with velocity free)."""
    t, J, given_limits = path
    model = UR5e()
    limits, _ = robot_limits(model, given_limits)
    keys = {"velocity": limits["joint_velocity"], "acceleration": limits["joint_acceleration"]}
    ratio = rate_ratio(t, J, **keys)
    out, note, law = _chain._timed_step({"joints": J}, t, limits, model, "step 1", ends)
    if ratio <= 1.0 + 1e-9:  # met already: kept
        assert law == "as given" and note is None and out is t
        return
    assert law in ("toppra", "uniform") and note.startswith("step 1: ")
    assert rate_ratio(out, J, **keys) <= 1.0 + 1e-9
    assert out[0] == 0.0 and (np.diff(out) > 0).all()
    assert out[-1] >= t[-1] * (1 - 1e-12)  # never faster than the step's own time base
    assert out[-1] <= t[-1] * ratio * (1 + 1e-9)  # never slower than the uniform stretch


def test_a_join_that_breaks_the_limits_stretches_the_chain_with_a_note():
    """Two steps timed on their own, the first ending moving (a step bound with velocity free): the
    join reverses the joints at full speed, and the chain is stretched until it meets the limits."""
    from skillbank import Demonstration

    t = np.linspace(0.0, 2.0, 41)
    J = np.zeros((41, 6))
    J[:, 0] = np.r_[np.linspace(0.0, 1.0, 21), np.linspace(1.0, 0.0, 21)[1:]]  # 1 rad/s, then back
    limits = {"joint_velocity": np.full(6, 1.0), "joint_acceleration": np.full(6, 2.0)}
    notes = []
    out = _chain._timed_joins(Demonstration(t, {"joints": J}), limits, notes)
    assert rate_ratio(out.t, J, velocity=1.0, acceleration=2.0) <= 1.0 + 1e-9
    scale = out.metadata["joins_stretched_by"]
    assert scale > 1.0 and out.t[-1] == pytest.approx(2.0 * scale)
    assert notes == [f"time stretched by {scale:.4g} to meet the joint limits across the joins of the steps "
                     f"(each step is timed on its own): 2 s -> {2.0 * scale:.6g} s"]
    met = Demonstration(out.t, {"joints": J})
    assert _chain._timed_joins(met, limits, notes) is met and len(notes) == 1  # met: kept, no note
