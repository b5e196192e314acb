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
        return {"out": str(out), "summary": str(Path(out) / "summary.md"), "reuse": []}


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
