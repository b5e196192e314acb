"""Two arms: robosuite's TwoArmLift recorded with both arms, read one demonstration per arm, and run with
both arms stepped together in new scenes (real episodes on two Pandas facing each other)."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

pytest.importorskip("robosuite")  # the extra skillbank[sim]

from skillbank.cli import main  # noqa: E402
from skillbank.core import Demonstration  # noqa: E402
from skillbank.io import read_robomimic, split_arms  # noqa: E402
from skillbank.pipeline import Library  # noqa: E402
from skillbank.simulation import evaluate, record  # noqa: E402


@pytest.fixture(scope="module")
def lift(tmp_path_factory):
    """Two scripted TwoArmLift episodes (seed 0) and the library of their four arm demonstrations."""
    folder = tmp_path_factory.mktemp("two_arms")
    out = folder / "lift.hdf5"
    report = record("robosuite:TwoArmLift", episodes=2, out=out, seed=0, robot="panda")
    with Library(folder / "lift.db") as lib:
        lib.add_files([out])
        lib.cluster()
    return out, folder / "lift.db", report


def test_a_two_arm_recording_is_read_as_one_demonstration_per_arm(lift):
    out, _, report = lift
    assert report["episodes"] == 2
    with h5py.File(out) as h5:
        g = h5["data/demo_0"]
        assert g["actions"].shape[1] == 14  # both arms' OSC_POSE and gripper, side by side
        both = g["obs/robot1_eef_pos"][:]
    demos = read_robomimic(out)
    arms = [(d.metadata["arm_index"], d.metadata["episode"]) for d in demos]
    assert arms == [(0, 0), (1, 0), (0, 1), (1, 1)]
    for d in demos:
        assert d.metadata["arm"] == "Panda" and d.metadata["pose_of"] == "panda_hand:grip_site"
        assert d["actions"].shape[1] == 7 and {"pot_pos", "pot_quat"} <= set(d.streams)
        assert not any(s.startswith(f"robot{1 - d.metadata['arm_index']}_") for s in d.streams)
    np.testing.assert_array_equal(demos[1]["position"], both)
    # each arm closes its gripper on its own handle and lifts: the two tools end 0.3 m apart across the pot
    ends = [d["position"][-1] for d in demos[:2]]
    assert 0.25 < np.linalg.norm(ends[0] - ends[1]) < 0.4


def test_split_arms_refuses_actions_that_do_not_split():
    t = np.arange(2.0)
    q = np.tile([0.0, 0.0, 0.0, 1.0], (2, 1))
    demo = Demonstration(t, {"position": np.zeros((2, 3)), "orientation": q,
                             "robot1_eef_pos": np.ones((2, 3)), "robot1_eef_quat": q,
                             "actions": np.zeros((2, 13))})
    with pytest.raises(ValueError, match="13 columns do not split among the recording's 2 arms"):
        split_arms(demo)
    del demo.streams["robot1_eef_quat"]
    demo.streams["actions"] = np.zeros((2, 14))
    with pytest.raises(ValueError, match="arm 1: the recording has no robot1_eef_quat"):
        split_arms(demo)


def test_both_arms_lift_the_pot_in_new_scenes(lift):
    _, library, _ = lift
    report = evaluate(library, "robosuite:TwoArmLift", robot="panda", episodes=2, seed=900)
    assert report["successes"] == 2, [e.get("failure") for e in report["per_episode"]]
    for row in report["per_episode"]:
        assert len(row["sources"]) == 2  # one demonstration per arm, of one recording
    assert any("not used with 2 arms" in note for note in report["notes"])


def test_a_library_missing_an_arm_of_its_recording_is_refused(lift, tmp_path):
    out, _, _ = lift
    with Library(tmp_path / "one_arm.db") as lib:
        lib.add_many([d for d in read_robomimic(out) if d.metadata["arm_index"] == 1])
        lib.cluster()
    with pytest.raises(ValueError, match=r"are of arm\(s\) \[1\] of a recording of 2 arms"):
        evaluate(tmp_path / "one_arm.db", "robosuite:TwoArmLift", robot="panda", episodes=1, seed=900)


def test_library_list_shows_each_primitives_arm_also_after_export_and_import(lift, capsys, tmp_path):
    _, library, _ = lift
    assert main(["library", "list", str(library)]) == 0
    out = capsys.readouterr().out
    assert "demonstration 1 (arm 0)," in out and "demonstration 2 (arm 1)," in out
    assert "ends at pot (0.1" in out  # a grasp of the pot's handle, 17 cm from the pot's origin
    copy = tmp_path / "copy.db"
    assert main(["library", "export", str(library), str(tmp_path / "exported")]) == 0
    assert main(["library", "init", str(copy)]) == 0
    assert main(["library", "import", str(copy), str(tmp_path / "exported")]) == 0
    capsys.readouterr()
    assert main(["library", "list", str(copy)]) == 0
    again = capsys.readouterr().out
    assert again.splitlines()[1:] == out.splitlines()[1:]  # all but the first line, which names the file


def test_a_handover_is_recorded_the_giving_hand_opening_only_once_the_taking_hand_holds(tmp_path):
    out = tmp_path / "handover.hdf5"
    assert record("robosuite:TwoArmHandover", episodes=1, out=out, seed=0, robot="panda")["episodes"] == 1
    giver, taker = read_robomimic(out)
    assert (giver.metadata["arm_index"], taker.metadata["arm_index"]) == (0, 1)
    closed = [d["actions"][:, 6] > 0 for d in (giver, taker)]
    taken = int(np.argmax(closed[1]))  # the taking hand closes
    held = np.flatnonzero(closed[0])
    let_go = int(held[-1]) + 1  # the giving hand opens for the last time
    assert int(held[0]) < taken < let_go
    # the hammer goes from the table into the taking hand, well above where it lay
    assert taker["hammer_pos"][-1, 2] - taker["hammer_pos"][0, 2] > 0.1


def test_the_web_view_shows_each_members_arm_and_what_it_acts_on(lift):
    from skillbank.plotting._view import LibraryView

    _, library, _ = lift
    with Library(library, readonly=True) as lib:
        view = LibraryView(lib)
        pages = [view.render(name) for name in view.pages() if name.startswith("skill-")]
    html = "\n".join(p for p in pages if p)
    assert "<th>arm</th>" in html and "<th>acts on</th>" in html
    assert "<td>1</td>" in html and "ends at pot (0.1" in html and "carries pot" in html


def test_a_two_arm_recording_in_robosuites_raw_format_is_read_as_the_same_arms(lift, tmp_path):
    from skillbank.io import read_robosuite_raw
    from skillbank.io._robosuite_raw import WORLD_TOLERANCE

    out, _, _ = lift
    raw = tmp_path / "raw.hdf5"
    with h5py.File(out) as src, h5py.File(raw, "w") as h5:  # robosuite's collection layout: states only
        data = h5.create_group("data")
        data.attrs["env"] = "TwoArmLift"
        data.attrs["env_info"] = json.dumps({"env_name": "TwoArmLift", "robots": ["Panda", "Panda"],
                                             "env_configuration": "opposed"})
        g = data.create_group("demo_1")
        g.create_dataset("states", data=src["data/demo_0/states"][:])
        g.create_dataset("actions", data=src["data/demo_0/actions"][:])
    replayed = read_robosuite_raw(raw)
    recorded = read_robomimic(out, episodes=[0])
    assert [d.metadata["arm_index"] for d in replayed] == [0, 1]
    for a, b in zip(replayed, recorded, strict=True):
        assert a.metadata["arm"] == "Panda" and a.metadata["pose_of"] == b.metadata["pose_of"]
        np.testing.assert_array_equal(a["actions"], b["actions"])
        # a state set and read again is the state the step left, to robosuite's own replay (within the
        # reader's world tolerance, a millimetre)
        for stream in ("position", "gripper", "pot_pos"):
            np.testing.assert_allclose(a[stream], b[stream], atol=WORLD_TOLERANCE)
        turned = 2 * np.arccos(np.clip(np.abs(np.sum(a["orientation"] * b["orientation"], axis=1)), 0, 1))
        assert np.degrees(turned).max() < 0.5


def test_the_cli_refuses_a_library_missing_an_arm_in_one_line(lift, tmp_path, capsys):
    out, _, _ = lift
    with Library(tmp_path / "one_arm.db") as lib:
        lib.add_many([d for d in read_robomimic(out) if d.metadata["arm_index"] == 0])
    before = sorted(p.name for p in tmp_path.iterdir())
    code = main(["sim", "evaluate", str(tmp_path / "one_arm.db"), "--env", "robosuite:TwoArmLift",
                 "--robot", "panda", "--episodes", "1", "--seed", "900"])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "are of arm(s) [0] of a recording of 2 arms; add every arm's demonstration" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_a_recordings_arms_said_in_invalid_json_are_one_clear_error(lift, tmp_path):
    import shutil

    from skillbank.io import FormatError

    out, _, _ = lift
    bad = tmp_path / "bad.hdf5"
    shutil.copy(out, bad)
    with h5py.File(bad, "r+") as h5:
        h5["data"].attrs["robots"] = "[{not json"
    with pytest.raises(FormatError, match=r"invalid JSON in data.attrs\['robots'\]"):
        read_robomimic(bad)
