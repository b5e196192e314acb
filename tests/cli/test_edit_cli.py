"""``skillbank edit``: every method through ``main``, JSON output, constraints, obstacles, errors.

Shape thresholds are the values measured on the synthetic arcs below (in the
comments) with a margin of about 2.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

import skillbank
import skillbank.io as sio
from skillbank.cli._options import constraints_from_args
from skillbank.metrics import dtw_distance, frechet_distance

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
METHODS = ["lte", "ja", "promp", "elmap", "dmp"]
MULTI = {"promp", "elmap", "dmp"}
KEYS = {"frechet", "dtw", "swept_error_area", "angular_similarity", "curvature_deviation", "path_length",
        "demo_path_length", "jerk_cost"}
# method -> (curvature deviation, angular similarity) to demo 0 after the move below
SHAPE = {
    "lte": (1e-4, 0.04),  # measured 3.5e-5, 0.020
    "ja": (1e-3, 0.10),  # 4.2e-4, 0.056
    "promp": (1e-3, 0.09),  # 2.0e-4, 0.046
    "elmap": (1e-3, 0.12),  # 4.5e-4, 0.059
    "dmp": (1e-4, 0.05),  # 2.9e-5, 0.028
}
# method -> largest distance to the demo (lte, ja) or to the demos' mean with no constraint at all
PLAIN = {"lte": 1e-12, "ja": 1e-4, "promp": 6e-3, "elmap": 8e-3, "dmp": 1e-3}  # 0, 4e-5, 2.7e-3, 3.9e-3, 2e-4




def arc(k: int, n: int = 200) -> skillbank.Demonstration:
    """A wavy half circle over 2 s, from (1, 0) to (-1.2, 0); ``k`` shifts it a little."""
    t = np.linspace(0.0, 2.0, n)
    s = t / 2.0
    Y = np.column_stack([np.cos(np.pi * s) * (1 + 0.2 * s) + 0.02 * k,
                         np.sin(np.pi * s) + 0.1 * np.sin(4 * np.pi * s) - 0.03 * k])
    return skillbank.Demonstration(t, {"position": Y})


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Three arcs, as CSV and NPZ."""
    folder = tmp_path_factory.mktemp("arcs")
    paths = []
    for k, suffix in enumerate(("csv", "npz", "csv")):
        path = folder / f"arc{k}.{suffix}"
        (sio.write_csv if suffix == "csv" else sio.write_npz)(arc(k), path)
        paths.append(path)
    return paths


def _inputs(files, method):
    return files if method in MULTI else files[:1]


def _json(cli, *argv):
    code, out, err = cli("edit", *argv, "--json", "--metrics")
    assert code == 0, err
    doc = json.loads(out)
    assert set(doc) - {"plot"} == {"t", "streams", "trajectory", "used", "rejected", "constraint_error",
                                   "orientation_error", "collision", "peaks", "notes", "metrics"}
    assert isinstance(doc["constraint_error"], float) and isinstance(doc["collision"], bool)
    return doc, np.array(doc["trajectory"])


@pytest.mark.parametrize("method", METHODS)
def test_constraints_met_and_shape_kept(cli, files, method):
    via = [] if method == "dmp" else ["--via", "0.5:0.1,1.2"]
    doc, Y = _json(cli, *_inputs(files, method), "--method", method, "--start", "1.1,0.1",
                   "--goal", "-1.3,-0.1", *via)
    assert Y.shape == (200, 2)
    tol = 1e-3 if method == "dmp" else 1e-6  # DMP reaches its goal to e^-8 of the move: measured 2.3e-4
    np.testing.assert_allclose(Y[0], [1.1, 0.1], atol=tol)
    np.testing.assert_allclose(Y[-1], [-1.3, -0.1], atol=tol)
    if via:
        np.testing.assert_allclose(Y[100], [0.1, 1.2], atol=1e-6)  # round(0.5 * 199) = 100 (half up)
    assert doc["constraint_error"] < tol and doc["collision"] is False
    m = doc["metrics"]
    assert set(m) == KEYS
    demo = arc(0)["position"]
    assert m["frechet"] == pytest.approx(frechet_distance(Y, demo), abs=1e-12)
    assert m["dtw"] == pytest.approx(dtw_distance(Y, demo), rel=1e-12)
    assert m["frechet"] < 0.3  # measured 0.14-0.24 (the ends move by 0.14, the via-point by 0.1)
    assert m["curvature_deviation"] < SHAPE[method][0]
    assert m["angular_similarity"] < SHAPE[method][1]


