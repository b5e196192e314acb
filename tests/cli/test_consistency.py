"""One consistent command line: help and ``--json`` everywhere, ``--version``, errors that name the
command, a quiet end when the reader closes the pipe, progress only for a person watching."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import skillbank
import skillbank.io as sio
from skillbank.cli import build_parser, main
from skillbank.cli._main import leaf_parsers

COMMANDS = leaf_parsers(build_parser())
REPO = Path(__file__).resolve().parents[2]


def test_the_walk_finds_every_command():
    assert {"skillbank segment", "skillbank demo", "skillbank cluster", "skillbank edit",
            "skillbank experiment rail", "skillbank library add", "skillbank library reuse"} <= set(COMMANDS)
    assert "skillbank library" not in COMMANDS  # a group, not a command


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_takes_json(name):
    options = {s for a in COMMANDS[name]._actions for s in a.option_strings}
    assert "--json" in options, f"{name} has no --json"


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_argument_has_help(name):
    missing = [a.dest for a in COMMANDS[name]._actions
               if not isinstance(a, argparse._HelpAction) and not (a.help or "").strip()]
    assert missing == [], f"{name}: no help text for {missing}"


def test_every_command_and_group_is_described():
    def walk(parser):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                described = {c.dest: c.help for c in action._choices_actions}
                for name, child in action.choices.items():
                    assert (described.get(name) or "").strip(), f"{child.prog} has no help line"
                    walk(child)

    walk(build_parser())


def test_help_says_what_sizes_accept():
    segment = COMMANDS["skillbank segment"]
    helps = {a.dest: a.help for a in segment._actions}
    assert "seconds" in helps["grace"] and "seconds" in helps["window"] and "seconds" in helps["min_size"]
    assert "sampling" in helps["mode"]
    assert "4 % of the length" in segment.format_help().replace("\n", " ").replace("  ", " ")


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out == f"skillbank {skillbank.__version__}\n"


@pytest.mark.parametrize(("argv", "prefix"), [
    (["experiment", "rail", "--data", "/no/such/folder"], "skillbank experiment rail: error: data_dir: "),
    (["library", "list", "/no/such/lib.db"], "skillbank library list: error: library "),
    (["cluster", "/no/such/X.npy"], "skillbank cluster: error: input: "),
])
def test_errors_name_the_command_that_ran(cli, argv, prefix):
    code, out, err = cli(*argv)
    assert code == 2 and out == "" and err.startswith(prefix) and err.count("\n") == 1, err


@pytest.mark.parametrize(("argv", "prefix"), [
    (["experiment", "rail", "--data", ".", "--mode", "quick"],
     "skillbank experiment rail: error: argument --mode: invalid choice: 'quick'"),
    (["library", "add"], "skillbank library add: error: the following arguments are required: db"),
    (["segment", "x.csv", "--window", "0s"], "skillbank segment: error: argument --window: expected"),
])
def test_usage_errors_name_the_command(capsys, argv, prefix):
    with pytest.raises(SystemExit) as info:
        main(argv)
    out, err = capsys.readouterr()
    assert info.value.code == 2 and out == "" and err.startswith(prefix) and err.count("\n") == 1, err


def _pipe_into_head(argv, head):
    """Run ``python -m skillbank.cli argv | head``; return (status, stderr) of skillbank."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    writer = subprocess.Popen([sys.executable, "-m", "skillbank.cli", *map(str, argv)], cwd=REPO, env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    reader = subprocess.Popen(["head", *head], stdin=writer.stdout, stdout=subprocess.PIPE)
    writer.stdout.close()  # head holds the only read end: when it exits, the pipe is closed
    first = reader.communicate(timeout=120)[0]
    err = writer.stderr.read().decode()
    writer.stderr.close()
    return writer.wait(timeout=120), err, first


