"""A few bytes cannot ask a simulation for gigabytes: physics steps and video frames are bounded (41)."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("mujoco")  # the extra skillbank[sim]

from skillbank.core import Demonstration  # noqa: E402
from skillbank.io import write_npz  # noqa: E402
from skillbank.planning import Scene  # noqa: E402
from skillbank.robots import robot_model  # noqa: E402
from skillbank.simulation import simulate  # noqa: E402
from skillbank.simulation._bounds import check_steps, max_frames, max_steps  # noqa: E402

EMPTY = Scene(objects={}, obstacles={}, init=[], goal=[])


def _still(duration, n=2):
    q = np.tile(robot_model("ur5e").home, (n, 1))
    return Demonstration(np.linspace(0.0, duration, n), {"joints": q})


@pytest.fixture
def long_file(tmp_path):
    path = tmp_path / "long.npz"
    write_npz(_still(1e6), path)
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({"objects": {"b1": {"type": "spot", "position": [0.4, 0.0, 0.1]}},
                                 "obstacles": [], "goal": ["(pressed b1)"]}))
    return path, scene


def test_a_million_seconds_is_one_line_and_exit_2_within_a_small_memory(long_file, limited, tmp_path):
    path, scene = long_file
    assert path.stat().st_size < 4096
    before = sorted(p.name for p in tmp_path.iterdir())
    code, out, err = limited("sim", "run", path, "--scene", scene, "--plot", tmp_path / "p.png",
                             "--video", tmp_path / "v.gif", memory=1 << 30, timeout=120)
    assert code == 2 and out == "", err
    assert err.count("\n") == 1
    assert "sim run: error: trajectory: the simulation would take 5e+08 physics steps (1e+06 s at 2 ms a " \
           "step), more than the bound of 2097152 (set SKILLBANK_MAX_SIMULATION_STEPS" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written


def test_the_bound_is_checked_by_the_api_before_the_world_is_built(monkeypatch):
    with pytest.raises(ValueError, match=r"^trajectory: the simulation would take 5e\+08 physics steps"):
        simulate(_still(1e6), EMPTY)
    monkeypatch.setenv("SKILLBANK_MAX_SIMULATION_STEPS", "50")
    with pytest.raises(ValueError, match=r"would take 101 physics steps \(0\.2 s at 2 ms a step\), more than "
                                         r"the bound of 50 \(set SKILLBANK_MAX_SIMULATION_STEPS"):
        simulate(_still(0.2), EMPTY)
    monkeypatch.setenv("SKILLBANK_MAX_SIMULATION_STEPS", "101")
    assert len(simulate(_still(0.2), EMPTY).t_) == 101  # exactly at the bound: simulated


def test_the_video_frames_are_bounded_before_rendering(monkeypatch, tmp_path):
    monkeypatch.setenv("SKILLBANK_MAX_VIDEO_FRAMES", "5")
    with pytest.raises(ValueError, match=r"^video: the video would hold 6 frames \(0\.24 s at 25 frames/s\), "
                                         r"more than the bound of 5 \(set SKILLBANK_MAX_VIDEO_FRAMES"):
        simulate(_still(0.2), EMPTY, video=tmp_path / "v.gif")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match=r"^video_fps: expected frames/s in \(0, 500\]"):
        simulate(_still(0.2), EMPTY, video=tmp_path / "v.gif", video_fps=0)


@pytest.mark.parametrize("variable, call", [("SKILLBANK_MAX_SIMULATION_STEPS", max_steps),
                                            ("SKILLBANK_MAX_VIDEO_FRAMES", max_frames)])
@pytest.mark.parametrize("text", ["0", "-3", "many", "1e9"])
def test_a_bad_override_is_one_line(variable, call, text):
    with pytest.raises(ValueError, match=rf"^{variable}: expected a whole number of \w+ > 0, got '{text}'"):
        call({variable: text})


def test_an_override_lets_a_long_simulation_through():
    assert check_steps(1e6, 0.002, {"SKILLBANK_MAX_SIMULATION_STEPS": str(10 ** 9)}) == 500_000_001
    with pytest.raises(ValueError, match="physics steps"):
        check_steps(float("inf"), 0.002)