@pytest.mark.parametrize("method", METHODS)
def test_unchanged_constraints_reproduce_the_demo(cli, files, method):
    _, Y = _json(cli, *_inputs(files, method), "--method", method)
    demos = [arc(k)["position"] for k in range(3 if method in MULTI else 1)]
    assert np.abs(Y - np.mean(demos, axis=0)).max() < PLAIN[method]


@pytest.mark.parametrize("method", METHODS)
def test_obstacle_avoided(cli, files, method):
    sphere, box = "sphere:0.0,1.0,0.15", "box:-1.0,0.7,-0.8,0.9"
    c = constraints_from_args(obstacle=[sphere, box])
    assert c.collision_mask(arc(0)["position"]).sum() > 10  # the demo runs through both
    doc, Y = _json(cli, *_inputs(files, method), "--method", method, "--goal", "-1.25,0.0",
                   "--obstacle", sphere, "--obstacle", box)
    assert doc["collision"] is False
    assert c.signed_distances(Y).min() >= 0.0
    assert doc["metrics"]["clearance"] == pytest.approx(c.signed_distances(Y).min())
    np.testing.assert_allclose(Y[-1], [-1.25, 0.0], atol=1e-9)  # LTE pins the ends while avoiding
    assert doc["constraint_error"] < 1e-9


def test_unavoidable_obstacle_is_reported(cli, files):
    # The goal itself is inside the sphere: no edit can be collision-free, and the result says so.
    doc, Y = _json(cli, files[0], "--goal", "-1.2,0.0", "--obstacle", "sphere:-1.2,0.0,0.1")
    assert doc["collision"] is True and doc["metrics"]["clearance"] < 0
    code, out, _ = cli("edit", files[0], "--goal", "-1.2,0.0", "--obstacle", "sphere:-1.2,0.0,0.1")
    assert code == 0 and "collision yes" in out and "warning: sample" in out and "pinned" in out


def test_negative_coordinates_without_equals_sign(cli, files):
    _, Y = _json(cli, files[0], "--start", "-0.5,-.25", "--goal=-1e0,0")
    np.testing.assert_allclose(Y[[0, -1]], [[-0.5, -0.25], [-1.0, 0.0]], atol=1e-12)


@pytest.mark.parametrize("suffix", ["csv", "npz"])
def test_out_and_plot(cli, files, tmp_path, suffix):
    out, plot = tmp_path / f"edited.{suffix}", tmp_path / "edit.png"
    doc, Y = _json(cli, *files, "--method", "promp", "--goal", "-1.3,0.1", "--via", "0.3:0.6,1.0",
                   "--obstacle", "sphere:-0.6,0.9,0.1", "--out", out, "--plot", plot)
    assert doc["plot"] == str(plot)
    back = sio.load(out)
    np.testing.assert_allclose(back["position"], Y, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back.t, np.linspace(0.0, 2.0, 200), atol=1e-15)
    if suffix == "npz":
        assert back.metadata["method"] == "promp" and back.metadata["collision"] is False
    assert plot.read_bytes()[:8] == PNG_MAGIC


def test_text_output(cli, files, tmp_path):
    plot = tmp_path / "e.png"
    argv = ["--method", "ja", "--goal", "-1.3,0.0"]
    code, out, err = cli("edit", files[0], *argv, "--plot", plot, "--metrics")
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert lines[0] == "ja: 1 demonstration(s) -> 200 samples, 2 dimensions"
    assert lines[1].startswith("  constraint error ") and lines[1].endswith("collision no")
    assert "frechet" in lines[2] and lines[-1] == f"  wrote {plot}"
    # the quadratic-time comparison only on request
    code, out, _ = cli("edit", files[0], "--method", "ja", "--goal", "-1.3,0.0")
    assert code == 0 and len(out.splitlines()) == 2 and "frechet" not in out
    code, out, _ = cli("edit", files[0], "--goal", "-1.3,0.0", "--json")
    assert "metrics" not in json.loads(out)