def test_a_closed_pipe_ends_quietly(tmp_path):
    # ~0.8 MB of JSON: far more than a pipe holds, so skillbank is still writing when head exits
    t = np.linspace(0.0, 1.0, 20_000)
    path = sio.write_csv(skillbank.Demonstration.from_array(np.c_[np.cos(t), np.sin(t)], t=t),
                         tmp_path / "long.csv")
    status, err, first = _pipe_into_head(["edit", path, "--json"], ["-c", "6"])
    assert first == b'{"t": '
    assert (status, err) == (0, "")
    # several lines, the reader stops after one; and --help
    status, err, first = _pipe_into_head(["edit", path, "--goal", "0.5,0.9"], ["-1"])
    assert first.startswith(b"lte: 1 demonstration(s)") and (status, err) == (0, "")
    status, err, first = _pipe_into_head(["--help"], ["-1"])
    assert first.startswith(b"usage: skillbank") and (status, err) == (0, "")


def test_other_write_errors_still_fail(cli, tmp_path, monkeypatch):
    """Only a closed pipe is quiet: a full disk is an error."""

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    demo = skillbank.Demonstration.from_array(np.c_[np.linspace(0, 1, 50), np.linspace(0, 2, 50)])
    path = sio.write_npz(demo, tmp_path / "d.npz")
    monkeypatch.setattr(np, "savetxt", full)
    code, out, err = cli("edit", path, "--out", tmp_path / "o.csv")
    assert code == 2 and err == "skillbank edit: error: [Errno 28] No space left on device\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.npz"]  # nothing written half


class _Recorder:
    def __init__(self):
        self.kwargs = None

    def __call__(self, out, **kwargs):
        self.kwargs = kwargs
        return {"out": str(out), "summary": str(Path(out) / "summary.md"), "reuse": [], "seconds": 0.5,
                "timing": []}


@pytest.mark.parametrize(("json_flag", "tty", "progress"), [
    ([], True, True), (["--json"], True, False), ([], False, False), (["--json"], False, False),
])
def test_demo_progress_only_for_a_person_watching(cli, monkeypatch, tmp_path, json_flag, tty, progress):
    import skillbank.experiments

    job = _Recorder()
    monkeypatch.setattr(skillbank.experiments, "run_library_demo", job)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: tty)
    code, out, _ = cli("demo", "--out", tmp_path, *json_flag)
    assert code == 0 and job.kwargs["progress"] is progress
    if json_flag:
        assert json.loads(out)["out"] == str(tmp_path)
    else:  # the total the run measured, on the terminal
        assert "done in 0.5 s (each part's time: " in out


# --- one coherent command line (issue 44, item 2) ---

def _long_options(parser) -> dict:
    return {o: a for a in parser._actions for o in a.option_strings if o.startswith("--")}


#: Options whose name is shared but whose default or choices legitimately differ, by command, with the words
#: of that command's help that say why. Any other disagreement fails the walk below.
DIFFER = {
    "--episodes": {"skillbank plan": "one plan carried out",
                   "skillbank library add": "episodes to read", "skillbank segment": "episodes to read"},
    "--method": {"skillbank library reuse": "learns from all of them"},
    "--features": {"skillbank library cluster": "the library stores its featuriser"},
    "--format": {"skillbank segment": "segment file format"},
    "--mode": {"skillbank experiment rail": "the paper's representatives"},
    "--out": {"skillbank demo": "default demo_output"},
    "--robot": {"skillbank edit": "add a 'joints' stream", "skillbank library reuse": "add a 'joints' stream",
                "skillbank plan": "add a 'joints' stream"},
    "--seed": {name: "sampl" for name in ("skillbank library reuse", "skillbank plan", "skillbank segment",
                                           "skillbank library add")},
    "--stretch": {"skillbank library cluster": "default 1.2"},
}


def _signature(option, action):
    default = action.default
    if option in ("--robot", "--record-robot") and isinstance(default, str):
        default = default.lower()  # robot names are case-insensitive
    return repr(default), repr(None if action.choices is None else tuple(action.choices))


def _shared():
    by_option: dict = {}
    for name, parser in COMMANDS.items():
        for option, action in _long_options(parser).items():
            by_option.setdefault(option, {})[name] = action
    return {o: d for o, d in by_option.items() if len(d) > 1}


