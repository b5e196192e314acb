"""The main demo job: a library built, clustered, labelled and reused, with figures and a summary."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from skillbank.experiments._library_demo import run_library_demo
from skillbank.pipeline import Library


def check_result(res, out):
    json.dumps(res)  # JSON-able
    assert Path(res["summary"]) == out / "summary.md" and Path(res["summary"]).is_file()
    assert json.loads((out / "summary.json").read_text())["n_demonstrations"] == res["n_demonstrations"]
    for fig in res["figures"].values():
        assert Path(fig).is_file() and Path(fig).stat().st_size > 10_000
    assert len(res["reuse"]) == 2
    for item in res["reuse"]:
        assert "error" not in item, item
        assert item["constraint_error"] < 1e-6 and not item["collision"]
    assert "majority" in Path(res["summary"]).read_text()
    # how long each part took, measured in the run, a line each in summary.md, and the total
    text = Path(res["summary"]).read_text()
    assert res["timing"] and all(row["seconds"] >= 0.0 for row in res["timing"])
    assert sum(row["seconds"] for row in res["timing"]) <= res["seconds"]
    timing = text.split("## Timing", 1)[1]
    for row in res["timing"]:
        assert f"| {row['part']} | {row['seconds']:.1f} |" in timing
    assert f"| **total** (start to summary) | **{res['seconds']:.1f}** |" in timing
    # one reproduction a UR5e executes, as CSV: pose, gripper and joints from t = 0
    ex = res["executable"]
    lines = Path(ex["csv"]).read_text().splitlines()
    # the law and limits it was timed for come first, as comment lines (docs/robots.md, "Time law")
    at = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    assert lines[0].startswith("# skillbank timing: ")
    header = lines[at].split(",")
    assert header[0] == "t" and "orientation_w" in header and "joints_shoulder_pan_joint" in header
    assert "gripper_0" in header or "gripper" in header
    rows = np.loadtxt(ex["csv"], delimiter=",", skiprows=at + 1)
    assert rows[0, 0] == 0.0 and ex["constraint_error"] < 1e-6 and ex["orientation_error"] < 1e-9
    assert ex["peak_joint_velocity"] <= 1.0 + 1e-9
    assert "reach_ur5e.csv" in Path(res["summary"]).read_text()
    # the library's web view, with the two reuses' pages linked from its index
    index = Path(res["view"])
    assert index == out / "view" / "index.html" and "view/index.html" in Path(res["summary"]).read_text()
    assert {"reuse-1.html", "reuse-2.html", "assets"} <= {p.name for p in index.parent.iterdir()}
    assert '<a href="reuse-1.html">' in index.read_text()
    # a task never demonstrated, planned and chained
    assert Path(res["planning"]).is_file() and "planning/summary.md" in Path(res["summary"]).read_text()


def _saved_figures(monkeypatch) -> dict:
    """Every figure the job saves, by file name."""
    saved, real = {}, Figure.savefig

    def spy(self, path, *args, **kwargs):
        name = Path(path).name  # figures are written to ".NAME.<random>.part.SUFFIX", then renamed NAME
        saved[name[1:].rsplit(".part", 1)[0].rsplit(".", 1)[0] if ".part" in name else name] = self
        return real(self, path, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", spy)
    return saved


def test_lasa_library_demo(tmp_path, capsys, monkeypatch):
    saved = _saved_figures(monkeypatch)
    res = run_library_demo(tmp_path, segmentation=False, composed=False)
    assert capsys.readouterr().err == ""  # no progress bar unless asked for
    check_result(res, tmp_path)
    labels = {r["label"] for r in res["skills"]}
    assert {"Angle", "CShape", "NShape", "WShape", "pick", "place", "return"} <= labels
    assert all(r["majority"] == 1.0 for r in res["skills"])
    wshape, place = res["reuse"]
    assert wshape["skill"] == "WShape" and "sphere" in wshape["task"] and len(wshape["used"]) == 3
    assert place["skill"] == "place" and len(place["used"]) == 1
    with Library(res["library"]) as lib:
        # 28 LASA drawings, 3 synthetic pick-and-place, 1 synthetic UR5e recording
        assert lib.summary()["n_demonstrations"] == res["n_demonstrations"] == 32
        ids = {p.id for p in lib.primitives(label="WShape", load=False)}
        assert set(wshape["used"]) <= ids
    # one panel per skill, each at its own scale: the 5 cm letters are not squeezed beside 0.4 m moves
    panels = {ax.get_title().split("\n")[0]: ax for ax in saved["clusters.png"].axes}
    assert set(panels) == {f"cluster {r['cluster']}: {r['label']}" for r in res["skills"]}
    letter, move = panels[next(k for k in panels if k.endswith("WShape"))], panels[
        next(k for k in panels if k.endswith("place"))]
    assert letter.name == "rectilinear" and move.name == "3d"
    assert np.ptp(letter.get_xlim()) < 0.1 < np.ptp(move.get_xlim())
    assert letter.get_xlabel() == "x (m)"
    # the reuse of 'place': its stored primitives alone on the left, the reproduction on the right
    left, right = saved["reuse_place.png"].axes
    assert "reproduction" not in [line.get_label() for line in left.get_lines()]
    for ax in (left, right):
        assert ax.get_xlabel() == "x (m)" and ax.get_zlabel() == "z (m)"
        assert {"start", "goal"} <= {t.get_text() for t in ax.get_legend().get_texts()}
    # a second run replaces the library rather than adding to it; this one shows its progress
    again = run_library_demo(tmp_path, segmentation=False, composed=False, progress=True)
    assert again["n_demonstrations"] == 32 and again["n_primitives"] == res["n_primitives"]
    assert [row["part"] for row in res["timing"]] == [
        "loading LASA", "adding demonstrations", "clustering", "labelling", "figure of the clusters",
        "reusing WShape", "reusing place", "executable reproduction (UR5e)", "web view of the library",
        "planning (tasks never demonstrated)"]
    err = capsys.readouterr().err
    for step in ("loading LASA", "adding demonstrations", "clustering", "labelling",
                 "figure of the clusters", "reusing WShape", "reusing place", "executable reproduction",
                 "web view of the library", "planning"):
        assert step in err, err
    # 4 steps to build the library, its figure, two reuses, the executable one, the web view, planning; no
    # segmentation
    assert "0/10 [00:00, loading LASA]" in err and "9/10" in err


def test_progress_steps_are_named_as_they_start(capsys):
    from skillbank.experiments._library_demo import _Steps

    step = _Steps(3, True)
    step("first")
    step("second")
    step.close()
    err = capsys.readouterr().err
    assert "0/3" in err and "first" in err and "1/3" in err and "second" in err
    assert "1/3 [00:00, first]" not in err  # a step's count is shown with its own name
    assert [row["part"] for row in step.timing] == ["first", "second"]
    quiet = _Steps(3, False)
    quiet("first")
    quiet.close()
    quiet.close()  # again: the last step is not counted twice
    assert capsys.readouterr().err == ""
    # timed whether the bar is shown or not
    assert [row["part"] for row in quiet.timing] == ["first"] and quiet.timing[0]["seconds"] >= 0.0


def test_reused_trajectory_meets_the_task(tmp_path):
    res = run_library_demo(tmp_path, segmentation=False, composed=False)
    with Library(res["library"]) as lib:
        from skillbank.experiments._library_demo import _goal_task

        task = _goal_task(lib, "place", "ja", np.array([0.08, -0.12, 0.05]), "x")
        out = lib.reuse("place", task.constraints, method="ja")
    Y = out.trajectory["position"]
    np.testing.assert_allclose(Y[-1], task.constraints.goal, atol=1e-9)
    np.testing.assert_allclose(Y[0], task.constraints.start, atol=1e-9)


def test_demo_with_segmentation_links_it(tmp_path):
    res = run_library_demo(tmp_path, composed=False)
    assert Path(res["segmentation"]).is_file()
    assert "segmentation/summary.md" in Path(res["summary"]).read_text()


def test_rail_library_demo(tmp_path, data_dir):
    res = run_library_demo(tmp_path, data=data_dir, segmentation=False, composed=False)
    check_result(res, tmp_path)
    skills = {r["label"] for r in res["skills"]}
    assert res["reuse"][0]["skill"] in skills
    assert res["reuse"][1]["skill"] == "press-button"
    assert res["n_demonstrations"] == 180  # 179 RAIL reaching, pushing, pressing + three-button
    # elastic clustering separates the three RAIL classes, each cluster at least 85 % one class
    assert sorted(r["label"] for r in res["skills"]) == ["pressing", "pushing", "reaching"]
    assert all(r["majority"] >= 0.85 for r in res["skills"])


def test_bad_data_folder(tmp_path):
    with pytest.raises(ValueError, match=r"data: expected a folder with rail/ and seed/"):
        run_library_demo(tmp_path / "out", data=tmp_path, segmentation=False, composed=False)
