"""The commands that only read, write or copy a library start without scikit-learn, scipy or a simulator.

Importing scikit-learn costs about 0.7 s and scipy, matplotlib and MuJoCo more; ``skillbank library list``
needs none of them (it took 1.3 s, the docs runner runs it dozens of times). Each command runs in a
fresh interpreter, so what it imports is what that command needs; the child reports ``sys.modules``
at exit, ``--help`` (which exits through SystemExit) included.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.io import write_csv

ROOT = Path(__file__).resolve().parents[2]
#: What no light command may import: scikit-learn, scipy, the plots, the simulators, the web view.
HEAVY = ("sklearn", "scipy", "matplotlib", "mujoco", "robosuite", "plotly")

# Runs the command line as ``python -m skillbank.cli`` would and writes the heavy packages it imported.
_PROBE = (
    "import atexit, json, sys\n"
    f"HEAVY = set({HEAVY!r})\n"
    "atexit.register(lambda: sys.stderr.write('\\nHEAVY ' + json.dumps(sorted(\n"
    "    {m.split('.')[0] for m in sys.modules} & HEAVY)) + '\\n'))\n"
    "from skillbank.cli._main import main\n"
    "sys.exit(main(sys.argv[1:]))\n"
)


def _heavy(args, cwd) -> list:
    """The heavy packages ``skillbank ARGS`` imported in a fresh interpreter; the command must succeed."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-c", _PROBE, *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith("HEAVY "), proc.stderr
    return json.loads(last[len("HEAVY "):])


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    """A clustered library of three 2-D demonstrations, one primitive each (made in this process)."""
    from skillbank.pipeline import Library

    folder = tmp_path_factory.mktemp("light")
    t = np.linspace(0.0, 1.0, 40)
    with Library(folder / "lib.sqlite") as lib:
        lib.add_many([Demonstration.from_array(np.column_stack([t, a * t]), t) for a in (1.0, 1.1, 1.2)],
                     segment=False)
        lib.cluster()
    (folder / "move.pddl").write_text("(:action move :parameters () :effect (moved))", encoding="utf-8")
    write_csv(Demonstration.from_array(np.column_stack([t, 1.3 * t]), t), folder / "more.csv")
    return folder


@pytest.mark.parametrize("args", [
    ["--help"],
    ["--version"],
    ["library", "--help"],
    ["library", "add", "--help"],
    ["library", "init", "new.sqlite"],
    ["library", "list", "lib.sqlite"],
    ["library", "list", "lib.sqlite", "--json"],
    ["library", "export", "lib.sqlite", "exported"],
    ["library", "copy", "lib.sqlite", "copied.sqlite"],
    ["library", "label", "lib.sqlite", "move", "--cluster", "0"],
    ["library", "describe", "lib.sqlite", "move"],
], ids=" ".join)
def test_a_light_command_imports_no_heavy_package(library, args):
    assert _heavy(args, library) == []


def test_the_work_still_imports_what_it_needs(library):
    # The probe sees imports: an add that cuts and assigns a demonstration needs scikit-learn and scipy.
    assert {"sklearn", "scipy"} <= set(_heavy(["library", "add", "lib.sqlite", "more.csv"], library))


def test_a_failing_light_command_is_reported(library):
    # The probe's own check: a command that fails is a failure of the test, not an empty import list.
    with pytest.raises(AssertionError, match="no such file|does not exist|not found"):
        _heavy(["library", "list", "missing.sqlite"], library)
