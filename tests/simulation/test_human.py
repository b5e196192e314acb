"""``skillbank sim record --style human``: a person-like demonstrator in robosuite's raw collection format.

Real robosuite episodes (one short Lift each on the Panda, as the real teleoperated file): the file's
layout is the real file's, the episode succeeds when its states are replayed, and its commands look
like a person's at a keyboard.
"""

from __future__ import annotations

import datetime
import json

import h5py
import numpy as np
import pytest

pytest.importorskip("robosuite")  # the extra skillbank[sim]

from skillbank.simulation import HumanDemonstrator, command_statistics, record_human  # noqa: E402

WHEN = datetime.datetime(2026, 12, 6, 9, 5, 7)
SEED = 4
#: A person who closes too early on the first grasp, sees the cube stay, and tries again.
RETRYING = {"retry_probability": 1.0}


@pytest.fixture(scope="module")
def lift(tmp_path_factory):
    out = tmp_path_factory.mktemp("human") / "lift_human.hdf5"
    report = record_human("robosuite:Lift", episodes=1, out=out, seed=SEED, robot="Panda", max_tries=2,
                          demonstrator=HumanDemonstrator(**RETRYING), when=WHEN)
    return out, report


@pytest.fixture(scope="module")
def replay():
    """``replay(states) -> (tool positions, cube positions, success at the last state)``: robosuite's Lift."""
    from skillbank.simulation._human_file import quiet_robosuite

    with quiet_robosuite():
        import robosuite

        env = robosuite.make("Lift", robots=["Panda"], has_renderer=False, has_offscreen_renderer=False,
                             use_camera_obs=False, ignore_done=True)
        env.reset()

    def run(states):
        tool, cube = [], []
        for s in states:
            env.sim.set_state_from_flattened(s)
            env.sim.forward()
            obs = env._get_observations(force_update=True)
            tool.append(np.array(obs["robot0_eef_pos"]))
            cube.append(np.array(obs["cube_pos"]))
        return np.array(tool), np.array(cube), bool(env._check_success())

    yield run, env.sim.get_state().flatten().size
    env.close()


def _contents(path) -> dict:
    with h5py.File(path, "r") as h5:
        found = {}
        h5.visititems(lambda name, item: found.__setitem__(
            name, (item[()].tobytes() if isinstance(item, h5py.Dataset) else None, dict(item.attrs))))
        found["/"] = dict(h5.attrs)
    return found


def _runs(actions) -> tuple:
    """Where the motion commands (any of the first six columns) start and end (inclusive)."""
    motion = np.any(np.abs(actions[:, :6]) > 0, axis=1)
    starts = np.flatnonzero(motion & ~np.r_[False, motion[:-1]])
    ends = np.flatnonzero(motion & ~np.r_[motion[1:], False])
    return motion, starts, ends


def test_the_file_has_the_real_files_layout(lift, replay, data_dir):
    out, report = lift
    _, size = replay
    assert report == {"env": "robosuite:Lift", "style": "human", "episodes": 1, "tried": report["tried"],
                      "seed": SEED, "out": str(out), "samples": report["samples"], "robot": "Panda"}
    with h5py.File(data_dir / "human" / "lift_panda_teleop.hdf5", "r") as real, h5py.File(out, "r") as h5:
        assert sorted(h5.keys()) == sorted(real.keys()) == ["data"]
        assert sorted(h5["data"].attrs) == sorted(real["data"].attrs) == [
            "date", "env", "env_info", "repository_version", "time"]
        assert h5["data"].attrs["env"] == real["data"].attrs["env"] == "Lift"
        info, real_info = (json.loads(f["data"].attrs["env_info"]) for f in (h5, real))
        assert sorted(info) == sorted(real_info) == ["controller_configs", "env_name", "robots"]
        assert info["robots"] == ["Panda"] and info["env_name"] == "Lift"
        assert info["controller_configs"]["body_parts"]["right"]["type"] == "OSC_POSE"
        assert h5["data"].attrs["date"] == "12-6-2026" and h5["data"].attrs["time"] == "9:5:7"
        assert list(h5["data"].keys()) == ["demo_1"]  # numbered from 1, as robosuite's
        demo, real_demo = h5["data/demo_1"], real["data/demo_1"]
        assert sorted(demo.keys()) == sorted(real_demo.keys()) == ["actions", "states"]
        assert sorted(demo.attrs) == sorted(real_demo.attrs) == ["model_file"]
        assert demo.attrs["model_file"].startswith("<mujoco model=")
        n = demo["actions"].shape[0]
        assert report["samples"] == n
        assert demo["actions"].shape == (n, 7)
        assert demo["states"].shape == (n, size) == (n, real_demo["states"].shape[1])
        assert demo["states"].dtype == demo["actions"].dtype == np.float64
        assert np.all(np.diff(demo["states"][:, 0]) > 0)  # the state's first entry is MuJoCo's time