@pytest.mark.parametrize("argv, match", [
    (["missing.csv"], r"input: no such file: '.*missing\.csv'"),
    (["{0}", "--goal", "1,2,3"], r"constraints: goal has 3 dimensions but the trajectory has 2"),
    (["{0}", "{1}", "--method", "ja"],
     r"input: method 'ja' \(JerkAccuracy\) adapts one demonstration, got 2; "
     r"use one of \['promp', 'elmap', 'dmp'\] for several"),
    (["{0}", "{1}"], r"input: method 'lte' \(LaplacianEditor\) adapts one demonstration"),
    (["{0}", "--method", "spline"], r"method: expected one of \['lte', 'ja', 'promp', 'elmap', 'dmp'\], "
                                    r"got 'spline'"),
    (["{0}", "--method", "dmp", "--via", "0.5:0,1"], r"DMP does not support via-points"),
    (["{0}", "--via", "1.5:0,1"], r"ViaPoint phase: expected .*1\.5"),
    (["{0}", "--via", "0,1"], r"via: expected 'PHASE:X,Y\[,Z\]'"),
    (["{0}", "--obstacle", "cone:0,0,1"], r"obstacle: expected 'sphere:X,Y\[,Z\],R'"),
    (["{0}", "--obstacle", "sphere:0,0,-1"], r"sphere radius"),
    (["{0}", "--start", "1,x"], r"start: expected a number, got 'x'"),
    (["{0}", "--out", "result.json"], r"out: expected a file name ending in \.csv, .* got 'result\.json'"),
    (["{0}", "{2}"], r"input: '.*forces\.npz' has streams \['force', 'torque'\] and none is 'position'"),
    (["{1}", "{3}", "--method", "promp"], r"input: '.*line3d\.csv' has 3 dimensions, but '.*' has 2"),
    (["{0}", "--plot", "{4}/e.txt"], r"plot: expected a figure file name ending in one of \.avif, .*\.png, .*"
                                    r"\(or no extension for \.png\), got '.*e\.txt'"),
    (["{0}", "--out", "{4}/no/such/dir/e.csv"], r"out: folder '.*dir' does not exist"),
])
def test_errors_exit_2_with_one_line(cli, files, tmp_path, argv, match):
    t = np.linspace(0.0, 1.0, 20)
    forces = tmp_path / "forces.npz"
    sio.write_npz(skillbank.Demonstration(t, {"force": np.ones((20, 3)), "torque": np.ones((20, 3))}), forces)
    line3d = tmp_path / "line3d.csv"
    sio.write_csv(skillbank.Demonstration.from_array(np.c_[t, t, t], t=t), line3d)
    paths = [files[0], files[1], forces, line3d, tmp_path]
    code, out, err = cli("edit", *[a.format(*paths) for a in argv])
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("skillbank edit: error: ")
    assert re.search(match, err), err


@pytest.mark.parametrize("name, written", [
    ("figs", "figs.png"),  # an existing folder: matplotlib writes next to it, with .png added
    ("edit", "edit.png"),
    ("new/sub/edit.pdf", "new/sub/edit.pdf"),  # parents created, as --plot does in every command
])
def test_plot_says_the_file_it_really_wrote(cli, files, tmp_path, name, written):
    (tmp_path / "figs").mkdir()
    code, out, err = cli("edit", files[0], "--goal", "-1.3,0.0", "--plot", tmp_path / name)
    assert code == 0, err
    assert out.splitlines()[-1] == f"  wrote {tmp_path / written}"
    assert (tmp_path / written).is_file() and (tmp_path / written).stat().st_size > 1000
    assert (tmp_path / "figs").is_dir()
    code, out, _ = cli("edit", files[0], "--plot", tmp_path / name, "--json")
    assert json.loads(out)["plot"] == str(tmp_path / written)