@pytest.mark.parametrize("option", sorted(_shared()))
def test_an_option_shared_by_commands_has_one_default_and_one_set_of_choices(option):
    commands = _shared()[option]
    explained = DIFFER.get(option, {})
    for name, words in explained.items():
        helps = " ".join(commands[name].help.split())
        assert words in helps, f"{name} {option}: its help should say why it differs ({words!r}): {helps}"
    usual = {_signature(option, a) for name, a in commands.items() if name not in explained}
    assert len(usual) == 1, f"{option} differs between commands: " + "; ".join(
        f"{name}: {_signature(option, a)}" for name, a in sorted(commands.items()) if name not in explained)


def test_the_robosuite_commands_agree_on_episodes_and_method():
    assert {COMMANDS[n].get_default("episodes") for n in ("skillbank sim record", "skillbank sim evaluate",
                                                          "skillbank experiment unload",
                                                          "skillbank experiment stack3")} == {10}
    assert {COMMANDS[n].get_default("method") for n in ("skillbank edit", "skillbank sim evaluate",
                                                         "skillbank plan", "skillbank experiment unload")} \
        == {"lte"}


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_with_out_has_force(name):
    options = _long_options(COMMANDS[name])
    assert ("--out" in options) == ("--force" in options), name


@pytest.mark.parametrize("name", sorted(n for n in COMMANDS if "--robot" in _long_options(COMMANDS[n])))
def test_robot_names_are_case_insensitive_in_every_command(name):
    for option in ("--robot", "--record-robot"):
        action = _long_options(COMMANDS[name]).get(option)
        if action is None:
            continue
        assert action.choices is None, f"{name} {option}: choices would be case-sensitive"
        assert "any case" in action.help, f"{name} {option}: the help should say any case is taken"


def test_robot_names_resolve_in_any_case():
    from skillbank.robots import robot_model
    from skillbank.simulation._robosuite import robosuite_robot

    for names in (("panda", "Panda", "PANDA"), ("ur5e", "UR5e", "Ur5E")):
        assert len({robosuite_robot(n) for n in names}) == 1
        assert len({repr(robot_model(n)) for n in names}) == 1


@pytest.mark.parametrize("name", ["skillbank sim record", "skillbank sim evaluate", "skillbank plan",
                                  "skillbank experiment unload", "skillbank experiment stack3"])
def test_every_robosuite_command_is_quiet_unless_verbose(name):
    action = _long_options(COMMANDS[name])["--verbose"]
    assert action.default is False and "robosuite's, MuJoCo's and Dask's log lines" in action.help