def test_the_episode_succeeds_when_its_states_are_replayed(lift, replay):
    out, _ = lift
    run, _ = replay
    with h5py.File(out, "r") as h5:
        states = h5["data/demo_1/states"][()]
    tool, cube, success = run(states)
    assert success  # the environment's own check at the last state
    assert cube[-1, 2] - cube[0, 2] > 0.03
    assert cube[0, 2] - cube[20, 2] > 0.005  # the cube settles at reset, before the person moves


def test_the_real_files_commands_are_keyboard_pulses(data_dir):
    """The statistics docs/simulation.md quotes for the people's file."""
    with h5py.File(data_dir / "human" / "lift_panda_teleop.hdf5", "r") as h5:
        stats = [command_statistics(h5["data"][f"demo_{k}"]["actions"][()]) for k in (1, 2, 3)]
    assert [s["steps"] for s in stats] == [482, 510, 392]
    assert [s["bursts"] for s in stats] == [45, 47, 34]
    assert [round(s["idle"], 3) for s in stats] == [0.907, 0.908, 0.913]
    assert [s["gap_max"] for s in stats] == [58, 67, 56]
    assert [s["closes"] for s in stats] == [1, 1, 1]
    assert [s["turn_taps"] for s in stats] == [4, 12, 0]
    assert [s["first_key"] for s in stats] == [27, 43, 147]


def test_command_statistics_refuses_what_is_not_actions():
    with pytest.raises(ValueError, match=r"actions: expected an array \(n, 7\), got shape \(3, 6\)"):
        command_statistics(np.zeros((3, 6)))


def test_the_commands_are_a_persons_at_a_keyboard(lift, replay):
    out, _ = lift
    run, _ = replay
    with h5py.File(out, "r") as h5:
        actions, states = h5["data/demo_1/actions"][()], h5["data/demo_1/states"][()]
    stats = command_statistics(actions)
    assert stats["idle"] >= 0.6  # most steps carry no motion command
    assert stats["bursts"] >= 10 and stats["corrections"] >= 1 and stats["closes"] == 2
    motion, starts, ends = _runs(actions)
    assert np.all(np.count_nonzero(actions[motion, :6], axis=1) == 1)  # one key at a time
    assert set(np.unique(np.abs(actions[:, :6]))) <= {0.0, 1.0, 0.6}  # quantised: a key is pressed or not
    assert set(np.unique(actions[:, 6])) == {-1.0, 1.0}
    grip = actions[:, 6]
    closes = np.flatnonzero(np.diff(grip) > 0) + 1
    opens = np.flatnonzero(np.diff(grip) < 0) + 1
    # it closed too early, saw the cube stay, opened and took it again
    assert len(closes) == 2 and len(opens) == 1 and closes[0] < opens[0] < closes[1]
    # at least one stop of half a second inside the approach (between the first key and the first close)
    gaps = starts[1:] - ends[:-1] - 1
    inside = ends[:-1] < closes[0]
    assert np.any(gaps[inside] >= 10)
    # the grasp that held is 1-3 cm off the cube's centre (horizontally, 10 steps after the fingers closed)
    tool, cube, _ = run(states[: closes[-1] + 11])
    offset = np.linalg.norm((tool[-1] - cube[-1])[:2])
    assert 0.01 <= offset <= 0.03


def test_the_same_seed_gives_the_same_file(lift, tmp_path):
    out, _ = lift
    again = tmp_path / "again.hdf5"
    record_human("robosuite:Lift", episodes=1, out=again, seed=SEED, robot="Panda", max_tries=2,
                 demonstrator=HumanDemonstrator(**RETRYING), when=WHEN)
    assert _contents(again) == _contents(out)


