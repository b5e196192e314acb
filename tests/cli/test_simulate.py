"""``skillbank sim run`` (old name ``simulate``): exit status 0 / 1 / 2, the report, --json, --plot."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("mujoco")  # the extra skillbank[sim]

from skillbank.core import Demonstration  # noqa: E402
from skillbank.io import write_npz  # noqa: E402
from skillbank.robots import robot_model  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _sweep(path, angle=0.9, duration=1.8):
    home = np.array(robot_model("ur5e").home)
    t = np.linspace(0.0, duration, 81)
    q = np.tile(home, (len(t), 1))
    q[:, 0] += angle * t / duration
    write_npz(Demonstration(t, {"joints": q}), path)
    return path


def _forearm_box():
    """A 4 cm box beside the forearm's middle, 0.6 rad round the base from home (as in the API test)."""
    ur5e = robot_model("ur5e")
    forearm = next(c for c in ur5e.bodies if c.name == "forearm")
    F = ur5e.link_frames(np.array(ur5e.home) + [0.6, 0, 0, 0, 0, 0])[0, forearm.frame]
    m = F[:3, :3] @ (0.5 * (np.asarray(forearm.a) + np.asarray(forearm.b))) + F[:3, 3]
    return "box:" + ",".join(f"{v:.6f}" for v in [*(m - 0.02), *(m + 0.02)])


@pytest.fixture
def files(tmp_path):
    traj = _sweep(tmp_path / "sweep.npz")
    wall = tmp_path / "wall.json"
    # b1 is of a type that is no button: a pose only, so its fact cannot be judged.
    point = {"b1": {"type": "spot", "position": [0.4, 0.0, 0.1]}}
    wall.write_text(json.dumps({"objects": point, "obstacles": {"wall": _forearm_box()},
                                "goal": ["(pressed b1)"]}))
    empty = tmp_path / "empty.json"
    empty.write_text(json.dumps({"objects": point, "obstacles": [], "goal": ["(pressed b1)"]}))
    return traj, wall, empty


def test_a_clean_replay_exits_0(cli, files):
    traj, _, empty = files
    code, out, err = cli("sim", "run", str(traj), "--scene", str(empty))
    assert code == 0, err
    assert "ok" in out.splitlines()[0] and "contacts: none unintended" in out
    assert "fact (pressed b1): cannot judge" in out


def test_a_button_the_replay_never_presses_exits_1(cli, files, tmp_path):
    traj, _, _ = files
    scene = tmp_path / "button.json"
    scene.write_text(json.dumps({"objects": {"b1": {"type": "button", "position": [0.4, 0.0, 0.1]}},
                                 "goal": ["(pressed b1)"]}))
    code, out, err = cli("sim", "run", str(traj), "--scene", str(scene), "--json")
    assert code == 1, err
    doc = json.loads(out)
    assert doc["facts"] == {"(pressed b1)": False} and doc["buttons"]["b1"]["pressed"] is False


def test_a_contact_exits_1_and_names_the_forearm_and_the_wall(cli, files):
    traj, wall, _ = files
    code, out, err = cli("sim", "run", str(traj), "--scene", str(wall))
    assert code == 1, err
    assert "forearm touched wall" in out and "NOT ok" in out


def test_json_and_plot(cli, files, tmp_path):
    traj, wall, _ = files
    plot = tmp_path / "sim.png"
    code, out, err = cli("sim", "run", str(traj), "--scene", str(wall), "--json", "--plot", str(plot))
    assert code == 1, err
    doc = json.loads(out)
    assert doc["contacts"][0]["robot_body"] == "forearm" and doc["contacts"][0]["other"] == "wall"
    assert set(doc["contacts"][0]) == {"robot_body", "other", "t", "force"}
    assert doc["written"] == [str(plot)]
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("argv, match", [
    (["missing.npz", "--scene", "{empty}"], "sim run: error: .*missing.npz"),
    (["{traj}", "--scene", "{empty}", "--robot", "nao"], "sim run: error: robot: expected one of"),
    (["{traj}", "--scene", "{empty}", "--video", "out.mp4"], r"sim run: error: video: expected a .gif file"),
    (["{traj}", "--scene", "{empty}", "--plot", "nowhere/sim.png"],
     "sim run: error: plot: expected a file in an existing folder"),
    (["{nojoints}", "--scene", "{empty}"], r"sim run: error: trajectory: expected a 'joints' stream"),
])
def test_bad_input_is_one_line_and_exit_2(cli, files, tmp_path, argv, match):
    traj, _, empty = files
    nojoints = tmp_path / "pos.npz"
    write_npz(Demonstration(np.linspace(0, 1, 5), {"position": np.zeros((5, 3))}), nojoints)
    argv = [a.format(traj=traj, empty=empty, nojoints=nojoints) for a in argv]
    code, out, err = cli("sim", "run", *argv)
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and __import__("re").search(match, lines[0]), err


def test_video_is_an_animated_gif_or_one_line_saying_what_to_install(files, tmp_path):
    """In a fresh process (MuJoCo picks its OpenGL backend when first imported)."""
    _, _, empty = files
    gif = tmp_path / "sim.gif"
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    env["PYTHONPATH"] = ROOT
    short = _sweep(tmp_path / "short.npz", angle=0.2, duration=0.5)
    argv = ["sim", "run", str(short), "--scene", str(empty), "--video", str(gif)]
    done = subprocess.run([sys.executable, "-m", "skillbank.cli", *argv], capture_output=True, text=True,
                          env=env, timeout=120)
    if done.returncode == 2:
        assert "video: no OpenGL backend" in done.stderr and len(done.stderr.strip().splitlines()) == 1
        pytest.skip("no OpenGL backend here: " + done.stderr.strip())
    assert done.returncode == 0, done.stderr
    from PIL import Image

    with Image.open(gif) as image:
        assert image.format == "GIF" and image.n_frames >= 10