def test_sim_groups_run_record_and_evaluate_and_says_so(capsys):
    assert {"skillbank sim run", "skillbank sim record", "skillbank sim evaluate"} <= set(COMMANDS)
    with pytest.raises(SystemExit):
        main(["sim", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for words in ("'run' replays a joint trajectory", "'record' writes demonstrations", "'evaluate' runs"):
        assert words in text
    # sim run and its old name take the same options
    assert _long_options(COMMANDS["skillbank sim run"]).keys() \
        == _long_options(COMMANDS["skillbank simulate"]).keys()


def test_simulate_is_an_alias_that_says_to_use_sim_run(cli, tmp_path):
    from skillbank.cli._simulate import DEPRECATED

    scene = tmp_path / "scene.json"
    scene.write_text("{}")
    code, out, err = cli("simulate", tmp_path / "none.csv", "--scene", scene)
    lines = err.splitlines()
    assert code == 2 and out == "" and len(lines) == 2, err
    assert lines[0] == DEPRECATED
    assert DEPRECATED == "skillbank simulate: deprecated, use 'skillbank sim run' (the same options)"
    assert lines[1].startswith("skillbank simulate: error: trajectory")
    code, out, err = cli("sim", "run", tmp_path / "none.csv", "--scene", scene)
    assert code == 2 and err.startswith("skillbank sim run: error: trajectory") and err.count("\n") == 1, err


def test_experiment_says_which_experiment_is_the_papers(capsys):
    with pytest.raises(SystemExit):
        main(["experiment", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "rail the paper's experiment" in text and "from the paper" not in text
    assert text.count("not in the paper") == 2  # unload and stack3


# --- one way to name a task ---

@pytest.mark.parametrize("argv", [
    ["sim", "record", "robosuite:Nope", "--out", "x.hdf5"],
    ["sim", "record", "--env", "robosuite:Nope", "--out", "x.hdf5"],
])
def test_sim_record_takes_the_task_as_env_or_positional(cli, tmp_path, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    code, out, err = cli(*argv)
    assert code == 2, err
    assert err.startswith("skillbank sim record: error: env: the recorder knows robosuite tasks"), err
    assert list(tmp_path.iterdir()) == []


def test_sim_record_refuses_no_task_and_two(cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, err = cli("sim", "record", "--out", "x.hdf5")
    assert code == 2 and "env: expected the task, --env robosuite:TASK" in err
    code, _, err = cli("sim", "record", "robosuite:Lift", "--env", "robosuite:Stack", "--out", "x.hdf5")
    assert code == 2 and "env: the task is given twice" in err and err.count("\n") == 1


def test_plan_takes_env_as_scene_robosuite(cli, tmp_path):
    db = tmp_path / "lib.db"
    assert cli("library", "init", db)[0] == 0
    said = []
    for argv in (["--env", "robosuite:Stack3"], ["--scene", "robosuite:Stack3"]):
        code, out, err = cli("plan", db, *argv)
        assert code == 2 and err.count("\n") == 1, err
        said.append(err)
    assert said[0] == said[1] and "is a robosuite task: its plan is carried out in the simulation" in said[0]
    code, _, err = cli("plan", db, "--env", "robosuite:Stack3", "--scene", "s.json")
    assert code == 2 and "env: give --env robosuite:Stack3 or --scene s.json, not both" in err
    code, _, err = cli("plan", db)
    assert code == 2 and "scene: expected --scene FILE (a scene file) or --env robosuite:TASK" in err
    code, _, err = cli("plan", db, "--env", "s.json")
    assert code == 2 and "env: expected robosuite:TASK" in err


# --- --out: refused when there, unless --force ---

def _line():
    return skillbank.Demonstration.from_array(np.c_[np.linspace(0, 1, 50), np.linspace(0, 2, 50)])


def _there(path):
    path.write_text("mine\n")
    return path


@pytest.mark.parametrize("argv", [
    ["edit", "{demo}", "--goal", "1,1", "--out", "{there}"],
    ["library", "reuse", "{db}", "--skill", "x", "--out", "{there}"],
    ["plan", "{db}", "--scene", "s.json", "--out", "{there}"],
    ["sim", "record", "--env", "robosuite:Lift", "--out", "{there}"],
    ["segment", "{demo}", "--out", "{folder}"],
    ["demo", "--out", "{folder}"],
    ["library", "view", "{db}", "--out", "{folder}"],
    ["experiment", "stack3", "--out", "{folder}"],
])
def test_an_output_that_is_there_is_refused_unless_force(cli, tmp_path, argv):
    demo = sio.write_npz(_line(), tmp_path / "d.npz")
    db = tmp_path / "lib.db"
    assert cli("library", "init", db)[0] == 0
    folder = tmp_path / "folder"
    folder.mkdir()
    _there(folder / "d_segment00.npz")  # an earlier run's segment of d.npz; for the others, something there
    there = _there(tmp_path / "there.out")
    before = sorted(p.name for p in tmp_path.rglob("*"))
    argv = [a.format(demo=demo, db=db, there=there, folder=folder) for a in argv]
    code, out, err = cli(*argv)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert ": error: out: " in err and "exists; give --force to overwrite it" in err
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # nothing written, nothing half-written
    assert there.read_text() == "mine\n"


def test_force_overwrites_and_a_new_or_empty_output_needs_none(cli, tmp_path):
    demo = sio.write_npz(_line(), tmp_path / "d.npz")
    there = _there(tmp_path / "o.csv")
    code, _, err = cli("edit", demo, "--goal", "1,1", "--out", there, "--force")
    assert code == 0 and there.read_text() != "mine\n", err
    code, _, err = cli("edit", demo, "--goal", "1,1", "--out", tmp_path / "new.csv")
    assert code == 0, err
    (tmp_path / "empty").mkdir()
    code, _, err = cli("segment", demo, "--out", tmp_path / "empty")
    assert code == 0, err


# --- experiment --out DIR, its progress and its report ---

def _fake_composition(calls):
    def run(name, *, folder=None, progress=None, paths=False, **kwargs):
        calls.append({"folder": folder, "paths": paths, **kwargs})
        if progress is not None:
            progress("record", 1, 2, None)
            progress("episodes", 1, 1, 1)
        if folder is not None:
            (Path(folder) / "Stack.hdf5").write_text("demonstrations")
            (Path(folder) / f"{name}.db").write_text("library")
        steps = [{"action": "pick", "args": ["cubeB"], "ok": True},
                 {"action": "place", "args": ["cubeB", "cubeA"], "ok": True}]
        row = {"seed": 1000, "success": True, "plan": ["(place cubeB cubeA)", "(pick cubeB)"], "steps": steps,
               **({"path": [[0, 0, 0]], "step_starts": [0]} if paths else {})}
        return {"experiment": name, "scene": "robosuite:Stack3", "robot": "UR5e", "recorded_on": ["UR5e"],
                "notes": [], "method": "lte", "seed": 0, "demos": 1, "episodes": 1, "successes": 1,
                "success_rate": 1.0, "interval": [0.2, 1.0], "failures": {}, "per_episode": [row],
                "labelled": {"pick": 1, "place": 2},
                "library": {"demonstrations": 1, "primitives": 4, "skills": 2}}
    return run


def test_experiment_out_keeps_what_it_recorded_and_built(cli, tmp_path, monkeypatch):
    import skillbank.experiments
    import skillbank.plotting

    calls = []
    monkeypatch.setattr(skillbank.experiments, "composition_experiment", _fake_composition(calls))
    monkeypatch.setattr(skillbank.plotting, "plot_composed",
                        lambda row, path, title: (Path(path).write_text("figure"), Path(path))[1])
    out = tmp_path / "stack"
    code, text, err = cli("experiment", "stack3", "--episodes", "1", "--out", out)
    assert code == 0, err
    assert calls[0]["paths"] is True and Path(calls[0]["folder"]).parent == tmp_path
    assert sorted(p.name for p in out.iterdir()) == ["Stack.hdf5", "stack3.db", "stack3.json", "stack3.png"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stack"]  # its work folder is gone
    assert "path" not in json.loads((out / "stack3.json").read_text())["per_episode"][0]
    assert f"  wrote {out / 'stack3.db'}" in text.splitlines()
    # the order carried out, not the planner's
    assert "  seed 1000: carried out (pick cubeB) (place cubeB cubeA): success" in text.splitlines()
    # a file is no folder, --force or not
    code, _, err = cli("experiment", "stack3", "--out", out / "stack3.json", "--force")
    assert code == 2 and "out: expected a folder to keep the experiment in" in err and len(calls) == 1
    # without --out nothing is kept
    code, _, err = cli("experiment", "stack3", "--episodes", "1")
    assert code == 0 and calls[1]["folder"] is None and calls[1]["paths"] is False


def test_experiment_shows_progress_with_successes(cli, monkeypatch):
    import skillbank.experiments

    monkeypatch.setattr(skillbank.experiments, "composition_experiment", _fake_composition([]))
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    code, _, err = cli("experiment", "stack3", "--episodes", "1")
    assert code == 0
    assert "recording" in err and "episodes" in err and "successes=1" in err


def test_verbose_lets_robosuites_log_through_and_quiet_is_the_default(monkeypatch):
    import argparse
    import logging

    from skillbank.cli._options import verbose_logging
    from skillbank.io import import_robosuite

    pytest.importorskip("robosuite")
    root, logger = logging.getLogger(), logging.getLogger("robosuite_logs")
    monkeypatch.setattr(root, "level", logging.WARNING)
    monkeypatch.setattr(logger, "disabled", False)
    verbose_logging(argparse.Namespace(verbose=False))
    import_robosuite()
    assert logger.disabled and root.level == logging.WARNING
    logger.disabled = False
    verbose_logging(argparse.Namespace(verbose=True))
    import_robosuite()
    assert not logger.disabled and root.level == logging.INFO