def test_the_command_records_and_refuses_an_existing_file(cli, tmp_path):
    out = tmp_path / "lift.hdf5"
    code, stdout, err = cli("sim", "record", "robosuite:Lift", "--style", "human", "--out", out,
                            "--episodes", 1, "--seed", 7, "--robot", "Panda", "--json")
    assert code == 0, err
    report = json.loads(stdout)
    assert report["style"] == "human" and report["episodes"] == 1 and out.is_file()
    assert "robosuite" not in err  # its log is off without -v
    with h5py.File(out, "r") as h5:
        assert h5["data/demo_1/actions"].shape[1] == 7
    before = out.read_bytes()
    code, stdout, err = cli("sim", "record", "robosuite:Lift", "--style", "human", "--out", out,
                            "--episodes", 1)
    assert code == 2 and err.count("\n") == 1 and "exists" in err
    assert out.read_bytes() == before and not (tmp_path / "lift.hdf5.part").exists()


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"episodes": 0}, "episodes: expected an integer > 0"),
    ({"seed": -1}, "seed: expected an integer"),
    ({"robot": "Puma"}, "robot: expected one of"),
    ({"env": "robosuite:Wipe"}, "env: the recorder knows"),
    ({"env": "Lift"}, "env: expected robosuite:TASK"),
    ({"max_tries": 0}, "max_tries: expected an integer > 0"),
    ({"demonstrator": "keyboard"}, "demonstrator: expected a HumanDemonstrator"),
    ({"when": "today"}, "when: expected a datetime"),
])
def test_bad_arguments_are_refused_before_robosuite_starts(tmp_path, kwargs, match):
    args = {"env": "robosuite:Lift", "episodes": 1, "out": tmp_path / "x.hdf5", **kwargs}
    with pytest.raises(ValueError, match=match):
        record_human(args.pop("env"), **args)
    assert not list(tmp_path.iterdir())


def test_an_existing_file_is_refused(tmp_path):
    out = tmp_path / "x.hdf5"
    out.write_text("mine")
    with pytest.raises(ValueError, match="out: .* exists; give a new file"):
        record_human("robosuite:Lift", episodes=1, out=out)
    assert out.read_text() == "mine"


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"pulse": 0}, "pulse: expected a number in"),
    ({"pulse_steps": 0}, "pulse_steps: expected an integer > 0"),
    ({"gap": (3, 1)}, "gap: expected low <= high"),
    ({"gap": 2}, r"gap: expected a pair \(low, high\)"),
    ({"pause_probability": 1.5}, "pause_probability: expected a number in"),
    ({"overshoot": -0.01}, "overshoot: expected a number in"),
    ({"off_centre": (0.01, 0.2)}, "off_centre: expected two numbers in"),
    ({"retry_probability": float("nan")}, "retry_probability: expected a number in"),
    ({"random_state": -3}, "random_state: expected a non-negative integer"),
])
def test_bad_habits_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        HumanDemonstrator(**kwargs)


def test_the_habits_are_stored_unchanged():
    person = HumanDemonstrator(gap=(2, 3), off_centre=(0.015, 0.025), random_state=5)
    assert person.gap == (2, 3) and person.off_centre == (0.015, 0.025) and person.random_state == 5
    assert HumanDemonstrator().pulse_steps == 1


def test_skillbanks_reader_takes_the_file_and_a_library_cuts_one_reach(lift, replay, tmp_path):
    """The recorded file is what people record: `io.read_robosuite_raw` replays it (its world agrees with
    today's), its tool is the simulator's, and `library add` takes it."""
    from skillbank.io import detect_format, read_robosuite_raw
    from skillbank.pipeline import Library

    out, _ = lift
    run, _ = replay
    assert detect_format(out) == "robosuite-raw"
    (demo,) = read_robosuite_raw(out)
    with h5py.File(out, "r") as h5:
        tool, _, _ = run(h5["data/demo_1/states"][()])
    np.testing.assert_allclose(demo["position"], tool, atol=1e-9)
    assert demo.metadata["arm"] == "Panda" and demo.metadata["pose_of"] == "panda_hand:grip_site"
    assert demo.metadata["world_check"]["agrees"]
    with Library(tmp_path / "lib.sqlite", create=True) as lib:
        lib.add_files([out])
        prims = sorted(lib.primitives(), key=lambda p: p.start)
    # the person's halting approach, with its pauses and the grasp that closed on nothing and opened
    # again, is one reach; the lift is one carry, cut where the fingers closed on the cube
    from skillbank.segmentation import MultimodalSegmenter, demonstration_phases

    phases = demonstration_phases(demo)
    assert [(p.kind, p.object) for p in phases] == [("reach", "cube"), ("carry", "cube")]
    assert [(p.start, p.stop) for p in prims] == [(p.start, p.stop) for p in phases]
    commands = demo["actions"][:phases[0].stop, 6]
    assert (np.diff(np.sign(commands)) > 0).sum() == 2  # closed twice before the carry: the retry
    assert MultimodalSegmenter(phases=False).fit(demo).result_.n_segments > 4  # the stops cut it
