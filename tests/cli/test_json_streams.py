"""Warnings and log lines, skillbank's and its libraries', go to stderr, never into ``--json`` (41)."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = str(Path(__file__).resolve().parents[2])


def _run(*argv, code=None, timeout=300):
    env = {**os.environ, "PYTHONPATH": ROOT, "PYTHONWARNINGS": "default"}
    command = [sys.executable, "-c", code, *map(str, argv)] if code else \
        [sys.executable, "-m", "skillbank.cli", *map(str, argv)]
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=timeout,
                          stdin=subprocess.DEVNULL)
    return done.returncode, done.stdout, done.stderr


# A command whose library warns through each channel a library may use: warnings, logging, a logger with
# its own handler (as robosuite's), and a message that the command itself says on stderr.
WARNING_LIBRARY = """
import logging, sys, warnings
import skillbank.pipeline as pipeline
from skillbank.cli._main import main

own = logging.getLogger("some_library")
own.addHandler(logging.StreamHandler())
summary = pipeline.Library.summary

def noisy(self, *args, **kwargs):
    warnings.warn("a library's UserWarning", UserWarning, stacklevel=1)
    logging.getLogger("skillbank.test").warning("a warning logged without a handler")
    own.warning("a warning of a library with its own handler")
    return summary(self, *args, **kwargs)

pipeline.Library.summary = noisy
sys.exit(main(sys.argv[1:]))
"""


def test_library_warnings_are_on_stderr_and_the_json_stays_json(tmp_path):
    lib = tmp_path / "lib.db"
    assert _run("library", "init", lib)[0] == 0
    code, out, err = _run("library", "list", lib, "--json", code=WARNING_LIBRARY)
    assert code == 0, err
    json.loads(out)  # stdout is the JSON document and nothing else
    for text in ("a library's UserWarning", "a warning logged without a handler",
                 "a warning of a library with its own handler"):
        assert text in err and text not in out


def test_a_command_note_is_on_stderr(data_dir):
    code, out, err = _run("segment", data_dir / "seed" / "r_shape.h5", "--json")
    assert code == 0, err
    assert json.loads(out)["n_demos"] == 5
    assert "holds 5 demonstrations; segmenting demonstration 0" in err


def test_robosuites_warnings_stay_out_of_the_json(tmp_path):
    if importlib.util.find_spec("robosuite") is None:  # not imported here: its import logs
        pytest.skip("needs robosuite (skillbank[sim])")
    code, out, err = _run("sim", "record", "robosuite:Lift", "--episodes", "1", "--out", tmp_path / "r.hdf5",
                          "--json")
    assert code == 0, err
    assert json.loads(out)["episodes"] == 1 and out.count("\n") == 1
    # robosuite's set-up log (no macro file, optional robots, controller files) is not the command's output
    # (io.import_robosuite turns its logger off): nowhere, and never in the JSON
    assert "WARNING" not in out and "[robosuite" not in err
