"""robosuite's set-up log stays off stderr unless asked for (``-v``): one import helper, used everywhere."""

from __future__ import annotations

import ast
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MISSING = importlib.util.find_spec("robosuite") is None and not os.environ.get("CI")  # CI has the extra
needs_robosuite = pytest.mark.skipif(MISSING, reason="robosuite is not installed (pip install -e '.[sim]')")


def _stderr_of(code: str) -> str:
    """stderr of a new interpreter running ``code`` (robosuite logs only at its first import)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env,
                          cwd=ROOT, check=True)
    return done.stderr


@needs_robosuite
def test_import_and_environment_say_nothing_on_stderr():
    # the import (macro file, robosuite_models, mink) and an environment made (controller INFO lines)
    err = _stderr_of("from skillbank.io import import_robosuite\n"
                     "suite = import_robosuite()\n"
                     "env = suite.make('Lift', robots='UR5e', has_renderer=False,"
                     " has_offscreen_renderer=False, use_camera_obs=False)\n"
                     "env.close()\n")
    assert err == ""


@needs_robosuite
def test_verbose_lets_its_log_through():
    # what `-v` does (cli._options.verbose_logging): the root logger at INFO
    err = _stderr_of("import logging\nlogging.basicConfig(level=logging.INFO)\n"
                     "from skillbank.io import import_robosuite\nimport_robosuite()\n")
    assert "robosuite WARNING" in err and "No private macro file found" in err


def _imports_robosuite(tree) -> list[int]:
    """Lines of ``import robosuite`` (the package itself, whose import logs) in a module's syntax tree."""
    return [node.lineno for node in ast.walk(tree)
            if isinstance(node, ast.Import) and any(a.name == "robosuite" for a in node.names)]


def test_robosuite_is_imported_through_the_helper_only():
    found = {str(path.relative_to(ROOT)): lines for path in sorted((ROOT / "skillbank").rglob("*.py"))
             if (lines := _imports_robosuite(ast.parse(path.read_text())))}
    assert list(found) == [os.path.join("skillbank", "io", "_robosuite_raw.py")], found


def test_the_check_finds_a_bare_import():
    assert _imports_robosuite(ast.parse("def f():\n    import os, robosuite\n")) == [2]
    assert _imports_robosuite(ast.parse("from robosuite.models import arenas\n")) == []