def test_bad_plot_name_fails_before_the_work(cli, files, tmp_path, monkeypatch):
    import skillbank.representations as reps

    monkeypatch.setattr(reps, "fit_reproduce", lambda *a, **k: pytest.fail("edited before checking --plot"))
    code, out, err = cli("edit", files[0], "--plot", tmp_path / "e.figure")
    assert code == 2 and out == "" and "plot: expected a figure file name" in err


# -- real data --------------------------------------------------------------------------------------

def _coords(values) -> str:
    return ",".join(repr(float(v)) for v in values)


def test_real_handwriting_2d(cli, data_dir):
    path = data_dir / "seed" / "r_shape.h5"
    demo = sio.load(path)["position"]
    goal = demo[-1] + 0.1 * np.ptp(demo, axis=0)
    mid = demo[500] + [0.05 * np.ptp(demo[:, 0]), 0.0]
    doc, Y = _json(cli, path, "--goal", _coords(goal), "--via", "0.5:" + _coords(mid))
    assert Y.shape == demo.shape and doc["collision"] is False
    assert doc["constraint_error"] < 1e-9
    np.testing.assert_allclose(Y[0], demo[0], atol=1e-12)
    assert doc["metrics"]["curvature_deviation"] < 1e-3 * np.ptp(demo)  # LTE keeps the Laplacian


def test_real_robot_3d_with_obstacles(cli, data_dir, tmp_path):
    path = data_dir / "seed" / "three_button_pressing_demo.h5"
    demo = sio.load(path)["position"]
    centre = demo[len(demo) // 3]
    radius = 0.2 * float(np.ptp(demo, axis=0).min())
    lo, hi = demo[2 * len(demo) // 3] - radius, demo[2 * len(demo) // 3] + radius
    sphere = "sphere:" + _coords([*centre, radius])
    box = "box:" + _coords([*lo, *hi])
    plot = tmp_path / "robot.png"
    doc, Y = _json(cli, path, "--obstacle", sphere, "--obstacle", box, "--plot", plot)
    c = constraints_from_args(obstacle=[sphere, box])
    assert c.collides(demo) and not c.collides(Y) and doc["collision"] is False
    assert Y.shape == demo.shape and np.abs(Y[[0, -1]] - demo[[0, -1]]).max() < 1e-12
    assert plot.read_bytes()[:8] == PNG_MAGIC


@pytest.mark.parametrize("beyond", [0.2, 0.05])
def test_edit_a_path_beyond_the_ur5es_reach_says_by_how_much(cli, tmp_path, beyond):
    """Issue 23, item 9: the arm stretched on the way is not the elbow singularity; the goal is out of reach.

    2000 samples: some pass within 0.25 mm of full stretch, where |sin(elbow)| < 0.05, before the reach ends.
    """
    from skillbank.robots import UR5e
    from skillbank.robots._ur5e import _dh

    robot = UR5e()
    q = np.array([[0.0, -1.2, 0.0, -1.5, -1.5, 0.0]])  # the elbow straight: the arm at full stretch
    out = (_dh(q[:, 0], 0) @ _dh(q[:, 1], 1) @ _dh(q[:, 2], 2))[0, :3, 3] - _dh(q[:, 0], 0)[0, :3, 3]
    out /= np.linalg.norm(out)  # from the shoulder to wrist 1: moving the tool along it moves wrist 1 as much
    p, quat = robot.fk(q[0])
    s = np.linspace(0.0, 1.0, 2000)
    demo = skillbank.Demonstration(2.0 * s, {"position": p + np.outer(s * (0.1 + beyond) - 0.1, out),
                                             "orientation": np.tile(quat, (2000, 1))},
                              {"pose_of": "robotiq_2f85:tcp"})  # FK of the default tool
    path = sio.write_npz(demo, tmp_path / "out.npz")
    code, text, err = cli("edit", path, "--robot", "ur5e", "--out", tmp_path / "r.csv")
    assert code == 2 and text == "" and err.count("\n") == 1, err
    assert "singularity" not in err
    found = re.search(r"is out of the arm's reach \(no solution on any branch; \d+ such samples, out by up "
                      r"to ([\d.]+) m at sample 1999\): bring the path within reach", err)
    assert found, err
    assert float(found.group(1)) == pytest.approx(beyond, rel=5e-3)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.npz"]
