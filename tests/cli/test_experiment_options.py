"""Every option of ``experiment unload|stack3|rail`` is checked before anything is recorded or read (41)."""

from __future__ import annotations

import pytest

import skillbank.experiments._composition as composition
from skillbank.experiments import composition_experiment
from skillbank.experiments._composition import check_options


@pytest.fixture
def no_recording(monkeypatch):
    """Recording (tens of seconds a task in robosuite) fails the test if it starts."""
    def refuse(*args, **kwargs):
        raise AssertionError("recorded before the options were checked")

    monkeypatch.setattr(composition, "record", refuse)
    monkeypatch.setattr(composition, "execute_plan", refuse)


@pytest.mark.parametrize("name", ["unload", "stack3"])
@pytest.mark.parametrize("extra, message", [
    (["--episodes", "0", "--demos", "1"], "episodes: expected an integer > 0, got 0"),
    (["--episodes", "-1"], "episodes: expected an integer > 0, got -1"),
    (["--demos", "0"], "demos: expected an integer > 0, got 0"),
    (["--demos", "-2", "--episodes", "3"], "demos: expected an integer > 0, got -2"),
    (["--method", "bogus"], "method: expected one of ["),
    (["--seed", "-1"], "seed: expected a non-negative integer, got -1"),
    (["--seed", str(2 ** 32)], "seed: episode 9 would be placed from seed 4294968305"),
])
def test_a_bad_option_is_one_line_before_anything_is_recorded(name, extra, message, cli, no_recording,
                                                              tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = cli("experiment", name, *extra)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and f"skillbank experiment {name}: error: {message}" in err, err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("options, match", [
    ({"episodes": 0}, r"^episodes: expected an integer > 0, got 0$"),
    ({"demos": 0}, r"^demos: expected an integer > 0, got 0$"),
    ({"episodes": 1.5}, r"^episodes: expected an integer > 0, got 1\.5$"),
    ({"method": "bogus"}, r"^method: expected one of \[.*'lte'.*'replay'\], got 'bogus'$"),
    ({"seed": 1.0}, r"^seed: expected a non-negative integer, got 1\.0$"),
    ({"replan": "yes"}, r"^replan: expected True or False, got 'yes'$"),
    ({"planner": "rrt"}, r"^planner: expected one of \['ompl', 'none'\], got 'rrt'$"),
])
def test_the_api_checks_them_first_too(options, match, no_recording, tmp_path):
    kwargs = {"episodes": 2, "seed": 0, "demos": 1, "method": "lte", **options}
    with pytest.raises(ValueError, match=match):
        composition_experiment("stack3", folder=tmp_path, **kwargs)
    with pytest.raises(ValueError, match=match):
        check_options("unload", **kwargs)
    assert list(tmp_path.iterdir()) == []


def test_good_options_come_back_checked():
    assert check_options("unload", episodes=3, seed=5, demos=2, method="replay") == {
        "episodes": 3, "seed": 5, "demos": 2, "method": "replay", "replan": False, "workers": None,
        "scheduler": None, "robot": "UR5e", "record_robot": "UR5e", "planner": "ompl"}


@pytest.mark.parametrize("seed", ["-1", str(2 ** 32)])
def test_rail_refuses_a_bad_seed_before_reading(seed, cli, tmp_path):
    # an empty folder: were the seed checked after the data, the message would be about the data
    code, out, err = cli("experiment", "rail", "--data", tmp_path, "--seed", seed)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert f"error: random_state: expected None or an integer in [0, 2^32 - 1] (--seed), got {seed}" in err
