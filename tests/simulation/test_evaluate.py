"""``skillbank sim evaluate``: a library's skills run closed loop in robosuite scenes they were not shown.

Real robosuite episodes (short ones): three recorded Lift demonstrations, then new placements drawn by
robosuite's own sampler, success by the environment's own ``_check_success()``.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from scipy.stats import binomtest

pytest.importorskip("robosuite")  # the extra skillbank[sim]

from skillbank.cli import main  # noqa: E402
from skillbank.pipeline import Library  # noqa: E402
from skillbank.selection import Relation, compose  # noqa: E402
from skillbank.simulation import REASONS, binomial_interval, evaluate  # noqa: E402

from .conftest import recorded_lift  # noqa: E402


@pytest.fixture(scope="module")
def lift(tmp_path_factory):
    db = recorded_lift(tmp_path_factory.mktemp("lift_eval"), episodes=3)
    with Library(db, readonly=True) as lib:
        starts = [lib.demonstration(i)["cube_pos"][0, :2] for i in lib.demonstration_ids()]
    return db, np.array(starts)


def test_a_lift_at_a_placement_no_demonstration_had_succeeds(lift):
    db, starts = lift
    report = evaluate(db, "robosuite:Lift", episodes=2, seed=500, placement=0.12)
    assert report["episodes"] == 2 and [r["seed"] for r in report["per_episode"]] == [500, 501]
    assert report["successes"] == 2 and report["success_rate"] == 1.0, report["per_episode"]
    assert report["interval"] == pytest.approx(list(binomial_interval(2, 2)))
    for row in report["per_episode"]:
        assert row["success"] and "failure" not in row and 0 < row["steps"] < 1000
        assert row["source"] in (1, 2, 3)
        # where no demonstration had its cube: farther from each than robosuite's default range allows
        assert np.linalg.norm(starts - row["objects"]["cube"][:2], axis=1).min() > 0.03, (starts, row)
    assert report["timing"]["segments"] >= 4 and report["timing"]["adapt_seconds"] > 0


def test_the_placement_is_drawn_from_the_seed_and_widened(lift):
    """The same seed gives the same scene and the same run (the same steps to the sample); another seed,
    another scene."""
    db, starts = lift
    a = evaluate(db, "robosuite:Lift", episodes=1, seed=42, placement=0.15)
    b = evaluate(db, "robosuite:Lift", episodes=1, seed=42, placement=0.15)
    assert a["per_episode"] == b["per_episode"]
    c = evaluate(db, "robosuite:Lift", episodes=1, seed=43, placement=0.15)
    assert c["per_episode"][0]["objects"] != a["per_episode"][0]["objects"]


def test_open_loop_replay_misses_a_cube_that_moved_and_says_where(lift):
    """The baseline that replays the source's actions reaches where the source's cube was: the segment
    that should carry the cube ends without it, and the failure names that segment and why."""
    db, _ = lift
    report = evaluate(db, "robosuite:Lift", episodes=3, seed=700, placement=0.15, method="replay")
    failed = [r for r in report["per_episode"] if not r["success"]]
    assert failed, report["per_episode"]
    for row in failed:
        f = row["failure"]
        assert f["reason"] in ("missed grasp", "misplaced") and f["reason"] in REASONS
        assert isinstance(f["segment"], int) and isinstance(f["primitive"], int) and f["detail"]
    assert any(r["failure"]["reason"] == "missed grasp"
               and "cube stayed where it was" in r["failure"]["detail"] for r in failed)


def test_an_episode_out_of_steps_is_a_timeout(lift):
    db, _ = lift
    report = evaluate(db, "robosuite:Lift", episodes=1, seed=3, horizon=40)
    row = report["per_episode"][0]
    assert not row["success"] and row["failure"]["reason"] == "timeout" and row["steps"] == 40


def test_the_baselines_run_the_same_episodes(lift):
    """Same seeds, same scenes: what differs between methods is only how the segments are adapted."""
    db, _ = lift
    scenes = {}
    for method in ("lte", "rigid", "replay"):
        report = evaluate(db, "robosuite:Lift", episodes=2, seed=500, placement=0.12, method=method)
        assert report["method"] == method
        scenes[method] = [(r["seed"], r["objects"], r["source"]) for r in report["per_episode"]]
    assert scenes["lte"] == scenes["rigid"] == scenes["replay"]


def test_the_wilson_interval_is_scipys():
    for k, n in [(0, 10), (3, 10), (10, 10), (47, 50)]:
        ci = binomtest(k, n).proportion_ci(method="wilson")
        assert binomial_interval(k, n) == pytest.approx((ci.low, ci.high), abs=1e-12)


def test_the_command_prints_json_with_every_episode(lift, capsys):
    db, _ = lift
    assert main(["sim", "evaluate", str(db), "--env", "robosuite:Lift", "--episodes", "1", "--seed", "9",
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert {"env", "episodes", "successes", "success_rate", "per_episode"} <= set(doc)
    assert doc["env"] == "robosuite:Lift" and len(doc["per_episode"]) == 1


def test_the_command_says_what_failed_in_words(lift, capsys):
    db, _ = lift
    assert main(["sim", "evaluate", str(db), "--env", "robosuite:Lift", "--episodes", "1", "--seed", "3",
                 "--horizon", "40"]) == 0
    out = capsys.readouterr().out
    assert "0 of 1 episodes of robosuite:Lift succeeded" in out and "timeout" in out


@pytest.mark.parametrize("argv, match", [
    (["--env", "Lift"], r"env: expected robosuite:TASK, got 'Lift'"),
    (["--env", "robosuite:Nope"], r"env: robosuite has no task 'Nope'"),
    (["--env", "robosuite:Lift", "--method", "magic"], r"method: expected one of"),
    (["--env", "robosuite:Lift", "--placement", "-0.1"], r"placement"),
    (["--env", "robosuite:Lift", "--episodes", "0"], r"episodes"),
    (["--env", "robosuite:Lift", "--order", "Milk"],
     r"order: the library's demonstrations move no object \['Milk'\]; they move \['cube'\]"),
    (["--env", "robosuite:Stack"], r"the environment shows no pose of the library's object\(s\) \['cube'\]; "
                                   r"evaluate the library in the task it was recorded in"),
])
def test_bad_input_is_one_line(lift, capsys, argv, match):
    db, _ = lift
    assert main(["sim", "evaluate", str(db), *argv]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and re.search(match, err), err


def test_a_library_without_object_poses_is_refused(tmp_path, capsys):
    db = tmp_path / "plain.db"
    t = np.linspace(0.0, 2.0, 200)
    demo = np.column_stack([t, np.sin(t), 0 * t])
    path = tmp_path / "d.csv"
    np.savetxt(path, np.column_stack([t, demo]), delimiter=",", header="t,x,y,z", comments="")
    with Library(db) as lib:
        lib.add_files([path])
    assert main(["sim", "evaluate", str(db), "--env", "robosuite:Lift"]) == 2
    err = capsys.readouterr().err
    assert "records no object poses" in err and "sim record" in err and len(err.strip().splitlines()) == 1


def test_what_each_primitive_acts_on_is_listed_and_travels_with_the_library(lift, tmp_path, capsys):
    """Found when the demonstrations were added, kept with them: ``library list`` shows it, and a library
    exported and imported elsewhere lists the same."""
    db, _ = lift
    assert main(["library", "list", str(db), "--json"]) == 0
    prims = json.loads(capsys.readouterr().out)["primitives"]
    acts = [p["acts_on"] for p in prims]
    assert all(a is None or a["object"] == "cube" for a in acts)
    assert any(a is not None and a["moves_with"] for a in acts)  # the lift carries the cube
    assert any(a is not None and not a["moves_with"] and a["distance"] < 0.03 for a in acts)  # the grasp
    # the stored relative pose of the grasp, put on the cube where it was, is the recorded grasp pose
    with Library(db) as lib:
        for p, a in zip(lib.primitives(), acts, strict=True):
            if a is None:
                continue
            relation = Relation.from_dict(a)
            position, orientation = compose(relation, p.demo["cube_pos"][-1], p.demo["cube_quat"][-1])
            assert np.linalg.norm(position - p.demo["position"][-1]) < 1e-3
            assert abs(abs(float(orientation @ p.demo["orientation"][-1])) - 1.0) < 1e-6
    assert main(["library", "list", str(db)]) == 0
    text = capsys.readouterr().out
    assert "carries cube" in text and "ends at cube" in text
    assert main(["library", "export", str(db), str(tmp_path / "out")]) == 0
    assert main(["library", "import", str(tmp_path / "copy.db"), str(tmp_path / "out")]) == 0
    capsys.readouterr()
    assert main(["library", "list", str(tmp_path / "copy.db"), "--json"]) == 0
    assert [p["acts_on"] for p in json.loads(capsys.readouterr().out)["primitives"]] == acts


def _segment(grip_at_start):
    from types import SimpleNamespace

    demo = {"actions": np.array([[0.0] * 6 + [grip_at_start], [0.0] * 6 + [-1.0]])}
    relation = SimpleNamespace(object="milk", moves_with=True)
    return SimpleNamespace(primitive=SimpleNamespace(demo=demo), relation=relation, scene=lambda name: "Milk")


@pytest.mark.parametrize(("grip", "reason"), [(1.0, "missed grasp"), (-1.0, None)])
def test_an_object_left_behind_is_a_missed_grasp_only_when_the_gripper_held_it(grip, reason):
    """A segment whose demonstration carried the milk (it moved with the tool) and whose tool rose 0.1 m
    without it: a missed grasp when the segment began with the gripper closed; nothing when it began
    open, a retreat whose demonstration dragged the milk up while the fingers opened."""
    from types import SimpleNamespace

    from skillbank.simulation._evaluate import _check

    before = {"Milk_pos": np.array([0.0, 0.15, 0.885]), "robot0_eef_pos": np.array([0.0, 0.15, 0.915])}
    after = {"Milk_pos": before["Milk_pos"], "robot0_eef_pos": before["robot0_eef_pos"] + [0.0, 0.0, 0.1]}
    found = _check(_segment(grip), before, SimpleNamespace(obs=after))
    assert (found if found is None else found[0]) == reason


def test_the_gripper_acts_once_the_tool_is_where_the_path_says(lift, monkeypatch):
    """On a fast descent the controller trails its commands by centimetres: fingers closed on the path's
    time but short of the cube would push it. Every change of the gripper's command is given with the
    tool within ARRIVE of the pose it belongs to (2.2 cm short here when the path's time decided)."""
    from skillbank.simulation import _evaluate

    changes = []
    step = _evaluate._Episode.step

    def watched(self, target, quat=None, grip=None, posture=None):
        if grip is not None and grip != self.driver.grip:
            changes.append(float(np.linalg.norm(np.asarray(target) - self.obs["robot0_eef_pos"])))
        step(self, target, quat, grip, posture)

    monkeypatch.setattr(_evaluate._Episode, "step", watched)
    db, _ = lift
    report = evaluate(db, "robosuite:Lift", episodes=1, seed=500, placement=0.12)
    assert report["successes"] == 1 and changes, report["per_episode"]
    assert max(changes) < _evaluate.ARRIVE, changes


def test_the_horizon_follows_the_longest_demonstration_of_each_part(lift):
    """Issue 42: a person's demonstration is longer than robosuite's default 1000 steps. The default horizon
    is what the executor may need for the longest demonstration of each part: its samples, up to a second to
    arrive and a second before each gripper change per segment, and a last second to settle."""
    from types import SimpleNamespace

    from skillbank.simulation._evaluate import DEFAULT_HORIZON, SETTLE, _horizon

    def source(*lengths):
        segs = [SimpleNamespace(primitive=SimpleNamespace(demo=SimpleNamespace(n_steps=n))) for n in lengths]
        return SimpleNamespace(segments=segs)

    short = {("cube",): [source(100, 50), source(120)]}
    assert _horizon(short) == DEFAULT_HORIZON
    long = {("can",): [source(3000, 500), source(100)], ("milk",): [source(2000)]}
    assert _horizon(long) == SETTLE + (3500 + 2 * 40) + (2000 + 40)
    db, _ = lift
    report = evaluate(db, "robosuite:Lift", episodes=1, seed=3, horizon=40)
    assert report["horizon"] == 40  # as asked


def test_an_object_is_in_the_hand_while_its_distance_to_the_tool_holds():
    """The let-go is aimed again only from an object still in the hand: one that slid a centimetre is,
    one that fell 20 cm is not (the arm would swing after it)."""
    from skillbank.simulation._evaluate import _in_hand

    held = np.array([0.0, 0.0, 0.05])  # 5 cm out along the tool's z when the carry began
    obs = {"robot0_eef_pos": np.array([0.1, 0.2, 1.0]), "Can_pos": np.array([0.1, 0.2, 0.94])}
    assert _in_hand(obs, "Can", held)
    obs["Can_pos"] = np.array([0.1, 0.2, 0.8])
    assert not _in_hand(obs, "Can", held)
