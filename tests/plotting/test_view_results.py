"""The result pages of the web view: ``library reuse --view`` and ``plan --view`` (simulated too)."""

from __future__ import annotations

import json
import re

import pytest

from .conftest import PRESS_PDDL

_FIGURE = re.compile(r'<script type="application/json" id="([\w-]+)-data">(.*?)</script>', re.S)


def figures(html: str) -> dict:
    """``{figure id: {"data", "layout"}}`` of a page, read back from its JSON blocks."""
    return {fid: json.loads(block) for fid, block in _FIGURE.findall(html)}


def test_reuse_view_draws_the_reproduction_over_the_skill(cli, view_library, tmp_path):
    db = tmp_path / "lib.db"
    db.write_bytes(view_library["path"].read_bytes())
    bowed = view_library["bowed"]
    code, out, err = cli("library", "reuse", db, "--skill", str(bowed), "--goal", "0.5,0.5,0.2",
                         "--obstacle", "sphere:0.2,0.2,0.1,0.05", "--view", tmp_path / "view", "--json")
    assert code == 0, err
    doc = json.loads(out)
    page = tmp_path / "view" / "reuse.html"
    assert doc["view"]["pages"] == {"reuse.html": str(page)} and doc["view"]["index"].endswith("index.html")
    html = page.read_text()
    assert f"<h1>Reuse of skill {bowed}</h1>" in html
    drawn = figures(html)["reuse"]["data"]
    legend = {t["name"] for t in drawn if t.get("showlegend", True)}
    assert {"reproduction", "adapted candidates", "stored primitives", "goal", "obstacle 1"} <= legend
    members = view_library["summary"]["skills"][bowed]["count"]
    assert sum(t["name"] == "stored primitives" for t in drawn) == members
    assert sum(t["name"] == "adapted candidates" for t in drawn) == len(doc["used"])
    assert '<a href="reuse.html">reuse of' in (tmp_path / "view" / "index.html").read_text()
    # the text report says where
    code, out, _ = cli("library", "reuse", db, "--skill", str(bowed), "--goal", "0.5,0.5,0.2", "--view",
                       tmp_path / "view")
    assert code == 0 and out.splitlines()[-1] == f"  wrote the view with the result: open {page}"


def test_a_view_folder_that_cannot_be_written_stops_the_reuse_before_any_output(cli, view_library, tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    code, out, err = cli("library", "reuse", view_library["path"], "--skill", "0", "--goal", "0.5,0.5,0.2",
                         "--out", tmp_path / "out.csv", "--view", tmp_path / "mine")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith("skillbank library reuse: error: view: folder ")
    assert "holds no skillbank view" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]


@pytest.fixture(scope="module")
def planned_view(data_dir, tmp_path_factory):
    """``plan --robot ur5e --simulate --view`` on the three-button demo's presses, past a wall."""
    pytest.importorskip("mujoco")  # the extra skillbank[sim]
    from skillbank.cli import main
    from skillbank.io import load
    from skillbank.pipeline import Library

    folder = tmp_path_factory.mktemp("plan")
    with Library(folder / "buttons.db") as lib:
        lib.add(load(data_dir / "seed" / "three_button_pressing_demo.h5"), segment=True, assign="none")
        for p in lib.primitives():
            if p.demo["position"][[0, -1], 2].max() < 0.15:  # from one button down to the next
                lib.label("press", primitive=p.id)
        lib.describe("press", PRESS_PDDL)
    down = [0.0, 1.0, 0.0, 0.0]
    scene = {"objects": {"b1": {"type": "button", "position": [-0.45, -0.2, 0.03], "orientation": down},
                         "b2": {"type": "button", "position": [-0.45, 0.2, 0.03], "orientation": down}},
             "obstacles": {"wall": "box:-0.6,-0.02,0.0,-0.3,0.02,0.25"}, "table": {"height": 0.0},
             "init": ["(free b1)", "(free b2)"], "goal": ["(pressed b2)"],
             "start": {"position": [-0.45, -0.2, 0.08], "orientation": down}}
    (folder / "scene.json").write_text(json.dumps(scene))
    code = main(["plan", str(folder / "buttons.db"), "--scene", str(folder / "scene.json"), "--robot", "ur5e",
                 "--simulate", "--view", str(folder / "view"), "--out", str(folder / "plan.csv")])
    assert code == 0
    return folder / "view"


def test_plan_view_shows_the_steps_joints_and_what_the_simulation_saw(planned_view, capsys):
    html = (planned_view / "plan.html").read_text()
    assert "<h1>Plan of 1 step(s)</h1>" in html and "(press b2)" in html
    assert '<table class="buttons">' in html and re.search(r"<td>b2</td><td>yes</td>", html)
    assert "<p>No unintended contact.</p>" in html
    drawn = figures(html)
    assert set(drawn) == {"plan", "joints", "buttons"}
    assert len(drawn["joints"]["data"]) == 6  # the UR5e's joints
    assert {t["name"] for t in drawn["buttons"]["data"]} == {"b1", "b2"}
    assert max(drawn["buttons"]["data"][1]["y"]) > 0.0  # b2 was pushed
    names = {t["name"] for t in drawn["plan"]["data"]}
    assert "1. (press b2)" in names and "obstacle wall" in names


def test_plan_view_in_the_browser(visit, planned_view):
    root = planned_view.as_uri() + "/"
    v = visit(root + "plan.html")
    assert v.ready == "1" and v.page.locator("div.figure canvas").count() >= 1
    assert [u for u in v.requests if not u.startswith(root)] == []
    assert v.console_errors() == [] and v.errors == []


def test_a_robosuite_scene_takes_no_view(cli, view_library, tmp_path):
    code, out, err = cli("plan", view_library["path"], "--scene", "robosuite:Stack3", "--simulate", "--view",
                         tmp_path / "view")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith("skillbank plan: error: --view: a robosuite scene runs robosuite's arm (--robot) "
                          "in its own")
    assert not (tmp_path / "view").exists()
